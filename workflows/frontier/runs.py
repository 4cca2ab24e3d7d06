"""The real-time frontier of SPEC 11: for each nearly incompressible case (and the
compressible rod as the control), every scheme (solvers/schemes/) with the implicit reference
algorithm, the paper's explicit-lumped (at h = 1/30 s and with the sub-steps that keep it
stable) and explicit (consistent mass, damping alpha M + beta K_0 as the truth's, with the
sub-steps that keep it stable, on the two smaller sizes), on four mesh sizes, graded against
the truth (SPEC 10: E_i in m^2 on the block, m^3 on the rod) and timed on one core. The
frontier of a case is the smallest E_i reached at a cost of at most 1 s of wall time per
simulated second.

Cost: the time loop's wall seconds (every sub-step) over the simulated seconds T; the set-up
(assembly, factorisation, the critical step's eigenvalues) is paid once per simulation and
is reported beside it: whole_s, the set-up and the loop (s), and whole_cost, whole_s / T, the
whole run's cost as the leaderboard counts every row's (compare's --wall-time: our study's
rows count the System's assembly, the integrator's set-up and the loop alike). One rank: the
cost a surgical simulator pays on one core.

Rows are written to DIR/frontier.csv as each run ends, so an interrupted study keeps what it
finished and resumes from it.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, cast

from mpi4py import MPI

import numpy as np

from tissuebench.meshes import get_benchmark, get_entry
from tissuebench.meshes.benchmark import CELLS
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.series import series_of
from tissuebench.metrics.truth import grade_truth, own_error
from tissuebench.solvers.schemes import SCHEMES, scheme_label
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.substeps import sub_stepped
from tissuebench.solvers.system import System
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.store import size_of
from tissuebench.workflows.compare.grading import load_truth
from tissuebench.workflows.io.tables import append_row, ends_whole, write_rows
from tissuebench.workflows.io.tables import read_rows as read_csv
from tissuebench.workflows.io.xdmf import gather_series

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples

# the cases of SPEC 11, the compressible control last
FRONTIER_CASES = ("block-MP2-w0.2", "block-MP1-w0.2", "rod-MP2", "rod")
# the mesh sizes of each benchmark: its entry's study sizes (four: the finest take more than 1 s
# per simulated s with some schemes, so that the real-time budget falls inside the range
# tried); quick, the first of them
# explicit-lumped at the benchmark's step ("large time-step"), and with the sub-steps that keep
# it stable; explicit (consistent mass, the stiffness-proportional damping beta K_0 that
# explicit-lumped lacks) with the sub-steps that keep it stable; implicit, the reference
RUNS: tuple[tuple[str, int | Literal["auto"]], ...] = (
    ("implicit", 1),
    ("explicit-lumped", 1),
    ("explicit-lumped", "auto"),
    ("explicit", "auto"),
)
# algorithms run on the two smaller sizes only: a sub-step of explicit solves with M + hC/2
# (8 times explicit-lumped's on the rod-MP2 paper grid: 3.3 s against 0.42 s for 10 simulated
# s with 40 and 23 sub-steps), and it costs more than real time already on the second size of
# block-MP2-w0.2 (n = 20: 1.2 to 1.7 s per simulated s); each size doubles the sub-steps and
# multiplies the dofs by 2^d, so that the larger sizes (some 13 and 100 s per simulated s)
# would take most of the study's time and cannot reach the real-time frontier
SMALLER_ONLY = ("explicit",)
# explicit-lumped at h = 1/30 s, whether stable or not, with these schemes only: the paper's
# element and Picinbono's remedy (the paper's question); auto takes k = 1 wherever h is stable
AT_H = ("standard", "penalty")
# the parameters swept on the middle mesh size (the defaults run on every size)
SWEEPS = {
    "hourglass": ("hourglass:c_hg=0.03", "hourglass:c_hg=1"),
    "penalty": ("penalty:k=0", "penalty:k=1", "penalty:nu_p=0.4,k=0.1"),
}
REAL_TIME = 1.0  # s of wall time per simulated second
COLUMNS = (
    "case",
    "benchmark",
    "material",
    "cell",
    "scheme",
    "algorithm",
    "requested",
    "substeps",
    "mesh_size",
    "dofs",
    "critical_dt_s",
    "status",
    "diverged_time",
    "setup_s",
    "loop_s",
    "cost",
    "whole_s",
    "whole_cost",
    "interior_error_mean",
    "interior_error_max",
    "relative_error_mean",
    "relative_error_max",
    "truth_own_error",
    "truth_size",
    "timings",
)


@dataclass(frozen=True)
class Config:
    """One run of the study: a truth case, its benchmark's cell shape and mesh size, a scheme
    (canonical text), an algorithm and its sub-steps (k or "auto")."""

    case: str
    cell: str
    scheme: str
    algorithm: str
    substeps: int | Literal["auto"]
    mesh_size: int

    def key(self) -> tuple:
        """The row key: what identifies the run in frontier.csv."""
        return (
            self.case,
            self.cell,
            self.scheme,
            self.algorithm,
            str(self.substeps),
            self.mesh_size,
        )


def configs(cases: tuple[str, ...] = FRONTIER_CASES, quick: bool = False) -> Iterator[Config]:
    """Every run of the study, in order."""
    for case in cases:
        benchmark = CASES[case][0]
        sizes = get_entry(benchmark).study_sizes[: 1 if quick else None]
        gdim = get_entry(benchmark).gdim
        for cell in CELLS[gdim]:
            schemes = [name for name, s in SCHEMES.items() if cell in s.cells]
            for size in sizes:
                chosen = [scheme_label(s) for s in schemes]
                if size == sizes[len(sizes) // 2] and not quick:
                    chosen += [scheme_label(s) for name in schemes for s in SWEEPS.get(name, ())]
                for scheme in chosen:
                    for algorithm, k in RUNS:
                        if k == 1 and algorithm != "implicit" and not scheme.startswith(AT_H):
                            continue
                        if algorithm in SMALLER_ONLY and size not in sizes[:2]:
                            continue
                        yield Config(case, cell, scheme, algorithm, k, size)


def benchmark_of(config: Config, comm: MPI.Comm):
    """The benchmark of a config: the case's load scale and needle width, its cell shape."""
    name, _, _, scale, width = CASES[config.case]
    options: dict[str, Any] = {"load_scale": scale}
    if width is not None:
        options["needle_width"] = width
    if config.cell != CELLS[get_entry(name).gdim][0]:
        options["cell"] = config.cell
    return get_benchmark(name, mesh_size=config.mesh_size, comm=comm, **options)


