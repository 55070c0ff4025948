"""proleg.report"""
