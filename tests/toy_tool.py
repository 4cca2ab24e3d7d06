"""A toy second 2D tool, defined here alone (issue 57 item 5): a rigid flat punch, the strip
{x >= c_x, |y - c_y| <= R} with a flat face at x = c_x, pushed into the contact block's right
edge as the needle is (c(t) = (1, 0.5) + s g(t), g the block's needle motion), and a benchmark
"punch" that poses it: the contact block with the punch in the needle's place.

`registered()` adds the benchmark to the registry (meshes.register) for the context's length;
everything the commands know of the punch is its Tool (its shape, written once for numpy and
UFL through the Tool's Ops) and the entry's tool, posing and export."""

from __future__ import annotations

import contextlib
import dataclasses
from typing import Any

import numpy as np

from tissuebench.meshes import get_entry, register, unregister
from tissuebench.meshes.benchmark import Benchmark
from tissuebench.meshes.tools import Tool
from tissuebench.meshes.tools.tool import Ops

NAME = "punch"
HALF_WIDTH = 0.1  # m, R: the punch's half-width, the needle's radius
EDGE = (1.0, 0.5)  # m: the middle of the block's right edge, where the punch's face starts


@dataclasses.dataclass(frozen=True)
class FlatPunch(Tool):
    """The flat punch of half-width `radius` (m): the strip {x >= c_x, |y - c_y| <= R}."""

    kind: str = "flat-punch"

    @property
    def words(self) -> str:
        return "the flat punch S(t): the strip {x >= c_x(t), |y - c_y(t)| <= R}, its face flat"

    def distance(self, x: Any, c: Any, ops: Ops) -> Any:
        """a = c_x - x (m, in front of the face), b = |y - c_y| - R (m, beside the strip): the
        distance to the strip outside it, max(a, b) inside."""
        a, b = c[0] - x[0], ops.abs(x[1] - c[1]) - self.radius
        beside = ops.where(ops.ge(a, 0), ops.where(ops.ge(b, 0), ops.norm([a, b]), a), b)
        return ops.where(ops.ge(b, 0), beside, ops.where(ops.ge(a, b), a, b))

    def normal(self, x: Any, c: Any, ops: Ops) -> list[Any]:
        """The gradient of `distance`: -e_x in front of the face, +-e_y beside the strip, the
        direction from the face's corner outside both."""
        a, b = c[0] - x[0], ops.abs(x[1] - c[1]) - self.radius
        s = ops.sign(x[1] - c[1])
        r = ops.positive(ops.norm([a, b]))
        n0 = ops.where(
            ops.ge(a, 0), ops.where(ops.ge(b, 0), -a / r, -1.0), ops.where(ops.ge(a, b), -1.0, 0.0)
        )
        n1 = ops.where(
            ops.ge(a, 0), ops.where(ops.ge(b, 0), s * b / r, 0.0), ops.where(ops.ge(a, b), 0.0, s)
        )
        return [n0, n1]


def punch(load_scale: float = 1.0) -> FlatPunch:
    """The punch at load scale s, its face at x = 1 at rest, moving as the block's needle."""
    needle = get_entry("contact").tool
    assert needle is not None
    motion = needle(load_scale).motion
    return FlatPunch(radius=HALF_WIDTH, c0=EDGE, motion=motion, scale=float(load_scale))


def _benchmark(**options: Any) -> Benchmark:
    """The contact block with the punch in the needle's place."""
    bench = get_entry("contact").build(**options)
    assert bench.contact is not None
    scale = float(bench.options.get("load_scale", 1.0))
    bench.contact = dataclasses.replace(bench.contact, tool=punch(scale))
    bench.name = NAME
    return bench


def _posing(load_scale: float = 1.0, **options: Any):
    posed = get_entry("contact").posing(load_scale=load_scale, **options)  # type: ignore[misc]
    return dataclasses.replace(posed, tool=dataclasses.replace(posed.tool, tool=punch(load_scale)))


def _export(mesh_size: int, load_scale: float = 1.0, **options: Any) -> dict:
    stated = get_entry("contact").contact_export(mesh_size, load_scale, **options)  # type: ignore[misc]
    stated["shape"] = punch(load_scale).shape()
    return stated


@contextlib.contextmanager
def registered():
    """The punch benchmark in the registry for the context's length."""
    contact = get_entry("contact")
    entry = dataclasses.replace(
        contact,
        build=_benchmark,
        tool=lambda load_scale=1.0, **options: punch(load_scale),
        posing=_posing,
        contact_export=_export,
        title="Block and flat punch (toy)",
    )
    register(NAME, entry)
    try:
        yield entry
    finally:
        unregister(NAME)


def closed_form_points() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points around the punch at rest (face at x = 1, |y - 0.5| <= 0.1), their signed distances
    (m) and outward normals, by hand."""
    points = np.array(
        [
            [0.9, 0.5],  # 0.1 m in front of the face
            [0.9, 0.65],  # in front of the upper corner: 0.1 and 0.05 m from it
            [1.2, 0.65],  # 0.05 m above the strip
            [1.02, 0.5],  # 0.02 m behind the face, far from the flanks
            [1.3, 0.58],  # 0.02 m below the upper flank, far behind the face
        ]
    )
    distance = np.array([0.1, np.hypot(0.1, 0.05), 0.05, -0.02, -0.02])
    corner = np.array([-0.1, 0.05]) / np.hypot(0.1, 0.05)
    normal = np.array([[-1.0, 0.0], corner, [0.0, 1.0], [-1.0, 0.0], [0.0, 1.0]])
    return points, distance, normal