def run_config(config: Config, truth, comm: MPI.Comm = MPI.COMM_SELF) -> dict:
    """Run one config and grade it against the truth (TruthSamples): its row (COLUMNS)."""
    benchmark, material, *_ = CASES[config.case]
    bench = benchmark_of(config, comm)
    start = time.perf_counter()
    system = System(bench, material, scheme=config.scheme)
    integrator, k, critical = sub_stepped(config.algorithm, system, bench.dt, config.substeps)
    setup = time.perf_counter() - start
    steps = round(bench.end_time / bench.dt)
    try:
        run = simulate(integrator, steps, bench.extent, config.algorithm)
    finally:
        integrator.destroy()
    row = {
        "case": config.case,
        "benchmark": benchmark,
        "material": material,
        "cell": config.cell,
        "scheme": config.scheme,
        "algorithm": config.algorithm,
        "requested": str(config.substeps),
        "substeps": k,
        "mesh_size": config.mesh_size,
        "dofs": system.num_dofs(),
        "critical_dt_s": critical,
        "status": run.status,
        "diverged_time": run.diverged_time,
        "setup_s": setup,
        "loop_s": run.wall_time_s,
        "cost": run.wall_time_s / (steps * bench.dt),
        "whole_s": setup + run.wall_time_s,
        "whole_cost": (setup + run.wall_time_s) / (steps * bench.dt),
        "truth_own_error": own_error(truth),
        "truth_size": size_of(truth),
        "timings": 1,
    }
    for name in ("interior_error", "relative_error"):
        row[f"{name}_mean"] = row[f"{name}_max"] = math.nan
    if run.status == "ok":  # a diverged run did not reach T: it has no reading
        gathered = gather_series(system.V, {"displacement": run.u})
        assert gathered is not None  # serial (COMM_SELF): rank 0's
        mesh, data = gathered
        points, cells, cell_type = mesh
        gdim = system.gdim
        series = series_of(
            Path(f"{config.case}-{config.scheme}-{config.algorithm}.xdmf"),
            "displacement",
            points[:, :gdim],
            cells,
            cell_type,
            np.arange(len(run.u)) * bench.dt,
            data["displacement"][:, :, :gdim],
        )
        grading = grade_truth(truth, series, comm, surface=False)  # E_i and E_n
        for name in ("interior_error", "relative_error"):
            peak, mean = summarize(grading.curves[name])
            row[f"{name}_max"], row[f"{name}_mean"] = peak, mean
    return row


