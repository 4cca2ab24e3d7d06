"""What a rigid tool is (SPEC 12 and 13): a shape that moves, written once for numpy and UFL.

A tool is the set S(t) of points within `radius` of a ray that starts at its centre c(t) and
points along +`axis`: in 2D the half-stadium of SPEC 12 (the ray along +x), in 3D the capsule
of SPEC 13 (the ray along +z). Its signed distance (m, negative inside) is the distance to the
ray minus the radius; its outward normal is that distance's gradient. Both are written once, as
functions of the point's components with an `Ops` of numpy's (grading, explicit loops,
simulators) or of UFL's (our forms), so that the two can never differ.

The centre moves as c(t) = c0 + s g(t), g(t) the benchmark's motion at load scale 1 (m) and s
the load scale. A benchmark builds its tool (its entry's `tool`, meshes/benchmark.py) and every
reader asks the tool: nothing else knows the shape.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

AXES = "xyz"


@dataclass(frozen=True)
class Ops:
    """The arithmetic a shape's formulas use, numpy's or UFL's."""

    where: Callable[[Any, Any, Any], Any]  # where(condition, a, b)
    ge: Callable[[Any, Any], Any]  # a >= b
    abs: Callable[[Any], Any]
    sign: Callable[[Any], Any]
    norm: Callable[[Sequence[Any]], Any]  # the Euclidean norm of components
    positive: Callable[[Any], Any]  # max(r, tiny): a norm safe to divide by


def _numpy_norm(components: Sequence[Any]) -> Any:
    return (
        np.hypot(*components) if len(components) == 2 else np.sqrt(sum(c * c for c in components))
    )


NUMPY = Ops(
    where=np.where,
    ge=np.greater_equal,
    abs=np.abs,
    sign=np.sign,
    norm=_numpy_norm,
    positive=lambda r: np.maximum(r, 1e-300),
)


def ufl_ops() -> Ops:
    """The Ops of UFL (imported here: the numpy side needs no UFL)."""
    import ufl

    return Ops(
        where=ufl.conditional,
        ge=ufl.ge,
        abs=abs,
        sign=ufl.sign,
        norm=lambda components: ufl.sqrt(sum(c * c for c in components)),
        positive=lambda r: r,
    )


