"""proleg.cli"""