TEXT = ("case", "benchmark", "material", "cell", "scheme", "algorithm", "requested", "status")


def _parsed(raw: dict) -> dict | None:
    """One row of a frontier.csv with its numbers as floats (ints where whole), NaN for empty,
    or None if a cell is missing or is not a number where one belongs (a row cut short)."""
    row: dict[str, Any] = {}
    for key, value in raw.items():
        if key is None:  # cells past the header's (a file of an older version)
            continue
        if not isinstance(value, str):
            return None  # the row ended before this column
        if key in TEXT:
            row[key] = value
        elif value == "":
            row[key] = math.nan
        else:
            try:
                number = float(value)
                whole = key in ("substeps", "mesh_size", "dofs", "timings")
                row[key] = int(number) if whole else number
            except (ValueError, OverflowError):
                return None
    set_whole(row)  # a file of an older version has no whole-run time: its set-up and loop
    return {k: row.get(k, math.nan) for k in COLUMNS}


def set_whole(row: dict) -> None:
    """Set a row's whole_s (s: its set-up and its time loop) and whole_cost (s per simulated
    s) from its setup_s, loop_s and cost (the loop's wall s per simulated s; NaN where one
    is missing)."""
    setup, loop, cost = (row.get(k, math.nan) for k in ("setup_s", "loop_s", "cost"))
    simulated = loop / cost if cost and math.isfinite(cost) else math.nan
    row["whole_s"] = setup + loop
    row["whole_cost"] = row["whole_s"] / simulated if simulated else math.nan


def read_rows(path: Path, log: Callable[[str], None] | None = None) -> list[dict]:
    """The rows of a frontier.csv, numbers as floats (ints where whole), NaN for empty. A row
    that is not whole (a cell missing or not a number, or the file's last line without its
    end: cut by a kill or a full disk) is left out, said in one line to `log` (default
    stderr), so that the study runs it again."""
    if not path.is_file():
        return []
    raw_rows = read_csv(path, errors="replace")
    cut = not ends_whole(path)
    rows = []
    for k, raw in enumerate(raw_rows):
        row = _parsed(raw)
        if row is not None and not (cut and k == len(raw_rows) - 1):
            rows.append(row)
    if len(rows) < len(raw_rows):
        left = len(raw_rows) - len(rows)
        (log or _stderr)(
            f"{path}: {left} row{'s' if left > 1 else ''} cut short or unreadable left out "
            "(`tissuebench frontier` runs them again)"
        )
    return rows


def _stderr(line: str) -> None:
    print(f"tissuebench: {line}", file=sys.stderr, flush=True)


def row_key(row: dict) -> tuple:
    """The key of a row, as Config.key()."""
    return (
        row["case"],
        row["cell"],
        row["scheme"],
        row["algorithm"],
        row["requested"],
        row["mesh_size"],
    )


def run_study(
    out: Path,
    cases: tuple[str, ...] = FRONTIER_CASES,
    quick: bool = False,
    log: Callable[[str], None] = print,
) -> list[dict]:
    """Every config not yet in out/frontier.csv, each appended as it ends; returns all rows.
    Rows graded against another truth of their case than today's (its own error differs) are
    dropped and run again. Serial (one core)."""
    comm = MPI.COMM_SELF
    path = out / "frontier.csv"
    rows = read_rows(path, log)
    # serial (COMM_SELF): rank 0's truths, never None
    truths = {case: cast("TruthSamples", load_truth(case, comm)) for case in cases}
    # a row graded against another truth (computed again since: its own error differs) is stale
    stale = [
        r
        for r in rows
        if r["case"] in truths
        and not math.isclose(r["truth_own_error"], own_error(truths[r["case"]]), rel_tol=1e-9)
    ]
    if stale:
        log(f"{path}: {len(stale)} rows were graded against another truth of their case: run again")
        rows = [r for r in rows if r not in stale]
        write_rows(path, rows, COLUMNS)
    if rows:  # today's columns (a file of an older version may lack some)
        write_rows(path, rows, COLUMNS)
    done = {row_key(r) for r in rows}
    todo = [c for c in configs(cases, quick) if c.key() not in done]
    for i, config in enumerate(todo, 1):
        row = run_config(config, truths[config.case], comm)
        append_row(path, row, COLUMNS)
        rows.append(row)
        log(
            f"[{i}/{len(todo)}] {config.case} {config.cell} n={config.mesh_size} {config.scheme} "
            f"{config.algorithm} k={row['substeps']}: {row['status']}, E_i mean "
            f"{row['interior_error_mean']:.3g}, {row['cost']:.3g} s per simulated s"
        )
    return rows


