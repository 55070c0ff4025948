"""proleg.identify"""
