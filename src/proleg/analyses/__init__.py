"""proleg.analyses"""
