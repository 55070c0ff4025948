"""proleg.robots"""
