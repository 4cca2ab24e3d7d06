"""The truth cases of SPEC 10 on the benchmarks' grids, and their hierarchy of levels."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.meshes.benchmark import Benchmark
from tissuebench.solvers.materials import Material, get_material
from tissuebench.solvers.truth.estimate import ErrorEstimate, estimate_error, interior_difference
from tissuebench.solvers.truth.solver import Boundary, Problem, Truth, TruthRun

# case -> (benchmark, material, model, load scale s, needle width w in m or None)
CASES = {
    "rod": ("rod", "MP3", "linear", 1.0, None),
    "rod-nh-s1": ("rod", "MP3", "neo-hookean", 1.0, None),
    "rod-nh-s3": ("rod", "MP3", "neo-hookean", 3.0, None),
    "block-MP1-w0.2": ("block", "MP1", "linear", 1.0, 0.2),
    "block-MP2-w0.2": ("block", "MP2", "linear", 1.0, 0.2),
    "block-MP1-nh-s2-w0.2": ("block", "MP1", "neo-hookean", 2.0, 0.2),
}


def _constraint_nodes(V: fem.FunctionSpace, dim: int, entities: np.ndarray) -> np.ndarray:
    """The nodes of V on the mesh entities (dim, entities); for vertices, also the nodes of
    the boundary facets whose vertices are all in the set (a Q2 edge's midpoint)."""
    mesh = V.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(dim, tdim)
    nodes = [fem.locate_dofs_topological(V, dim, entities)]
    if dim == 0 and len(entities):
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim - 1, 0)
        inside = np.zeros(
            mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts, bool
        )
        inside[entities] = True
        f2v = mesh.topology.connectivity(tdim - 1, 0)
        facets = np.array(
            [
                f
                for f in dolfinx.mesh.exterior_facet_indices(mesh.topology)
                if inside[f2v.links(f)].all()
            ],
            dtype=np.int32,
        )
        nodes.append(fem.locate_dofs_topological(V, tdim - 1, facets))
    return np.unique(np.concatenate(nodes)).astype(np.int32)


def benchmark_problem(
    benchmark: Benchmark, material: Material | str, model: str = "linear"
) -> Problem:
    """The truth Problem of a benchmark (meshes.benchmark.Benchmark, built with its load scale
    and needle width) with a material (solvers.materials.Material or name): its constraints on
    every Q2 node of the constrained entities, gravity rho g (N/m^3), and its probe."""
    mat = get_material(material)
    rho = mat.rho
    gravity = np.asarray(benchmark.gravity, dtype=float)

    def boundaries(V):
        out = []
        for c in benchmark.constraints:
            motion = c.motion
            out.append(
                Boundary(_constraint_nodes(V, c.dim, c.entities), lambda t, x, m=motion: m(t))
            )
        return out

    return Problem(
        mesh=benchmark.mesh,
        mu=mat.mu,
        lmbda=mat.lmbda,
        rho=rho,
        alpha=mat.alpha,
        beta=mat.beta,
        model=model,
        body_force=lambda x, t: rho * ufl.as_vector([float(g) for g in gravity]),
        boundaries=boundaries,
        probe=benchmark.probe,
    )


def case_truth(
    case: str, mesh_size: int, comm: MPI.Comm = MPI.COMM_WORLD
) -> tuple[Truth, Benchmark]:
    """(Truth, Benchmark) of a SPEC 10 case on the benchmark's grid of `mesh_size`."""
    from tissuebench.meshes import get_benchmark

    name, material, model, scale, width = CASES[case]
    options = {"load_scale": scale}
    if width is not None:
        options["needle_width"] = width
    bench = get_benchmark(name, mesh_size=mesh_size, comm=comm, **options)
    return Truth(benchmark_problem(bench, material, model)), bench


@dataclass
class Hierarchy:
    """A truth case computed on uniformly refined levels (mesh sizes) and, on the finest,
    with h/2: runs[k] at h on levels[k]; half the finest at h/2 (kept at the steps of h);
    level_ei[k] E_i per step between levels k and k+1; time_ei E_i per step between h and
    h/2 on the finest; estimate: the finest level's own E_i, its maximum over the steps (SPEC
    10; m^3 on the rod, m^2 on the block)."""

    case: str
    levels: tuple
    runs: list
    half: TruthRun
    level_ei: list
    time_ei: np.ndarray
    estimate: ErrorEstimate


def hierarchy(
    case: str,
    levels: Sequence[int],
    steps: int | None = None,
    log: Callable[[str], None] | None = None,
) -> Hierarchy:
    """Compute a SPEC 10 case on `levels` (at least three mesh sizes, each twice the previous)
    with the benchmark's h and, on the finest, h/2, for `steps` steps of h (default: to the
    benchmark's end time). `log(message)` is told what was done and how long it took."""
    if len(levels) < 3 or any(b != 2 * a for a, b in zip(levels, levels[1:])):  # noqa: B905
        raise ValueError(f"levels must be three or more mesh sizes, each twice the last: {levels}")
    runs = []
    for n in levels:
        truth, bench = case_truth(case, n)
        count = steps if steps is not None else round(bench.end_time / bench.dt)
        runs.append(truth.run(bench.dt, count))
        if log:
            log(f"{case} n={n}: {runs[-1].dofs} dofs, {count} steps, {runs[-1].wall:.1f} s")
    half = truth.run(bench.dt / 2, 2 * count, keep=2)  # the finest level's Truth, h/2
    if log:
        log(f"{case} n={levels[-1]} h/2: {half.wall:.1f} s")
    level_ei = [interior_difference(a, b) for a, b in zip(runs, runs[1:])]  # noqa: B905
    time_ei = interior_difference(runs[-1], half)  # half keeps every second step: those of h
    estimate = estimate_error([d.max() for d in level_ei], time_ei.max())
    return Hierarchy(case, tuple(levels), runs, half, level_ei, time_ei, estimate)
