"""SPEC 13's needle: the capsule, the ball of radius R centred at c(t) with the half-infinite
cylinder {r <= R, z >= c_z(t)} above it, its axis along z (a 3D tool; its force in N).

On a meridian (r, z) of a body of revolution about the same axis, the capsule is the
half-stadium whose ray points along +z (`meridian`): the axisymmetric truth poses it there."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from tissuebench.meshes.tools.half_stadium import HalfStadium
from tissuebench.meshes.tools.tool import Tool


@dataclass(frozen=True)
class Capsule(Tool):
    """The capsule of radius `radius` (m) on the axis x = y = 0, its ray along +z from c(t)."""

    motion: Callable[[float], tuple[np.ndarray, np.ndarray]] = field(compare=False)
    kind: str = "capsule"
    dim: int = 3
    axis: int = 2

    @property
    def words(self) -> str:
        return (
            "the capsule S(t): the ball of radius R centred at c(t), with the half-infinite "
            "cylinder {(x - c_x)^2 + (y - c_y)^2 <= R^2, z >= c_z(t)} above it"
        )

    def meridian(self) -> HalfStadium:
        """The capsule on the meridian plane (r, z), m: a half-stadium along +z whose centre
        is (0, c_z(t))."""
        c0, motion = self.c0, self.motion

        def meridian_motion(t: float) -> tuple[np.ndarray, np.ndarray]:
            g, dg = motion(t)
            return np.array([0.0, g[2]]), np.array([0.0, dg[2]])

        return HalfStadium(
            radius=self.radius, c0=(0.0, c0[2]), motion=meridian_motion, scale=self.scale, axis=1
        )
