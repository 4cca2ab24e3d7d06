"""Our `implicit` on a candidate's own mesh (SPEC 10's I(M', m)), read from its series, and the
error budget of a user's leaderboard row that it gives (discretisation, algorithm, model).

The mesh is the series' (metrics.series.Series: first-order triangles, quadrilaterals,
tetrahedra or hexahedra, cells in VTK node order), made a DOLFINx mesh on one process (VTK's
corner order permuted to DOLFINx's: dolfinx.io.utils.cell_perm_vtk); the benchmark is posed on
it by meshes/regions.py (its constrained nodes found by the benchmark's own region predicates,
the ones the export states, within SPEC 9's τ of the extent). Our run is returned as a Series
on the candidate's points and cells, node for node, so that the candidate is graded against it
on the same mesh (SPEC 6) and it against the truth as any row is (metrics/truth.py).

Nothing is written: the run lives in memory (the rod at n = 3: about a second).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx.io.utils import cell_perm_vtk

from tissuebench.core.errors import UserError
from tissuebench.meshes.posed import on_mesh
from tissuebench.metrics.series import CELLS, Series

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples
    from tissuebench.workflows.leaderboard.rows import Board, Row

REFERENCE = "implicit"


class OnMeshError(UserError):
    """Our implicit cannot run on a candidate's mesh, or did not finish: one line."""


def series_mesh(series: Series, comm: MPI.Comm = MPI.COMM_SELF) -> dolfinx.mesh.Mesh:
    """The DOLFINx mesh of a series' points (m) and first-order cells (VTK order), on comm
    (rank 0's series; others may pass None). OnMeshError for cells that are not first order or
    points that are in no cell."""
    kind = comm.bcast(
        (series.cell_type, series.dim, series.cells.shape[1]) if comm.rank == 0 else None, root=0
    )
    cell_type, dim, per_cell = kind
    if cell_type not in CELLS or CELLS[cell_type][1] != per_cell:
        raise OnMeshError(f"its cells ({cell_type}, {per_cell} nodes) are not first-order ones")
    if comm.rank == 0:
        unused = len(series.points) - len(np.unique(series.cells))
        cells = series.cells[:, cell_perm_vtk(dolfinx.mesh.CellType[cell_type], per_cell)]
        x = np.ascontiguousarray(series.points, dtype=np.float64)
    else:
        unused, cells, x = 0, np.empty((0, per_cell), dtype=np.int64), np.empty((0, dim))
    unused = comm.bcast(unused, root=0)
    if unused:
        raise OnMeshError(f"{unused} of its points are in no cell")
    element = basix.ufl.element("Lagrange", cell_type, 1, shape=(dim,))
    return dolfinx.mesh.create_mesh(comm, cells, ufl.Mesh(element), x)


def point_of_node(V: dolfinx.fem.FunctionSpace) -> np.ndarray:
    """For each node of the vector P1/Q1 space V on a mesh made from a series (series_mesh,
    one process), the index of its point in the series: cell by cell the dofs sit at the
    geometry nodes, which know their input index."""
    point = np.empty(V.dofmap.index_map.size_local, dtype=np.int64)
    geometry = V.mesh.geometry
    point[V.dofmap.list.ravel()] = geometry.input_global_indices[geometry.dofmaps[0].ravel()]
    return point


def implicit_on(
    series: Series,
    benchmark: str,
    material: str,
    model: str,
    options: dict,
    h: float,
    steps: int,
) -> Series:
    """Our implicit with `model` on the series' own mesh, the benchmark posed on it with its
    options (meshes/regions.py), `steps` steps of h (s) from rest: a Series on the series'
    points and cells (same order) of the displacement (m) at t_i = i h. One process.
    MeshError when a region holds no node; OnMeshError for a mesh that cannot be read or a
    run that does not finish (one line each)."""
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.simulate import simulate
    from tissuebench.solvers.system import System

    mesh = series_mesh(series)
    bench = on_mesh(benchmark, mesh, **options)
    system = System(bench, material)
    integrator = get_integrator(REFERENCE, system, h, model=model)
    try:
        run = simulate(integrator, steps, bench.extent, REFERENCE)
    finally:
        integrator.destroy()
    if run.status != "ok":
        raise OnMeshError(
            f"our {REFERENCE} ({model}) diverged on it at step {run.diverged_step} "
            f"(t = {run.diverged_time:.4g} s): {run.reason}"
        )
    point = point_of_node(system.V)
    gdim = system.gdim
    displacements = []
    for u in run.u:
        values = np.empty((len(series.points), gdim))
        values[point] = np.asarray(u).reshape(-1, gdim)[: len(point)]
        displacements.append(values)
    return replace(
        series,
        path=Path(f"{REFERENCE}-{model}-on-its-mesh"),
        times=np.arange(steps + 1) * h,
        displacements=displacements,
        field="displacement",
    )


