"""Timing the grading of a candidate against the truth (SPEC 10; issue 25, item 6): a 300-step
candidate of about 1e5 dofs on its own hexahedra graded against a synthetic truth of rod shape
on one core (metrics/truth.py's grade_truth: the candidate located once at the truth's
vertices and quadrature points, then applied as a sparse matrix at every step). Prints one
table: `python -m tissuebench.workflows.bench.truth_grading`. Times are wall-clock and CPU
seconds of this process.
"""

from __future__ import annotations

import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.cells import DIM, boundary_facets, shape_functions, shape_gradients
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.series import Series
from tissuebench.metrics.truth import grade_truth
from tissuebench.solvers.truth.samples import TruthSamples


def _grid(n: tuple[int, ...], lengths: tuple[float, ...]) -> tuple[np.ndarray, np.ndarray]:
    """A structured grid of quadrilaterals or hexahedra (VTK order): points and cells."""
    d = len(n)
    axes = [np.linspace(0.0, L, k + 1) for k, L in zip(n, lengths, strict=True)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
    index = np.arange(len(points)).reshape([k + 1 for k in n])
    corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
    if d == 3:
        corners = [(*c, 0) for c in corners] + [(*c, 1) for c in corners]
    cells = np.stack(
        [index[tuple(slice(o, o + k) for o, k in zip(c, n, strict=True))].ravel() for c in corners],
        axis=1,
    )
    return points, cells


def gauss_points(
    points: np.ndarray, cells: np.ndarray, cell_type: str, per_direction: int = 3
) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature points (m) and weights (m^d) of a first-order Q1 mesh, per_direction Gauss
    points per direction, cell by cell."""
    d = DIM[cell_type]
    g, gw = np.polynomial.legendre.leggauss(per_direction)
    g, gw = 0.5 * (g + 1), 0.5 * gw
    xi = np.stack(np.meshgrid(*[g] * d, indexing="ij"), axis=-1).reshape(-1, d)
    w = np.prod(np.stack(np.meshgrid(*[gw] * d, indexing="ij"), axis=-1).reshape(-1, d), axis=1)
    X = points[cells]
    x = np.einsum("qk,cki->cqi", shape_functions(cell_type, xi), X).reshape(-1, d)
    J = np.einsum("cki,qkj->cqij", X, shape_gradients(cell_type, xi))
    return x, (w * np.abs(np.linalg.det(J))).ravel()


def bench(
    truth_cells: tuple[int, ...] = (24, 12, 12),
    candidate_cells: tuple[int, ...] = (50, 25, 25),
    steps: int = 300,
) -> dict[str, float]:
    """Time grade_truth on COMM_SELF for a synthetic rod-shaped truth (hexahedra, 27 Gauss
    points per cell) and a hexahedral candidate of 3 x its node count dofs over `steps` steps:
    wall seconds for locating and for the steps, and the total in wall and CPU seconds (the
    CPU time of this process: the one core's work, whatever else the machine runs)."""
    lengths = (10.0, 1.0, 1.0)
    tv, tc = _grid(truth_cells, lengths)
    tq, tw = gauss_points(tv, tc, "hexahedron")
    times = np.arange(steps + 1) * 0.0333

    def field_at(x, t):
        s = np.sin(np.pi * x[:, 0] / 20.0)
        return np.stack([0.01 * s * x[:, 1], -0.1 * s * t / times[-1], 0.02 * s * x[:, 2]], 1)

    truth = TruthSamples(
        "bench",
        "hexahedron",
        times,
        tv,
        tc,
        boundary_facets(tv, tc, "hexahedron"),
        tq,
        tw,
        np.stack([field_at(tv, t) for t in times]),
        np.stack([field_at(tq, t) for t in times]),
        {"interior_error_max": 1e-6},
    )
    cv, cc = _grid(candidate_cells, lengths)
    cand = Series(
        Path("candidate.xdmf"),
        cv,
        cc,
        "hexahedron",
        times,
        [field_at(cv, t) * 1.001 for t in times],
    )
    start, cpu = time.perf_counter(), time.process_time()
    g = grade_truth(truth, cand, MPI.COMM_SELF)
    total, cpu = time.perf_counter() - start, time.process_time() - cpu
    return {
        "truth vertices": len(tv),
        "truth quadrature points": len(tq),
        "candidate dofs": 3 * len(cv),
        "steps": steps,
        "locate s": g.seconds["locate"],
        "steps s": g.seconds["steps"],
        "total s": total,
        "total CPU s": cpu,
        "E_i max": summarize(g.curves["interior_error"])[0],
    }


def main() -> None:
    """Print bench()'s table."""
    row = bench()
    width = max(len(k) for k in row)
    for key, value in row.items():
        shown = f"{value:.4g}" if isinstance(value, float) else f"{value:,}"
        print(f"{key:<{width}}  {shown}")


if __name__ == "__main__":
    main()
