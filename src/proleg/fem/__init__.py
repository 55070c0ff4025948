"""proleg.fem"""
