"""The mesh-sensitivity study (SPEC 9, the paper's future work), which `tissuebench
sensitivity` runs and reports and the leaderboard reads: each algorithm on coarser and
other-shaped meshes, graded on its own mesh against `implicit` on a finer grid. The cases,
meshes, timing and files are described where users read them, in the command's docstring
(workflows/commands/sensitivity.py, its --help).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from tissuebench.core.fingerprint import fingerprint
from tissuebench.meshes import get_benchmark, get_entry
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.crossmesh import BODY_TOLERANCE, CrossMetrics, Mesh
from tissuebench.solvers import ALGORITHMS, REFERENCE, get_integrator
from tissuebench.solvers.simulate import Run, simulate
from tissuebench.solvers.system import System
from tissuebench.workflows.io.output import (
    OutputError,
    collective,
    write_owned,
)
from tissuebench.workflows.io.xdmf import gather_mesh, gather_series, write_series
from tissuebench.workflows.leaderboard.mesh_sensitivity_board import (  # noqa: F401 (read here before)
    leaderboard_boards,
)
from tissuebench.workflows.leaderboard.mesh_sensitivity_cases import (  # noqa: F401 (read here before)
    GRADED,
    MARKER,
    NAME,
    QUICK,
    STUDIES,
    Study,
    shapes,
)
from tissuebench.workflows.leaderboard.rows import finite, real

# --- running and grading -----------------------------------------------------------------------


def timed_run(
    system: System, algorithm: str, h: float, steps: int, extent: float, solver: str
) -> tuple[Run, float]:
    """(Run, seconds of the integrator's set-up) of one algorithm on system."""
    start = time.perf_counter()
    integrator = get_integrator(algorithm, system, h, solver=solver)
    setup_s = time.perf_counter() - start
    try:
        return simulate(integrator, steps, extent, algorithm), setup_s
    finally:
        integrator.destroy()


def whole_mesh(V: fem.FunctionSpace, comm: MPI.Comm) -> tuple[Mesh, dict]:
    """The mesh of V on every rank (points, VTK cells), and its sizes."""
    data, _ = gather_mesh(V)
    mesh = comm.bcast(
        Mesh(data[0][:, : V.mesh.geometry.dim], data[1], data[2]) if data else None, root=0
    )
    return mesh, {"nodes": len(mesh.points), "cells": len(mesh.cells)}


def grade_run(grader: CrossMetrics, ref_u: list, cand_u: np.ndarray) -> dict:
    """Max and time-mean (steps 1..) of the GRADED metrics of a candidate's nodal series
    (steps, N′, d), on every rank, over the steps that both runs have."""
    steps = min(len(ref_u), len(cand_u))
    curves = {name: np.full(steps, np.nan) for name in GRADED}
    for i in range(steps):
        for name, value in grader.evaluate(ref_u[i], cand_u[i], GRADED).items():
            curves[name][i] = value
    out = {}
    for name, curve in curves.items():
        out[f"{name}_max"], out[f"{name}_mean"] = summarize(curve)
    return out


def run_mesh(
    study: Study,
    shape: str,
    options: dict,
    size: int,
    ref: dict,
    h: float,
    steps: int,
    solver: str,
    folder: Path,
    comm: MPI.Comm,
    log: Callable[[str], None],
) -> list[dict]:
    """Every algorithm on one mesh of the study, graded against the reference; the rows."""
    entry = get_entry(study.benchmark)
    start = time.perf_counter()
    bench = get_benchmark(study.benchmark, mesh_size=size, comm=comm, **study.options, **options)
    system = System(bench, study.material)
    system_s = time.perf_counter() - start
    mesh, sizes = whole_mesh(system.V, comm)
    where = f"{study.name} {shape} {size}"
    grader = CrossMetrics(ref["V"], mesh, BODY_TOLERANCE * ref["extent"], where)
    rows = []
    for algorithm in ALGORITHMS:
        run, setup_s = timed_run(system, algorithm, h, steps, bench.extent, solver)
        gathered = gather_series(system.V, {"displacement": run.u})
        stem = f"{shape.replace(' ', '-')}-{size}-{algorithm}"
        collective(
            comm,
            lambda: write_series(folder / f"{stem}.xdmf", gathered, np.arange(run.steps + 1) * h),
            folder,
        )
        cand = comm.bcast(gathered[1]["displacement"][:, :, : system.gdim] if gathered else None)
        errors = grade_run(grader, ref["u"], cand)
        wall = system_s + setup_s + run.wall_time_s
        row = {
            "case": study.name,
            "algorithm": algorithm,
            "shape": shape,
            "cell": mesh.cell_type,
            "mesh": options.get("mesh", "structured"),
            "size": size,
            "spacing_m": entry.cell_size(size),
            **sizes,
            "dofs": system.num_dofs(),
            "status": run.status,
            "diverged_time_s": run.diverged_time,
            "steps": run.steps,
            **errors,
            "wall_time_s": wall,
            "end_time_s": steps * h,
            "cost_s_per_s": wall / (steps * h),
        }
        rows.append(row)
        if comm.rank == 0:
            state = "ok" if run.status == "ok" else f"DIVERGED at t = {run.diverged_time:.4g} s"
            log(
                f"{study.name} {shape:>24} {size:>3} {algorithm:<16} {state}: "
                f"E_i max {errors['interior_error_max']:.3g}, {row['cost_s_per_s']:.3g} s/s"
            )
    return rows


def warm_up(study: Study, options: dict, h: float, solver: str, comm: MPI.Comm) -> None:
    """Build every integrator once on the smallest mesh of a shape, untimed: FFCx compiles the
    forms of a cell type on first use, which is no part of a run's cost."""
    bench = get_benchmark(
        study.benchmark, mesh_size=study.sizes[0], comm=comm, **study.options, **options
    )
    system = System(bench, study.material)
    for algorithm in ALGORITHMS:
        get_integrator(algorithm, system, h, solver=solver).destroy()


def reference_run(
    study: Study,
    size: int,
    h: float,
    steps: int,
    solver: str,
    folder: Path,
    comm: MPI.Comm,
    log: Callable[[str], None],
) -> dict:
    """`implicit` on the grid of size 2N: its space, owned values per step and extent."""
    bench = get_benchmark(study.benchmark, mesh_size=2 * size, comm=comm, **study.options)
    system = System(bench, study.material)
    run, _ = timed_run(system, REFERENCE, h, steps, bench.extent, solver)
    if run.status != "ok":
        raise OutputError(f"{study.name}: the reference diverged ({run.reason})")
    gathered = gather_series(system.V, {"displacement": run.u})
    target = folder / f"reference-{2 * size}.xdmf"
    collective(comm, lambda: write_series(target, gathered, np.arange(steps + 1) * h), folder)
    if comm.rank == 0:
        log(
            f"{study.name} reference: implicit on the grid of size {2 * size}, "
            f"{run.wall_time_s:.1f} s"
        )
    return {
        "V": system.V,
        "u": run.u,
        "extent": bench.extent,
        "dofs": system.num_dofs(),
        "size": 2 * size,
    }


def run_study(
    study: Study,
    out: Path,
    solver: str,
    petsc: str,
    comm: MPI.Comm,
    log: Callable[[str], None] = print,
    quick: bool = False,
    session: str | None = None,
) -> dict:
    """Every mesh of the study (those already graded with the same inputs are read back);
    returns {"rows": [...], "reference": {...}, "h": s, "end_time": s}. A quick study keeps
    its series and rows apart (OUT/mesh-sensitivity-quick/)."""
    entry = get_entry(study.benchmark)
    h = entry.dt
    end_time = study.end_time or entry.end_time
    steps = round(end_time / h)
    folder = out / (f"{NAME}-quick" if quick else NAME) / study.name
    collective(comm, lambda: folder.mkdir(parents=True, exist_ok=True), folder)
    inputs = {
        "study": study.name,
        "benchmark": study.benchmark,
        "material": study.material,
        "options": study.options,
        "sizes": list(study.sizes),
        "h": h,
        "steps": steps,
        "solver": solver,
        "petsc": petsc,
        "algorithms": list(ALGORITHMS),
    }
    key = fingerprint(inputs)
    rows, ref, sessions = [], None, []
    session = session or time.strftime("%Y-%m-%d %H:%M %Z")  # when this command started
    for shape, options in shapes(entry.gdim).items():
        warm = False
        for size in study.sizes:
            done = folder / f"rows-{shape.replace(' ', '-')}-{size}.json"
            saved, damaged = comm.bcast(
                read_saved(done, key, study, shape, size) if comm.rank == 0 else None
            )
            if damaged and comm.rank == 0:
                log(f"{done}: {damaged}; this mesh is run again")
            if saved is not None:
                rows += [{**r, "session": saved["session"]} for r in saved["rows"]]
                sessions.append(saved["session"])
                continue
            if ref is None:
                ref = reference_run(study, study.size, h, steps, solver, folder, comm, log)
            if not warm:  # compile this cell type's forms before anything is timed
                warm_up(study, options, h, solver, comm)
                warm = True
            new = run_mesh(study, shape, options, size, ref, h, steps, solver, folder, comm, log)
            record = {"fingerprint": key, "session": session, "rows": new}
            text = json.dumps(record, indent=1) + "\n"
            try:
                collective(comm, lambda: write_owned(done, lambda tmp: tmp.write_text(text)), done)
            except OutputError as exc:
                if not damaged:
                    raise
                if comm.rank == 0:  # someone else's file now: kept; the rows are in the report
                    log(f"{exc}; the mesh's new rows are not saved")
            rows += [{**r, "session": session} for r in new]
            sessions.append(session)
    reference = {"size": 2 * study.size, "dofs": ref["dofs"] if ref else None}
    return {
        "rows": rows,
        "reference": reference,
        "h": h,
        "end_time": steps * h,
        "sessions": sorted(set(sessions)),
    }


ROW_NUMBERS = ("spacing_m", "wall_time_s", "end_time_s", "cost_s_per_s")  # finite, >= 0
ROW_COUNTS = ("size", "nodes", "cells", "dofs", "steps")  # whole numbers >= 0


def row_problem(row: dict, study: Study, shape: str, size: int) -> str | None:
    """Why a saved row (run_mesh's) is not one of this mesh's runs (None: it is)."""
    if not isinstance(row, dict):
        return "holds a row that is not an object"
    errors = [f"{name}_{kind}" for name in GRADED for kind in ("max", "mean")]
    keys = ("case", "algorithm", "shape", "status", "diverged_time_s", *ROW_NUMBERS)
    missing = [k for k in (*keys, *ROW_COUNTS, *errors) if k not in row]
    if missing:
        return f"holds a row without {missing[0]}"
    if (row["case"], row["shape"], row["size"]) != (study.name, shape, size):
        return "holds a row of another case or mesh"
    if row["algorithm"] not in ALGORITHMS or not isinstance(row["status"], str):
        return "holds a row whose algorithm or status is not one of ours"
    if not all(finite(row[k]) and row[k] >= 0 for k in ROW_NUMBERS) or row["end_time_s"] <= 0:
        return "holds a row whose times are not finite numbers >= 0"
    if not all(type(row[k]) is int and row[k] >= 0 for k in ROW_COUNTS):
        return "holds a row whose sizes are not whole numbers >= 0"
    if not all(row[k] is None or real(row[k]) for k in (*errors, "diverged_time_s")):
        return "holds a row whose metrics are not numbers"
    return None


def read_saved(
    path: Path, key: str, study: Study, shape: str, size: int
) -> tuple[dict | None, str | None]:
    """(record, problem) of a mesh graded before (rows-SHAPE-SIZE.json: fingerprint, session,
    rows): the record if the file exists, carries the fingerprint `key` and holds one
    well-formed row per algorithm of this mesh, else None so that the mesh is run again; the
    problem says in a few words why a file that exists cannot be used (None when it can, or
    when it holds the rows of other inputs)."""
    if not path.is_file():
        return None, None
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError) as exc:  # a decoding error is a ValueError
        return None, f"cannot be read ({type(exc).__name__})"
    if not isinstance(record, dict):
        return None, "is not a record of rows"
    if record.get("fingerprint") != key:
        return None, None
    rows = record.get("rows")
    if not isinstance(rows, list):
        return None, "holds no rows"
    problem = next(filter(None, (row_problem(r, study, shape, size) for r in rows)), None)
    if problem is None and sorted(r["algorithm"] for r in rows) != sorted(ALGORITHMS):
        problem = "does not hold one row per algorithm"
    if problem:
        return None, problem
    session = record.get("session")
    return {"rows": rows, "session": session if isinstance(session, str) else "?"}, None
