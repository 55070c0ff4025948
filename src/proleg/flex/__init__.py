"""proleg.flex"""
