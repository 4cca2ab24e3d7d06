"""The mesh-sensitivity study (SPEC 9, the paper's future work), which `tissuebench
sensitivity` runs and reports and the leaderboard reads: each algorithm on coarser and
other-shaped meshes, graded on its own mesh against `implicit` on a finer grid. The cases,
meshes, timing and files are described where users read them, in the command's docstring
(workflows/commands/sensitivity.py, its --help).
"""

from __future__ import annotations

import json
import math
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from tissuebench.core import interrupt
from tissuebench.core.fingerprint import fingerprint
from tissuebench.meshes import get_benchmark, get_entry
from tissuebench.meshes.benchmark import CELLS
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.crossmesh import BODY_TOLERANCE, CrossMetrics, Mesh
from tissuebench.solvers import ALGORITHMS, REFERENCE, get_integrator
from tissuebench.solvers.simulate import Run, simulate
from tissuebench.solvers.system import System
from tissuebench.workflows.io.tables import CSVError, read_rows, write_rows
from tissuebench.workflows.io.xdmf import gather_mesh, gather_series, write_series
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, finite, fmt, real
from tissuebench.workflows.output import (
    OutputError,
    collective,
    write_owned,
)

NAME = "mesh-sensitivity"
MARKER = "# Mesh sensitivity"
GRADED = ("relative_error", "interior_error", "interior_error_nodal")