# --- timing again where the budget is decided ----------------------------------------------------

RETIME = (0.1, 20.0)  # s per simulated s: the finished runs timed again, near the budget of 1


def loop_seconds(config: Config) -> float:
    """The wall time (s) of one config's time loop, run again without grading. Serial."""
    benchmark, material, *_ = CASES[config.case]
    bench = benchmark_of(config, MPI.COMM_SELF)
    system = System(bench, material, scheme=config.scheme)
    integrator, _, _ = sub_stepped(config.algorithm, system, bench.dt, config.substeps)
    try:
        run = simulate(integrator, round(bench.end_time / bench.dt), bench.extent, keep=False)
    finally:
        integrator.destroy()
    return run.wall_time_s


def retime(out: Path, log: Callable[[str], None] = print) -> list[dict]:
    """Time again, once, every finished run of out/frontier.csv timed only once whose cost lies
    within RETIME, and keep the smaller of its two times (other jobs on the machine only add
    time): a cost near the budget is then not decided by one noisy timing. Rewrites the file
    after each run; returns all rows."""
    path = out / "frontier.csv"
    rows = read_rows(path, log)
    low, high = RETIME
    todo = [
        r
        for r in rows
        if r["status"] == "ok"
        and low <= r["cost"] <= high
        and not (isinstance(r["timings"], int) and r["timings"] >= 2)
    ]
    for i, r in enumerate(todo, 1):
        k = r["requested"] if r["requested"] == "auto" else int(r["requested"])
        config = Config(r["case"], r["cell"], r["scheme"], r["algorithm"], k, r["mesh_size"])
        seconds = loop_seconds(config)
        simulated = r["loop_s"] / r["cost"]
        before = r["cost"]
        r["loop_s"] = min(r["loop_s"], seconds)
        r["cost"] = r["loop_s"] / simulated
        set_whole(r)
        r["timings"] = 2
        write_rows(path, rows, COLUMNS)
        again = seconds / simulated
        log(f"[{i}/{len(todo)}] {run_words(r)}: {before:.3g}, then {again:.3g} s per simulated s")
    return rows


def run_words(r: dict) -> str:
    """A row's run in a few words."""
    what = f"{r['scheme']} {r['algorithm']} ({r['requested']})"
    return f"{r['case']} {r['cell']} n={r['mesh_size']} {what}"


# --- the remedy's cost against Q1's, measured side by side ---------------------------------------

PAIR_REPEATS = 5  # alternating runs of each; the median of each is compared


def side_by_side(case: str, repeats: int = PAIR_REPEATS) -> list[dict]:
    """Q1 and mean-dilatation on the paper's grid of a case, each with implicit and with
    explicit-lumped (auto sub-steps), run in turn `repeats` times each (Q1, remedy, Q1, ...)
    so that a busy machine slows both alike: per algorithm, the median time loop of each (s)
    and their ratio. Serial."""
    from tissuebench.workflows.frontier.report import paper_size

    benchmark = CASES[case][0]
    cell = CELLS[get_entry(benchmark).gdim][0]
    rows = []
    pairs: tuple[tuple[str, int | Literal["auto"]], ...] = (
        ("implicit", 1),
        ("explicit-lumped", "auto"),
    )
    for algorithm, k in pairs:
        loops: dict[str, list[float]] = {"standard": [], "mean-dilatation": []}
        substeps = {}
        for _ in range(repeats):
            for scheme in loops:
                config = Config(case, cell, scheme, algorithm, k, paper_size(benchmark))
                bench = benchmark_of(config, MPI.COMM_SELF)
                system = System(bench, CASES[case][1], scheme=scheme)
                integrator, substeps[scheme], _ = sub_stepped(algorithm, system, bench.dt, k)
                steps = round(bench.end_time / bench.dt)
                try:
                    run = simulate(integrator, steps, bench.extent, algorithm, keep=False)
                finally:
                    integrator.destroy()
                loops[scheme].append(run.wall_time_s / (steps * bench.dt))
        q1, md = (float(np.median(loops[s])) for s in loops)
        rows.append(
            {
                "case": case,
                "algorithm": algorithm,
                "mesh_size": paper_size(benchmark),
                "substeps_q1": substeps["standard"],
                "substeps_remedy": substeps["mean-dilatation"],
                "cost_q1": q1,
                "cost_remedy": md,
                "ratio": md / q1,
                "repeats": repeats,
            }
        )
    return rows
