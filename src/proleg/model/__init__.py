"""1. DESCRIPTION: plain Python, mutable, named elements; no jax here."""
