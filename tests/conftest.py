"""Test configuration: float64 everywhere, strict dtype promotion where proleg allows it."""

import jax

jax.config.update("jax_enable_x64", True)
