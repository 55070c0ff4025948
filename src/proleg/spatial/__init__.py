"""Rotations in Euler parameters (unit quaternions, scalar first) and helpers, in jnp and numpy."""

from .rotation import (
    A_of_p as A_of_p,
    G_of_p as G_of_p,
    L_of_p as L_of_p,
    skew as skew,
    p_from_matrix as p_from_matrix,
    euler_zyx_deg as euler_zyx_deg,
    frame_from_axis as frame_from_axis,
)
