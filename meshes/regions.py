"""Each benchmark's constrained regions as geometric predicates (meshes/posed.py poses them on a
mesh that is not ours: a candidate's own, SPEC 9 and 10's "our implicit on M'").

A region is the box's part where its nodes are constrained, stated as the export states it
(workflows/compare/posing.py's `geometry`: "x = 0", "x = 1 and |y - 0.5| <= 0.1"), with the
motion its nodes follow. posed.py's `on_mesh` finds each region's nodes on any first-order mesh
of the benchmark's body within a tolerance (SPEC 9's τ = 1e-6 of the benchmark's extent by
default) and returns the Benchmark with those constraints, the benchmark's gravity, load scale
and needle motion, so that solvers.system.System assembles on that mesh as on ours.

A benchmark with a rigid tool in contact (SPEC 12) states it too (`Touching`: the surface that
may touch it, as terms, the tool, meshes/tools/, and the penalty), and posed.py's `on_mesh`
finds that surface's boundary facets on the mesh, so that the tool pushes the body there as on
our mesh.

Each benchmark's module states its regions (its Entry's `posing`, with the classes here).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from tissuebench.meshes.tools import Tool

AXES = "xyz"
SAME_BODY = 1e-6  # SPEC 9's τ: a node lies on a region within this fraction of the extent


def number(value: float) -> str:
    """A coordinate in a predicate: the shortest text that reads back as the float (0.5, 0)."""
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


@dataclass(frozen=True)
class Term:
    """|X[axis] - centre| <= radius (m): "x = c" when the radius is 0."""

    axis: int
    centre: float  # m
    radius: float = 0.0  # m

    @property
    def text(self) -> str:
        """The term as the export writes it ("x = 0", "|y - 0.5| <= 0.1")."""
        c = AXES[self.axis]
        if self.radius == 0:
            return f"{c} = {number(self.centre)}"
        return f"|{c} - {number(self.centre)}| <= {number(self.radius)}"


@dataclass(frozen=True)
class Region:
    """A constrained node set: the nodes where every term holds, following `motion(t) ->
    (u, v, a)` (m, m/s, m/s^2 per component)."""

    name: str
    terms: tuple[Term, ...]
    motion: Callable

    @property
    def predicate(self) -> str:
        """The region as the export states it: its terms joined by "and"."""
        return " and ".join(t.text for t in self.terms)

    def mask(self, points: np.ndarray, tolerance: float) -> np.ndarray:
        """Which of the points (n, d), m, lie in the region within tolerance (m)."""
        inside = np.ones(len(points), dtype=bool)
        for t in self.terms:
            inside &= np.abs(points[:, t.axis] - t.centre) <= t.radius + tolerance
        return inside


@dataclass(frozen=True)
class Touching:
    """A rigid tool in frictionless penalty contact (SPEC 12, 13): the boundary facets where
    every term of `surface` holds may touch `tool` (meshes/tools/); the penalty is
    k = kappa E / h_e, h_e the smallest of those facets (m)."""

    surface: tuple[Term, ...]
    tool: Tool
    kappa: float

    @property
    def predicate(self) -> str:
        """The surface as the export states it ("x = 1")."""
        return " and ".join(t.text for t in self.surface)

    def mask(self, points: np.ndarray, tolerance: float) -> np.ndarray:
        """Which of the points (n, d), m, lie on the surface within tolerance (m)."""
        return Region("surface", self.surface, lambda t: None).mask(points, tolerance)


@dataclass(frozen=True)
class Posing:
    """What a benchmark prescribes on any mesh of its body: its regions in the solver's order
    (a node in several follows the last), gravity (m/s^2) and extent (m), and the rigid tool
    in contact with it, if any."""

    regions: tuple[Region, ...]
    gravity: tuple[float, ...]
    extent: float
    tool: Touching | None = None


def shortest_edge(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> float:
    """The shortest edge (m) of the boundary facets `facets` (local indices) over every rank,
    the penalty's h_e of a contact surface. Collective."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, 0)
    owned = facets[facets < mesh.topology.index_map(tdim - 1).size_local]
    ends = dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, owned)
    x = mesh.geometry.x
    pairs = [(i, j) for i in range(ends.shape[1]) for j in range(i)]
    sizes = [np.linalg.norm(x[ends[:, i]] - x[ends[:, j]], axis=1) for i, j in pairs]
    local = float(np.min(sizes)) if len(owned) else np.inf
    return mesh.comm.allreduce(local, op=MPI.MIN)