@dataclass(frozen=True)
class Tool:
    """A rigid tool: the points within `radius` (m) of the ray from its centre c(t) along
    +`axis`, in `dim` dimensions; c(t) = c0 + scale g(t), `motion(t)` -> (g, g') in m and m/s
    at load scale 1. Subclasses name the shape (`kind`) and say it in words (`words`)."""

    radius: float  # m
    c0: tuple[float, ...]  # m, the centre at t = 0
    motion: Callable[[float], tuple[np.ndarray, np.ndarray]] = field(compare=False)
    scale: float = 1.0  # the load scale s
    kind: str = "tool"
    dim: int = 2
    axis: int = 0

    @property
    def force_unit(self) -> str:
        """The unit of the force on the tool: per unit thickness in 2D."""
        return "N/m" if self.dim == 2 else "N"

    def centre(self, t: float) -> np.ndarray:
        """c(t) = c0 + s g(t) (m) at time t (s)."""
        return np.asarray(self.c0, dtype=float) + self.scale * self.motion(t)[0]

    def velocity(self, t: float) -> np.ndarray:
        """c'(t) = s g'(t) (m/s) at time t (s), the right derivative."""
        return self.scale * np.asarray(self.motion(t)[1], dtype=float)

    # -- the shape, once: x and c as lists of components, ops numpy's or UFL's --------------
    def _parts(self, x: Sequence[Any], c: Any) -> tuple[Any, list[Any]]:
        along = x[self.axis] - c[self.axis]
        across = [x[i] - c[i] for i in range(self.dim) if i != self.axis]
        return along, across

    def distance(self, x: Sequence[Any], c: Any, ops: Ops) -> Any:
        """The signed distance (m, negative inside) from x to S with centre c: the distance
        to the ray {c + r e_axis, r >= 0} minus the radius."""
        along, across = self._parts(x, c)
        off = ops.abs(across[0]) if len(across) == 1 else ops.norm(across)
        return ops.where(ops.ge(along, 0), off, ops.norm([along, *across])) - self.radius

    def normal(self, x: Sequence[Any], c: Any, ops: Ops) -> list[Any]:
        """The unit outward normal of S at its point closest to x (the gradient of
        `distance`), as components."""
        along, across = self._parts(x, c)
        flank = ops.ge(along, 0)
        r = ops.positive(ops.norm([along, *across]))
        if len(across) == 1:
            side = [ops.sign(across[0])]
        else:
            off = ops.positive(ops.norm(across))
            side = [a / off for a in across]
        n, j = [], 0
        for i in range(self.dim):
            if i == self.axis:
                n.append(ops.where(flank, 0.0, along / r))
            else:
                n.append(ops.where(flank, side[j], across[j] / r))
                j += 1
        return n

    # -- numpy ------------------------------------------------------------------------------
    def signed_distance(self, points: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The signed distance (m) from each point (n, dim), m, to S centred at c (m)."""
        points = np.asarray(points, dtype=float)
        return self.distance([points[:, i] for i in range(self.dim)], c, NUMPY)

    def outward_normal(self, points: np.ndarray, c: np.ndarray) -> np.ndarray:
        """The unit outward normal (n, dim) of S centred at c (m) at its point closest to
        each point (n, dim), m."""
        points = np.asarray(points, dtype=float)
        return np.stack(self.normal([points[:, i] for i in range(self.dim)], c, NUMPY), axis=1)

    # -- UFL ----------------------------------------------------------------------------------
    def ufl_signed_distance(self, x: Any, c: Any) -> Any:
        """The signed distance (m) as a UFL expression of the point x and the centre c."""
        return self.distance([x[i] for i in range(self.dim)], c, ufl_ops())

    def ufl_outward_normal(self, x: Any, c: Any) -> Any:
        """The outward normal as a UFL vector of the point x and the centre c."""
        import ufl

        return ufl.as_vector(self.normal([x[i] for i in range(self.dim)], c, ufl_ops()))

    def outline(self, c: np.ndarray, length: float = 1.5) -> np.ndarray:
        """A 2D tool's outline (n, 2), m, centred at c (m): the half circle away from its ray
        and its two flanks, `length` (m) long along the ray (for figures)."""
        if self.dim != 2:
            raise ValueError("an outline is drawn for a 2D tool only")
        e = np.eye(2)[self.axis]  # along the ray
        n = np.eye(2)[1 - self.axis]  # across it
        angles = np.linspace(np.pi / 2, 3 * np.pi / 2, 91)
        arc = c + self.radius * (np.cos(angles)[:, None] * e + np.sin(angles)[:, None] * n)
        ends = [c + length * e - self.radius * n, c + length * e + self.radius * n]
        return np.vstack([arc, ends])

    # -- the export ---------------------------------------------------------------------------
    @property
    def words(self) -> str:
        return f"the points within R of the ray from the centre c(t) along +{AXES[self.axis]}"

    def shape(self) -> dict:
        """The tool's shape as the export states it (the JSON's `contact.shape`, SI units)."""
        a = AXES[self.axis]
        across = [AXES[i] for i in range(self.dim) if i != self.axis]
        ray = ", ".join("r" if i == self.axis else "0" for i in range(self.dim))
        if len(across) == 1:
            off = f"|x_{across[0]} - c_{across[0]}|"
            side = [f"sign(x_{across[0]} - c_{across[0]})"]
        else:
            off = "(" + " + ".join(f"(x_{b} - c_{b})^2" for b in across) + ")^(1/2)"
            side = [f"(x_{b} - c_{b}) / {off}" for b in across]
        parts = iter(side)
        flank = "(" + ", ".join("0" if i == self.axis else next(parts) for i in range(self.dim))
        flank += ")"
        return {
            "kind": self.kind,
            "dimension": self.dim,
            "words": self.words,
            "radius": self.radius,
            "axis": a,
            "signed_distance": f"g(x) = {off} - R where x_{a} >= c_{a}, else |x - c| - R "
            f"(m, negative inside): the distance from x to the ray {{c + ({ray}), r >= 0}} "
            "minus R",
            "outward_normal": f"n(x) = {flank} where x_{a} >= c_{a}, else (x - c) / |x - c|: the "
            "gradient of g, the outward normal of S at its point closest to x",
        }
