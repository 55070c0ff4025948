"""proleg.drives"""
