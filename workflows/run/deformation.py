"""deformation.json of a case with elastic models (model_figures.py): the step of the
reference's largest deflection, and for every run its smallest J = det F over the steps it kept,
at the Gauss points at which the solver checks for inverted elements (2 per direction), with
the step and the cell's centre, and the same at its last kept step; from the runs' series."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from tissuebench.workflows.io.summary import CaseSummary

# the corners of the reference cells in VTK order: [0, 1]^2 and [0, 1]^3
VTK_CORNERS = {
    4: np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float),
    8: np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        dtype=float,
    ),
}


def gauss_points(d: int) -> np.ndarray:
    """The 2 x ... x 2 Gauss points on [0, 1]^d: the points at which the solver checks J
    (solvers/elastic.py, quadrature degree 2)."""
    g = 0.5 + np.array([-1.0, 1.0]) / (2 * np.sqrt(3.0))
    return np.stack(np.meshgrid(*([g] * d), indexing="ij"), axis=-1).reshape(-1, d)


def shape_gradients(corners: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Gradients of the Q1 shape functions of the reference corners at the points xi:
    (points, corners, d)."""
    # N_a(xi) = prod_k (c_ak xi_k + (1 - c_ak)(1 - xi_k)); dN_a/dxi_j drops factor j for 2 c_aj - 1
    factors = corners[None] * xi[:, None] + (1 - corners[None]) * (1 - xi[:, None])
    d = corners.shape[1]
    grads = np.empty(factors.shape)
    for j in range(d):
        others = np.prod(np.delete(factors, j, axis=2), axis=2)
        grads[..., j] = (2 * corners[None, :, j] - 1) * others
    return grads


def jacobians(points: np.ndarray, cells: np.ndarray, displacements: np.ndarray) -> np.ndarray:
    """J = det F at the Gauss points of every cell, (steps, cells, points), for displacements
    (steps, nodes, d) on a Q1 mesh with cells in VTK order: the ratio of the deformed to the
    undeformed determinant of the map from the reference cell."""
    X = np.asarray(points, dtype=float)
    u = np.asarray(displacements, dtype=float)
    d = X.shape[1]
    grads = shape_gradients(VTK_CORNERS[cells.shape[1]], gauss_points(d))

    def determinants(x):  # x: (..., nodes, d) -> (..., cells, points)
        # A[..., c, q, i, j] = sum_n x[cells[c, n], i] dN_n/dxi_j (q): one matrix product
        A = np.moveaxis(np.tensordot(x[..., cells, :], grads, axes=([-2], [1])), -3, -2)
        if d == 2:
            return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]
        return np.einsum("...i,...i->...", np.cross(A[..., 0], A[..., 1]), A[..., 2])

    return determinants(X + u) / determinants(X)[None]


def deformation_data(folder: Path, summary: CaseSummary, cache: dict | None = None) -> dict:
    """deformation.json's content from the runs' series: those in `cache` ({label: Series}),
    the others read from their XDMF files in folder into it, for the figures that follow."""
    from tissuebench.metrics.series import InputError
    from tissuebench.workflows.io.series import read_series

    cache = {} if cache is None else cache
    ref = summary.reference
    result: dict[str, Any] = {"largest_deflection": None, "smallest_J": {}}
    for label, run in summary.runs.items():
        try:
            series = cache[label] if label in cache else read_series(folder / f"{label}.xdmf")
        except InputError:  # a run that diverged at step 0 keeps no step
            continue
        cache[label] = series
        u = np.asarray(series.displacements)
        if label == ref:
            norms = np.linalg.norm(u, axis=2).max(axis=1)
            k = int(np.argmax(norms))
            node = int(np.argmax(np.linalg.norm(u[k], axis=1)))
            result["largest_deflection"] = {
                "label": label,
                "step": k,
                "time": float(series.times[k]),
                "u_max": float(norms[k]),
                "node": [float(x) for x in series.points[node]],
            }
        J = jacobians(series.points, series.cells, u).min(axis=2)  # (steps, cells)
        per_step = J.min(axis=1)
        k = int(np.argmin(per_step))

        def centre(step):
            cell = series.cells[int(np.argmin(J[step]))]
            return [float(x) for x in series.points[cell].mean(axis=0)]

        result["smallest_J"][label] = {
            "J": float(per_step[k]),
            "step": k,
            "time": float(series.times[k]),
            "cell_centre": centre(k),
            "last_step": len(u) - 1,
            "J_last_step": float(per_step[-1]),
            "cell_centre_last_step": centre(-1),
        }
    return result
