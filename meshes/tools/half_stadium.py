"""SPEC 12's needle: the half-stadium, the disc of radius R centred at c(t) with the strip
{x >= c_x(t), |y - c_y| <= R} to its right (a 2D tool; its force per unit thickness, N/m)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from tissuebench.meshes.tools.tool import Tool


@dataclass(frozen=True)
class HalfStadium(Tool):
    """The half-stadium of radius `radius` (m) whose ray points along +x from c(t)."""

    motion: Callable[[float], tuple[np.ndarray, np.ndarray]] = field(compare=False)
    kind: str = "half-stadium"
    dim: int = 2
    axis: int = 0

    @property
    def words(self) -> str:
        return (
            "the half-stadium S(t): the disc of radius R centred at c(t), with the strip "
            "{x >= c_x(t), |y - c_y(t)| <= R} to its right"
        )
