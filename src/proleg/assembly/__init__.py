"""proleg.assembly"""