@dataclass(frozen=True)
class Study:
    """One case of the study: a benchmark, material and options; the runs' finest grid size N
    (N/4 must be a valid size) and the reference on 2N; h and T are the benchmark's."""

    name: str
    benchmark: str
    material: str
    size: int
    options: dict = field(default_factory=dict)
    end_time: float | None = None  # s; None: the benchmark's

    @property
    def sizes(self) -> tuple[int, int, int]:
        return (self.size // 4, self.size // 2, self.size)


STUDIES = (
    Study("block-MP1", "block", "MP1", 40, {"needle_width": 0.2}),
    Study("rod-MP3", "rod", "MP3", 8),
)
# --quick: the same cases on small grids and 1 s (a check of the workflow, never the results)
QUICK = (
    Study("block-MP1", "block", "MP1", 8, {"needle_width": 0.2}, end_time=1.0),
    Study("rod-MP3", "rod", "MP3", 4, end_time=1.0),
)


def shapes(gdim: int) -> dict[str, dict]:
    """The three mesh shapes of the study: {label: benchmark options}."""
    grid, simplex = CELLS[gdim]
    return {
        f"{grid} grid": {},
        f"{simplex} grid": {"cell": simplex},
        f"{simplex} unstructured": {"cell": simplex, "mesh": "unstructured"},
    }


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


# --- the report --------------------------------------------------------------------------------


def own_error(rows: list[dict], study: Study) -> float:
    """The reference's own error: E_i max of `implicit` on the grid of size N against 2N."""
    grid = next(iter(shapes(get_entry(study.benchmark).gdim)))
    return next(
        r["interior_error_max"]
        for r in rows
        if r["algorithm"] == REFERENCE and r["shape"] == grid and r["size"] == study.size
    )


def trade_offs(rows: list[dict], floor: float) -> list[tuple[dict, dict, str, float]]:
    """Where a coarser mesh with `implicit` beats, or does not beat, a finer mesh with another
    algorithm at no more cost: for every finished run of another algorithm, the implicit run
    of the same shape on a coarser mesh with the smallest E_i max among those that cost no
    more. (fast, exact, winner, ratio): winner "coarse + exact", "fine + fast" or "none" when
    both E_i are below `floor` (the reference's own error); ratio = larger / smaller E_i."""
    found = []
    for fast in rows:
        if fast["algorithm"] == REFERENCE or fast["status"] != "ok":
            continue
        exact = [
            r
            for r in rows
            if r["algorithm"] == REFERENCE
            and r["shape"] == fast["shape"]
            and r["size"] < fast["size"]
            and r["cost_s_per_s"] <= fast["cost_s_per_s"]
        ]
        if not exact:
            continue
        best = min(exact, key=lambda r: r["interior_error_max"])
        a, b = best["interior_error_max"], fast["interior_error_max"]
        winner = "none" if max(a, b) < floor else "coarse + exact" if a < b else "fine + fast"
        found.append((fast, best, winner, max(a, b) / min(a, b)))
    return found


def trade_off_lines(found: list[tuple[dict, dict, str, float]]) -> list[str]:
    """The table rows of trade_offs, then a summary paragraph."""
    lines = []
    for fast, best, winner, ratio in found:
        verdict = (
            "no finding: both below the reference's own error"
            if winner == "none"
            else f"**{winner} wins** ({ratio:.3g}x smaller E_i)"
        )
        lines.append(
            f"| {fast['shape']} | implicit, size {best['size']}: E_i max "
            f"{best['interior_error_max']:.3g}, {best['cost_s_per_s']:.3g} s/s | "
            f"{fast['algorithm']}, size {fast['size']}: E_i max {fast['interior_error_max']:.3g}, "
            f"{fast['cost_s_per_s']:.3g} s/s | {verdict} |"
        )
    if not lines:
        return ["| — | no implicit run on a coarser mesh costs as little | | |"]
    lines.append("")
    for winner in ("coarse + exact", "fine + fast", "none"):
        mine = [(f, r) for f, _, w, r in found if w == winner]
        if not mine:
            continue
        against = sorted({f["algorithm"] for f, _ in mine}, key=list(ALGORITHMS).index)
        ratios = [r for _, r in mine]
        what = "no finding" if winner == "none" else f"**{winner}** wins"
        lines.append(
            f"- {what} in {len(mine)} of {len(found)} pairings (against "
            f"{', '.join(against)}), by {min(ratios):.3g}x to {max(ratios):.3g}x in E_i max."
        )
    return lines


def timed(studies: list[Study], results: dict) -> str:
    """When the runs were timed: one session, or (a resumed study) which."""
    sessions = sorted({t for s in studies for t in results[s.name]["sessions"]})
    if len(sessions) == 1:
        return f"every run timed in one session, {sessions[0]}."
    return (
        f"runs timed in {len(sessions)} sessions ({', '.join(sessions)}: the study was "
        "resumed), so that ratios across sessions carry the machine's drift."
    )


def markdown(studies: list[Study], results: dict, quick: bool, ranks: int) -> str:
    lines = [
        f"{MARKER}{' (quick check, not the results)' if quick else ''}",
        "",
        "How sensitive each algorithm is to mesh density and mesh shape (the paper's future "
        "work; SPEC 9), written by `tissuebench sensitivity`. Every run is graded on its own "
        "mesh against `implicit` on the grid of twice the finest size (E_n at the reference's "
        "nodes, E_i by quadrature on the reference's cells with u′ located in the candidate's "
        "mesh). The reference's own error is `implicit` on the finest grid against it: below "
        "it, no difference is a finding. Cost: the wall time of the System's assembly, the "
        "integrator's set-up and its time loop, per simulated second, "
        f"{ranks} MPI process(es); {timed(studies, results)}",
        "",
    ]
    for study in studies:
        res = results[study.name]
        rows = res["rows"]
        floor = own_error(rows, study)
        entry = get_entry(study.benchmark)
        options = ", ".join(f"{k} = {v}" for k, v in study.options.items()) or "no options"
        lines += [
            f"## {study.name}",
            "",
            f"{study.benchmark}, {study.material}, {options}; h = {fmt(res['h'], '.4g')} s, "
            f"T = {fmt(res['end_time'], '.4g')} s; sizes {', '.join(map(str, study.sizes))} "
            f"(spacing {', '.join(fmt(entry.cell_size(s), '.4g') for s in study.sizes)} m); "
            f"reference: implicit on the {CELLS[entry.gdim][0]} grid of size "
            f"{res['reference']['size']}. **Reference's own error (E_i max, implicit at size "
            f"{study.size}): {floor:.3g}.**",
            "",
            f"![{study.name}]({NAME}-{study.name}.png)",
            "",
            "| algorithm | mesh | size | nodes | E_n max | E_i max | E_i time-mean | cost (s/s) "
            "| status |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in sorted(
            rows, key=lambda r: (list(ALGORITHMS).index(r["algorithm"]), r["shape"], r["size"])
        ):
            status = (
                "ok" if r["status"] == "ok" else f"diverged at {fmt(r['diverged_time_s'], '.3g')} s"
            )
            lines.append(
                f"| {r['algorithm']} | {r['shape']} | {r['size']} | {r['nodes']} | "
                f"{fmt(r['relative_error_max'])} | {fmt(r['interior_error_max'])} | "
                f"{fmt(r['interior_error_mean'])} | {fmt(r['cost_s_per_s'])} | {status} |"
            )
        diverged = [r for r in rows if r["status"] != "ok"]
        if diverged:
            lines += [
                "",
                f"Diverged at h = {fmt(res['h'], '.4g')} s (an explicit scheme's critical step "
                "shrinks with the cells, faster on simplices: `tissuebench stability`; the "
                "errors above are up to the divergence): "
                + "; ".join(
                    f"{r['algorithm']} on the {r['shape']} of size {r['size']} at "
                    f"t = {fmt(r['diverged_time_s'], '.3g')} s"
                    for r in diverged
                )
                + ".",
            ]
        lines += [
            "",
            "### Coarse and exact against fine and fast, at no more cost",
            "",
            "For every finished run of another algorithm on a finer mesh, the most accurate "
            "`implicit` run of the same shape on a coarser mesh that costs no more (E_i max). "
            "These runs are small: their costs are mostly fixed costs, and single timings "
            "under 0.2 s vary by tens of per cent between sessions.",
            "",
            "| shape | coarse + implicit | fine + faster | verdict |",
            "|---|---|---|---|",
            *trade_off_lines(trade_offs(rows, floor)),
            "",
        ]
    return "\n".join(lines)


def write_csv(path: Path, rows: list[dict]) -> None:
    """mesh-sensitivity.csv: the rows' keys as its header (io/tables.py)."""
    write_rows(path, rows, empty_nan=False)


LINES = ("-", "--", ":")  # the shapes' line styles, in the order of shapes()


@interrupt.drawing  # a signal while drawing: raised once drawn (core/interrupt.py)
def plot(path: Path, study: Study, rows: list[dict]) -> None:
    """E_i max and time-mean against spacing (colour: algorithm; line: mesh shape; diverged
    runs left out), and E_i max against cost; the reference's own error as a grey line."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    fig = Figure(figsize=(15, 5.4), layout="constrained")
    axes = fig.subplots(1, 3)
    colours = {name: f"C{k}" for k, name in enumerate(ALGORITHMS)}
    shape_names = list(dict.fromkeys(r["shape"] for r in rows))
    line = dict(zip(shape_names, LINES, strict=False))
    keys = ("interior_error_max", "interior_error_mean", "interior_error_max")
    for algorithm in ALGORITHMS:
        for shape in shape_names:
            mine = sorted(
                (
                    r
                    for r in rows
                    if r["algorithm"] == algorithm and r["shape"] == shape and r["status"] == "ok"
                ),
                key=lambda r: r["spacing_m"],
            )
            xs = ([r["spacing_m"] for r in mine],) * 2 + ([r["cost_s_per_s"] for r in mine],)
            for ax, key, x in zip(axes, keys, xs, strict=True):
                ax.plot(
                    x,
                    [r[key] for r in mine],
                    line[shape],
                    marker="o",
                    ms=4,
                    color=colours[algorithm],
                )
    grid = shape_names[0]
    implicit_n = next(
        r
        for r in rows
        if r["algorithm"] == REFERENCE and r["shape"] == grid and r["size"] == study.size
    )
    spacings = sorted({r["spacing_m"] for r in rows})
    for ax, key, what in zip(
        axes, keys, ("max over time", "time-mean", "max over time"), strict=True
    ):
        ax.axhline(implicit_n[key], color="0.5", lw=1.2, zorder=0)
        ax.text(
            0.01,
            implicit_n[key],
            " reference's own error (implicit, grid of size N)",
            color="0.35",
            va="bottom",
            fontsize=7,
            transform=ax.get_yaxis_transform(),
        )
        ax.set_yscale("log")
        ax.set_xscale("log")
        ax.set_ylabel(f"E_i, {what}")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[:2]:
        ax.xaxis.set_major_locator(FixedLocator(spacings))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticklabels([f"{x:.4g}" for x in spacings])
        ax.set_xlabel("mesh spacing (m)")
    axes[2].xaxis.set_minor_formatter(NullFormatter())  # decades only: no crowded labels
    axes[2].set_xlabel("cost: wall time per simulated second (s/s)")
    handles = [Line2D([], [], color=colours[a], marker="o", ms=4, label=a) for a in ALGORITHMS]
    handles += [Line2D([], [], color="k", ls=line[s], label=s) for s in shape_names]
    fig.legend(handles=handles, loc="outside right center", fontsize=8)
    diverged = sorted(
        f"{r['algorithm']} ({r['shape']}, {r['size']})" for r in rows if r["status"] != "ok"
    )
    title = (
        f"Mesh sensitivity, {study.name}: E_i of each run on its own mesh against implicit on "
        f"the grid of size {2 * study.size}"
    )
    if diverged:
        title += "\nleft out, diverged: " + "; ".join(diverged)
    fig.suptitle(title, fontsize=10, wrap=True)
    fig.savefig(path, dpi=110)


def leaderboard_boards(out: Path, log: Callable[[str], None] = lambda line: None) -> list[tuple]:
    """The full study's runs in OUT as leaderboard cases: [(Board, [Row])], one
    per case (none without a full study's report). Nothing read is trusted: a report or table
    that cannot be read, and each row of the table that is not a run of the study, is left
    out with one line to `log`."""
    md, table = out / f"{NAME}.md", out / f"{NAME}.csv"
    if not (md.is_file() and table.is_file()):
        return []
    try:
        first = md.read_text(errors="replace").split("\n", 1)[0]
        if first == MARKER:
            every = read_rows(table, errors="replace")
    except (OSError, CSVError) as exc:
        log(f"{md.parent / NAME}.md and .csv: cannot be read ({type(exc).__name__}); left out")
        return []
    if first != MARKER:
        if not first.startswith(MARKER):
            log(f"{md}: not a report of tissuebench sensitivity; its runs are left out")
        return []  # a quick check: never on the leaderboard
    boards = []
    for study in STUDIES:
        mine = []
        for number, raw in enumerate(every, start=1):
            if raw.get("case") != study.name:
                continue
            try:
                mine.append(study_row(study, raw))
            except (TypeError, ValueError) as exc:
                log(f"{table}, row {number}: not a run of the study ({exc}); left out")
        if not mine:
            continue
        sessions = sorted({r["session"] for r in mine})
        entry = get_entry(study.benchmark)
        options = ", ".join(f"{k} = {v}" for k, v in study.options.items())
        board = Board(
            f"{NAME}-{study.name}",
            study.benchmark,
            study.material,
            "linear",
            options=study.options,
            simulators=(),
            description=f"`tissuebench sensitivity` ({NAME}.md): {study.benchmark}, "
            f"{study.material}{', ' + options if options else ''}, linear; ours on grids of "
            f"size {', '.join(map(str, study.sizes))} in three shapes, graded on their own "
            f"meshes against implicit on the {CELLS[entry.gdim][0]} grid of size "
            f"{2 * study.size}. Timed in that study's session ({', '.join(sessions)}), not "
            "this leaderboard's; E_s not graded.",
        )
        rows = []
        for r in mine:
            rows.append(
                Row(
                    board.name,
                    f"{r['algorithm']} ({r['shape']}, size {r['size']})",
                    "tissuebench",
                    f"{r['algorithm']}, linear (SPEC 3), on its own mesh (SPEC 9)",
                    f"{r['shape']}: {r['nodes']} nodes",
                    r["dofs"],
                    r["status"],
                    None
                    if r["status"] == "ok"
                    else f"diverged at t = {fmt(r['diverged_time_s'], '.3g')} s",
                    r["errors"],
                    r["wall_time_s"],
                    r["end_time_s"],
                    f"tissuebench sensitivity, {', '.join(sessions)}",
                )
            )
        boards.append((board, rows))
    return boards


SESSION = re.compile(r"[0-9A-Za-z :+\-./]{1,40}")  # a session's time, as main writes it


def study_row(study: Study, r: dict) -> dict:
    """One row of mesh-sensitivity.csv (text) as numbers, checked to be a run of the study:
    its algorithm, shape and size, counts >= 0, finite times >= 0 (s), errors empty or "nan"
    (None: never ranked) or finite numbers >= 0. ValueError or TypeError says what is wrong."""

    def count(key):
        value = int(r.get(key))
        if value < 0:
            raise ValueError(f"{key} is negative")
        return value

    def seconds(key, positive=False):
        value = float(r.get(key))
        if not math.isfinite(value) or value < 0 or (positive and value == 0):
            raise ValueError(f"{key} is not a finite number of seconds > 0")
        return value

    def error(key):
        text = (r.get(key) or "").strip()
        if text.lower() in ("", "nan"):
            return None
        value = float(text)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{key} is not a finite number >= 0")
        return value

    if r.get("algorithm") not in ALGORITHMS:
        raise ValueError(f"algorithm {str(r.get('algorithm'))[:40]!r} is not one of ours")
    if r.get("shape") not in shapes(get_entry(study.benchmark).gdim):
        raise ValueError(f"shape {str(r.get('shape'))[:40]!r} is not one of the study's")
    if count("size") not in study.sizes:
        raise ValueError(f"size {r.get('size')} is not one of the study's")
    status = r.get("status")
    if status not in ("ok", "diverged"):
        raise ValueError(f"status {str(status)[:40]!r} is neither ok nor diverged")
    return {
        "algorithm": r["algorithm"],
        "shape": r["shape"],
        "size": count("size"),
        "nodes": count("nodes"),
        "dofs": count("dofs"),
        "status": status,
        "diverged_time_s": None if status == "ok" else seconds("diverged_time_s"),
        "errors": {k: error(k) for k in error_keys()},
        "wall_time_s": seconds("wall_time_s"),
        "end_time_s": seconds("end_time_s", positive=True),
        "session": r["session"] if SESSION.fullmatch(r.get("session") or "") else "?",
    }