def one_line(exc: BaseException) -> str:
    """An exception in one line of at most 200 characters."""
    text = " ".join(str(exc).split())[:200]
    return text if isinstance(exc, UserError) else f"{type(exc).__name__}: {text}"


def budget_on_mesh(
    board: Board,
    row: Row,
    truth: TruthSamples | None,
    user: Series | None = None,
    cache: dict | None = None,
    located: dict | None = None,
) -> dict:
    """A user row's error budget parts beyond its total (SPEC 10), time-mean E_i in m^gdim,
    from our implicit run here on the row's own mesh (read from its series, row.series, unless
    `user` is that series read already): discretisation, I(M', truth's model) against the
    truth; algorithm, the row against I(M', m) with m the row's model (row.model, as its user
    stated it to compare with --model, else the case's, board.model); model, I(M', m) against
    I(M', truth's model), 0 when m is the truth's. Each part's `_how` says how it was
    measured; where our implicit cannot run on that mesh, every part is None and
    discretisation_how says why in one line.

    `cache`, a dict the caller keeps: what depends on the mesh and the case only (our runs on
    the mesh, the discretisation and model parts, or why our implicit cannot run there) is
    computed once per mesh (crossmesh.Mesh.key) and case, and rows on the same mesh take it
    from there; only the algorithm part is graded per row. `located` is grade_truth's for this
    truth. The same numbers as without them. Rank 0, serial."""
    from tissuebench.metrics.compare import grade_series, summarize
    from tissuebench.metrics.crossmesh import Mesh
    from tissuebench.metrics.truth import grade_truth
    from tissuebench.solvers.truth.cases import CASES
    from tissuebench.workflows.io.series import read_series
    from tissuebench.workflows.leaderboard.rows import E_I, board_case

    assert row.series is not None  # a user row with its series (the caller's condition)
    case = board_case(board)
    real = CASES[board.truth][2] if board.truth in CASES else board.model
    mine = row.model or board.model  # the row's model: stated to compare, else the case's

    def mean(curve) -> float | None:
        value = float(summarize(curve)[1])
        return value if np.isfinite(value) else None

    def failed(exc: BaseException) -> dict:
        return {
            "discretisation": None,
            "discretisation_how": f"our implicit not run on its mesh: {one_line(exc)}",
            "algorithm": None,
            "model": None,
        }

    def on_its_mesh(user: Series) -> tuple[dict, dict]:
        """Our runs on the user's mesh and the parts they give (discretisation, model)."""
        runs = {}
        for model in dict.fromkeys((real, mine)):
            runs[model] = implicit_on(
                user,
                board.benchmark,
                board.material,
                model,
                board.options,
                case["h"],
                case["steps"],
            )
        graded = grade_truth(truth, runs[real], MPI.COMM_SELF, surface=False, located=located)
        parts = {"discretisation": mean(graded.curves[E_I])}
        if mine == real:
            parts["model"] = 0.0
        else:
            between = grade_series(runs[real], runs[mine], MPI.COMM_SELF, surface=False)
            parts["model"] = mean(between.curves[E_I])
        return runs, parts

    try:
        user = read_series(row.series, row.series_field) if user is None else user
        key = (
            Mesh.of(user).key(),
            board.benchmark,
            board.material,
            real,
            mine,
            repr(sorted(board.options.items())),
            case["h"],
            case["steps"],
            None if truth is None else truth.case,
        )
        found = None if cache is None else cache.get(key)
        if found is None:
            try:
                found = on_its_mesh(user)
            except Exception as exc:  # anything a run can do: no parts on this mesh
                found = exc
            if cache is not None:
                cache[key] = found
        if isinstance(found, BaseException):
            raise found
        runs, parts = found
        # E_i only: E_s (surface=False) is most of a grading's cost and no part of the budget
        against = grade_series(runs[mine], user, MPI.COMM_SELF, surface=False)
        parts = {**parts, "algorithm": mean(against.curves[E_I])}
    except Exception as exc:  # anything a file or a run can do: this row's parts are not known
        return failed(exc)
    nodes = len(user.points)
    return {
        "discretisation": parts["discretisation"],
        "algorithm": parts["algorithm"],
        "model": parts["model"],
        "discretisation_how": f"our {REFERENCE} ({real}) run here on its mesh, {nodes:,} nodes",
        "algorithm_how": f"against our {REFERENCE} ({mine}) on its mesh",
        "model_how": (
            f"none: its model, {real}, is the truth's"
            if mine == real
            else f"our {REFERENCE} {mine} against {real} on its mesh"
        ),
    }
