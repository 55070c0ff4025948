"""proleg.control"""
