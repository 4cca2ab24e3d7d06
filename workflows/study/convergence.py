"""Observed orders of convergence of the schemes, in time and in space (the numerics of
`tissuebench convergence`, workflows/commands/convergence.py).

Time: every dynamic scheme with h, h/2, h/4, h/8 against `implicit` with h/64; each metric's
error is its maximum over the times t_j = j h that all runs share. Space: solutions at one
time on nested meshes, interpolated onto the finest and measured there. Observed orders
p = log(e_a / e_b) / log(s_b / s_a) between consecutive refinements s (1/h, or cells per unit
length), and from the differences between consecutive solutions, free of the reference's own
error. Units: h and t in s, errors dimensionless (E_n, E_s) or in m (E_i).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from tissuebench.meshes import get_benchmark
from tissuebench.metrics import METRICS as ALL_METRICS
from tissuebench.metrics import Metrics
from tissuebench.solvers import ALGORITHMS, get_integrator
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System

DYNAMIC = tuple(name for name, a in ALGORITHMS.items() if a.newmark)
# the metrics of the table that are no variant (E_n, E_s, E_i), as they were when imported
METRICS = tuple(name for name, m in ALL_METRICS.items() if m.variant_of is None)
LEVELS = 4  # h, h/2, h/4, h/8
REFINEMENT = 64  # the reference's step is h / 64
SPACE_TIME = 1.0  # s: the space study compares the solutions at this time


# --- runs ---------------------------------------------------------------------------------------


def displacements(
    system: System, algorithm: str, h: float, n_steps: int, every: int = 1
) -> list[np.ndarray]:
    """The owned displacement values (m) at steps 0, every, 2 every, ... of a run with step h
    (s); a diverged run gives the ones before it diverged."""
    kept = []

    def keep(state):
        if state.i % every == 0:
            kept.append(state.u.array_r.copy())

    simulate(
        get_integrator(algorithm, system, h),
        n_steps,
        system.benchmark.extent,
        algorithm,
        on_step=keep,
        keep=False,
    )
    return kept


def peak_errors(
    metrics: Metrics, reference: list[np.ndarray], candidate: list[np.ndarray]
) -> dict[str, float]:
    """Each metric's maximum over the shared times j = 1..n; inf when a run diverged (it then
    has fewer times than the other)."""
    if len(candidate) != len(reference):
        return {name: math.inf for name in METRICS}
    curves = metrics.history(reference, candidate)
    return {name: float(np.max(curves[name][1:])) for name in METRICS}


# --- observed orders ----------------------------------------------------------------------------


def orders(refinements: Sequence[float], errors: Sequence[float]) -> list[float]:
    """p = log(e_a / e_b) / log(s_b / s_a) for consecutive refinements s (1/h or cells per unit
    length); NaN where an error is not finite and positive."""
    out = []
    for (sa, ea), (sb, eb) in zip(
        zip(refinements, errors, strict=True),
        zip(refinements[1:], errors[1:], strict=True),
        strict=False,
    ):
        ok = all(math.isfinite(e) and e > 0 for e in (ea, eb))
        out.append(math.log(ea / eb) / math.log(sb / sa) if ok else math.nan)
    return out


def difference_orders(refinements: Sequence[float], differences: Sequence[float]) -> list[float]:
    """The order p from the differences d_ab = |u_a - u_b| of consecutive solutions: for three
    consecutive refinements a < b < c, the p with d_ab / d_bc = (a^-p - b^-p) / (b^-p - c^-p),
    the ratio of an error C s^-p; log2(d_ab / d_bc) when each refines the last by 2."""
    out = []
    for k in range(len(differences) - 1):
        a, b, c = refinements[k : k + 3]
        d_ab, d_bc = differences[k], differences[k + 1]
        if not all(math.isfinite(d) and d > 0 for d in (d_ab, d_bc)):
            out.append(math.nan)
            continue

        def ratio(p):
            return (a**-p - b**-p) / (b**-p - c**-p)

        lo, hi = 1e-3, 20.0  # ratio(p) grows with p
        target = d_ab / d_bc
        if not ratio(lo) <= target <= ratio(hi):
            out.append(math.nan)
            continue
        while hi - lo > 1e-10:
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if ratio(mid) < target else (lo, mid)
        out.append((lo + hi) / 2)
    return out


# --- time ---------------------------------------------------------------------------------------


def time_study(
    system: System,
    h: float,
    end_time: float,
    algorithms: Sequence[str] = DYNAMIC,
    levels: int = LEVELS,
    refinement: int = REFINEMENT,
) -> dict[str, dict[str, list[dict[str, float]]]]:
    """For each scheme, the peak errors of h / 2^k (k < levels) against `implicit` with
    h / refinement, and the peak differences between consecutive levels, all at t_j = j h up to
    end_time (s). {algorithm: {"errors": [...], "differences": [...]}}, each a list of dicts
    keyed by METRICS."""
    n = round(end_time / h)
    metrics = Metrics(system.V)
    reference = displacements(system, "implicit", h / refinement, n * refinement, every=refinement)
    results = {}
    for name in algorithms:
        runs = [displacements(system, name, h / 2**k, n * 2**k, every=2**k) for k in range(levels)]
        results[name] = {
            "errors": [peak_errors(metrics, reference, u) for u in runs],
            "differences": [peak_errors(metrics, runs[k + 1], runs[k]) for k in range(levels - 1)],
        }
    return results


# --- space --------------------------------------------------------------------------------------


def interpolate(
    V_to: fem.FunctionSpace, V_from: fem.FunctionSpace, values: np.ndarray
) -> np.ndarray:
    """Owned dof values on V_to of the Q1 field with owned dof values `values` on V_from (on
    another mesh of the same domain), by Function.interpolate_nonmatching."""
    u_from = fem.Function(V_from)
    u_from.x.array[: len(values)] = values
    u_from.x.scatter_forward()
    u_to = fem.Function(V_to)
    cell_map = V_to.mesh.topology.index_map(V_to.mesh.topology.dim)
    cells = np.arange(cell_map.size_local + cell_map.num_ghosts, dtype=np.int32)
    data = fem.create_interpolation_data(V_to, V_from, cells, padding=1e-8)
    u_to.interpolate_nonmatching(u_from, cells, data)
    u_to.x.scatter_forward()
    return u_to.x.array[: V_to.dofmap.index_map.size_local * V_to.dofmap.bs].copy()


def solution_at(system: System, problem: str, t: float, h: float) -> np.ndarray:
    """The owned displacement values (m) at time t (s): `quasi-static` (one solve of K u = f(t))
    or `implicit` with step h (s)."""
    if problem == "quasi-static":
        return displacements(system, "quasi-static", t, 1)[-1]
    return displacements(system, "implicit", h, round(t / h))[-1]


def space_study(
    benchmark: str,
    material: str | None,
    sizes: Sequence[int],
    problems: Sequence[str] = ("quasi-static", "implicit"),
    t: float = SPACE_TIME,
    h: float = 1 / 30,
    comm: MPI.Comm = MPI.COMM_WORLD,
    **options: object,
) -> dict[str, dict[str, list[dict[str, float]]]]:
    """For each problem, the errors of the solutions at time t on every mesh but the finest
    against the finest, and the differences between consecutive meshes, all measured on the
    finest mesh. {problem: {"errors": [...], "differences": [...]}}, lists of dicts keyed by
    METRICS."""
    systems = [
        System(get_benchmark(benchmark, mesh_size=size, comm=comm, **options), material)
        for size in sizes
    ]
    fine = systems[-1]
    metrics = Metrics(fine.V)
    results = {}
    for problem in problems:
        u = [interpolate(fine.V, s.V, solution_at(s, problem, t, h)) for s in systems]
        results[problem] = {
            "errors": [metrics.evaluate(u[-1], uk) for uk in u[:-1]],
            "differences": [metrics.evaluate(u[k + 1], u[k]) for k in range(len(u) - 1)],
        }
    return results
