"""Parts (rigid bodies) and markers: the description layer, plain Python and numpy."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ._validate import finite_array, finite_scalar, inertia_tensor, rotation


@dataclass(eq=False)
class Part:
    """A rigid body.

    Parameters
    ----------
    name : str
    mass : float [kg], > 0
    inertia : (3,) principal values or (3, 3) tensor [kg m^2], about the COM in part axes
    position : (3,) [m], centre of mass in the ground frame (initial / modelled pose)
    orientation : (3, 3) rotation matrix (part axes → ground) or unit quaternion (scalar first)
    velocity : (3,) [m/s], initial COM velocity in ground
    angular_velocity : (3,) [rad/s], initial angular velocity in ground components
    """

    name: str
    mass: float
    inertia: np.ndarray
    position: np.ndarray
    orientation: np.ndarray = field(default_factory=lambda: np.eye(3))
    velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    angular_velocity: np.ndarray = field(default_factory=lambda: np.zeros(3))
    is_ground: bool = False

    @classmethod
    def build(cls, name, mass, inertia, position, orientation=None, velocity=None, angular_velocity=None):
        mass = finite_scalar(f"Part '{name}' mass", mass, unit="kg")
        if not mass > 0:
            raise ModelError(f"Part '{name}' mass must be positive [kg], got {mass}. Give the part's mass in kg.")
        return cls(
            name=name,
            mass=mass,
            inertia=inertia_tensor(name, inertia),
            position=finite_array(f"Part '{name}' position", position, (3,)),
            orientation=np.eye(3) if orientation is None else rotation(f"Part '{name}' orientation", orientation),
            velocity=np.zeros(3) if velocity is None else finite_array(f"Part '{name}' velocity", velocity, (3,)),
            angular_velocity=np.zeros(3)
            if angular_velocity is None
            else finite_array(f"Part '{name}' angular_velocity", angular_velocity, (3,)),
        )

    def __repr__(self):
        return f"Part({self.name!r}, mass={self.mass:g} kg)"


@dataclass(eq=False)
class Marker:
    """A frame fixed to a part.

    ``local_position`` and ``local_orientation`` are in part axes relative to the part's COM;
    ``position``/``orientation`` are the ground-frame values at the modelled configuration.
    """

    name: str
    part: Part
    local_position: np.ndarray
    local_orientation: np.ndarray

    @property
    def position(self) -> np.ndarray:
        return self.part.position + self.part.orientation @ self.local_position

    @property
    def orientation(self) -> np.ndarray:
        return self.part.orientation @ self.local_orientation

    def __repr__(self):
        return f"Marker({self.name!r} on {self.part.name!r})"


def make_marker(name: str, part: Part, position, orientation=None) -> Marker:
    """A marker from ground-frame position/orientation at the modelled configuration."""
    pos = finite_array(f"Marker '{name}' position", position, (3,))
    R = np.eye(3) if orientation is None else rotation(f"Marker '{name}' orientation", orientation)
    Rb = part.orientation
    return Marker(name, part, Rb.T @ (pos - part.position), Rb.T @ R)
