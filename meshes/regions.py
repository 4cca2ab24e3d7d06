"""Each benchmark's constrained regions as geometric predicates, and a benchmark posed on a mesh
that is not ours (a candidate's own, SPEC 9 and 10's "our implicit on M'").

A region is the box's part where its nodes are constrained, stated as the export states it
(workflows/posing.py's `geometry`: "x = 0", "x = 1 and |y - 0.5| <= 0.1"), with the motion its
nodes follow. `on_mesh` finds each region's nodes on any first-order mesh of the benchmark's
body within a tolerance (SPEC 9's τ = 1e-6 of the benchmark's extent by default) and returns
the Benchmark with those constraints, the benchmark's gravity, load scale and needle motion,
so that solvers.system.System assembles on that mesh as on ours.

Each benchmark's module states its regions (its Entry's `posing`, with the classes here).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from tissuebench.meshes.benchmark import Benchmark, Constraint, Entry
from tissuebench.meshes.gmshio import MeshError, TaggedMesh

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
class Posing:
    """What a benchmark prescribes on any mesh of its body: its regions in the solver's order
    (a node in several follows the last), gravity (m/s^2) and extent (m)."""

    regions: tuple[Region, ...]
    gravity: tuple[float, ...]
    extent: float


def posing(benchmark: str, **options: object) -> tuple[Entry, Posing]:
    """A benchmark's entry and posing with its options (those its entry takes: load_scale,
    needle_width; others, such as our mesh's cell and mesh kind, are not the posing's)."""
    from tissuebench.meshes import BENCHMARKS

    entry = BENCHMARKS.get(benchmark)
    if entry is None or entry.posing is None:
        posed = ", ".join(name for name, e in BENCHMARKS.items() if e.posing is not None)
        raise MeshError(f"benchmark {benchmark!r} states no regions: use one of {posed}")
    return entry, entry.posing(**{k: v for k, v in options.items() if k in entry.options})


def on_mesh(
    benchmark: str,
    mesh: dolfinx.mesh.Mesh,
    tolerance: float | None = None,
    **options: object,
) -> Benchmark:
    """The benchmark posed on `mesh` (any first-order mesh of its body, m): each region's nodes
    found geometrically within `tolerance` (m; default SPEC 9's τ = 1e-6 of the extent), with
    the benchmark's gravity, load scale, motions and defaults (material, h, T). MeshError, one
    line, for a mesh of another dimension or a region that holds no node of it. Collective."""
    entry, posed = posing(benchmark, **options)
    gdim = mesh.geometry.dim
    if gdim != entry.gdim:
        raise MeshError(f"a {gdim}D mesh cannot pose the {entry.gdim}D benchmark {benchmark}")
    tol = SAME_BODY * posed.extent if tolerance is None else tolerance
    constraints = []
    for region in posed.regions:
        vertices = dolfinx.mesh.locate_entities(
            mesh, 0, lambda x, region=region: region.mask(x[:gdim].T, tol)
        )
        owned = mesh.topology.index_map(0).size_local
        found = mesh.comm.allreduce(int(np.sum(vertices < owned)), op=MPI.SUM)
        if found == 0:
            raise MeshError(
                f"no node of the mesh lies on {benchmark}'s region {region.name} "
                f"({region.predicate}, within {tol:.3g} m)"
            )
        constraints.append(Constraint(region.name, 0, vertices, region.motion))
    return Benchmark(
        name=benchmark,
        tagged=TaggedMesh(mesh, {}, {}),
        constraints=constraints,
        gravity=posed.gravity,
        material=entry.material,
        dt=entry.dt,
        end_time=entry.end_time,
        extent=posed.extent,
        mesh_size=0,  # not one of our meshes
        probe=entry.probe,
        options={k: v for k, v in options.items() if k in entry.options},
    )
