"""proleg.io"""
