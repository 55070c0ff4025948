"""proleg.solvers"""
