"""The speed-accuracy leaderboard (`tissuebench leaderboard`): for each case, our algorithms
and models (a study case, workflows/study.py), every outside simulator's variants that pose it
(workflows/simulators/runner.py) and any run a user graded with `compare` into the case's `user/`
folder, in one table and one figure per case: accuracy (time-mean and maximum E_i) against
cost (wall time per simulated second), with the Pareto front marked.

Cost. Ours: M, K and f assembled (System), the integrator set up (factorisations) and its time
loop, in process, 1 rank. CalculiX: the `ccx` process, 1 thread, its file output included.
SfePy and Newton: their setup and time loop in process (see each entry's `timing`). A case's
runs in one session on one machine (Board.session; `--rerun CASE` re-times one case alone); a
user's run carries the wall time they gave compare.

OUT/leaderboard/CASE/ours, OUT/leaderboard/CASE/SIMULATOR: the case's folders (ours);
OUT/leaderboard/CASE/user/NAME: compare folders a user put there (read only);
OUT/leaderboard.md, OUT/leaderboard.csv, OUT/leaderboard/CASE.png: the leaderboard;
OUT/leaderboard.json: its record (workflows/commands/leaderboard.py), from which it is
rendered again.

Nothing read is trusted: a user's folder is checked against its case (dimension and nodes of
the reference it was graded against, h, steps, end time) and each of its rows for its label,
status, wall time and metrics; its reference's fingerprint (compare's summary.json) must be
the case's; what fails is left out with one line saying why. Every text
that was read is escaped for Markdown and HTML in leaderboard.md (md) and for matplotlib in
the figures (plain); a user's label is never taken for a simulator's name. A NaN or infinite
cost or error never ranks.
"""

from __future__ import annotations

import csv
import math
import numbers
import platform
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

from tissuebench.meshes import get_entry
from tissuebench.metrics.table import METRICS
from tissuebench.solvers import interrupt
from tissuebench.workflows.limits import step_count
from tissuebench.workflows.output import read_summary
from tissuebench.workflows.reports.budget import budget_rows
from tissuebench.workflows.simulators import SIMULATORS
from tissuebench.workflows.summary import CaseSummary

E_I = "interior_error"
E_N = "relative_error"


@dataclass
class Board:
    """One leaderboard case: a benchmark posed once (material, model, options at the
    benchmark's default mesh, h and T), our algorithms with `models`, and the simulators."""

    name: str
    benchmark: str
    material: str
    model: str  # the reference's model, and the model the simulators are given
    models: tuple[str, ...] = ("linear",)  # ours
    options: dict = field(default_factory=dict)
    simulators: tuple[str, ...] = tuple(SIMULATORS)
    description: str = ""
    mesh_size: int | None = None  # None: the benchmark's default
    end_time: float | None = None  # s; None: the benchmark's default
    truth: str | None = None  # its SPEC 10 truth case (None: it has none, truth_note says why)
    truth_note: str = ""  # one line on the truth in the case's header (why none, not computed)
    truth_band: float | None = None  # the truth's own E_i max (m^gdim), once it is loaded
    # simulator -> the variants run on this case (a simulator not named: every variant), with
    # `skip_note` saying why the others are not
    variants: dict[str, tuple[str, ...]] = field(default_factory=dict)
    skip_note: str = ""
    sizes: str | None = None  # the series of mesh sizes it belongs to (size_table), if any
    session: str = ""  # when its runs were timed ("" : the session writing the leaderboard)
    machine: str = ""  # where (machine(); "": this machine)


@dataclass
class Row:
    """One graded run of a case."""

    case: str
    label: str
    source: str  # "tissuebench", "CalculiX 2.20", ..., "user"
    description: str
    mesh: str
    dofs: int
    status: str
    reason: str | None
    errors: dict  # "<metric>_max" / "<metric>_mean" -> value or None
    wall_time_s: float | None  # s
    end_time: float  # s, simulated
    timing: str  # "this session" or "reported by the user"
    reference: bool = False
    pareto: dict = field(default_factory=dict)  # "mean" / "max" -> bool
    group: str | None = None  # its own legend entry and marker in the figure (default: source)
    series: str | None = None  # the run's own series file (graded against the truth)
    series_field: str | None = None  # its point field (None: series.DEFAULT_FIELDS)
    truth: dict = field(default_factory=dict)  # TRUTH_KEYS -> value or None, against the truth
    truth_pareto: dict = field(default_factory=dict)  # "mean" / "max" -> bool, against the truth
    truth_note: str | None = None  # why the row has no truth columns
    budget: dict = field(default_factory=dict)  # the error budget (SPEC 10): workflows/leaderboard

    @property
    def cost(self) -> float | None:
        """Wall time per simulated second (s/s); None unless both are finite, T > 0."""
        if not finite(self.wall_time_s) or not finite(self.end_time) or self.end_time <= 0:
            return None
        return self.wall_time_s / self.end_time

    @property
    def cost_per_dof(self) -> float | None:
        """Wall time per simulated second and per dof (µs/s)."""
        return None if self.cost is None or not self.dofs else 1e6 * self.cost / self.dofs


def our_rows(case: str, summary: CaseSummary) -> list[Row]:
    """Rows of our runs from a study case's summary (workflows/summary.py): the cost (s) is
    the System's assembly, the integrator's setup and its time loop."""
    rows = []
    for label, run in summary.runs.items():
        wall = run.wall_time_s + (run.setup_time_s + summary.system_time_s)
        rows.append(
            Row(
                case,
                label,
                "tissuebench",
                f"{run.algorithm}, {run.model} (SPEC 3, 8)",
                "reference",
                int(summary.num_dofs),
                run.status,
                run.reason,
                {k: run.readings.get(k) for k in error_keys()},
                wall,
                float(summary.end_time),
                "this session",
                reference=label == summary.reference,
            )
        )
    return rows


def external_rows(case: str, summary: dict) -> list[Row]:
    """Rows of a simulator folder's summary.json (workflows/simulators/runner.py)."""
    rows = []
    for label, run in summary["runs"].items():
        version = run.get("version") or ""
        source = run["title"] if version in run["title"] else f"{run['title']} {version}"
        rows.append(
            Row(
                case,
                label,
                source,
                f"{run['description']}; timed: {run.get('timing') or 'around its run'}",
                run["mesh"],
                int(run["dofs"]),
                run["status"],
                run.get("reason"),
                {k: run.get(k) for k in error_keys()},
                run.get("wall_time_s"),
                float(summary["end_time"]),
                "this session",
            )
        )
    return rows


# --- what is read from outside ----------------------------------------------------------------

MAX_LABEL = 64  # characters of a user's label, as compare takes it
STATUSES = ("ok", "diverged", "reference diverged", "missing")  # compare's
TOLERANCE = 1e-5  # relative, on h and T: compare's time stamps match to six printed digits


def real(x) -> bool:
    """True for a real number that is not a bool (it may be NaN or infinite)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def finite(x) -> bool:
    """True for a real number (not a bool) that is neither NaN nor infinite."""
    return real(x) and math.isfinite(x)


def one_line(text) -> str:
    """text with every character that is not printable (a newline, a tab) shown escaped:
    safe in a one-line message."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


MARKDOWN = str.maketrans(
    {c: "\\" + c for c in "\\`*_[]|~$#"} | {"&": "&amp;", "<": "&lt;", ">": "&gt;"}
)


def md(text) -> str:
    """text as literal Markdown and HTML on one line (a table cell, a list item): every
    character that is not printable becomes a space, Markdown's inline marks and | are
    backslash-escaped and <, >, & become entities."""
    line = "".join(c if c.isprintable() else " " for c in str(text))
    return line.translate(MARKDOWN)


def plain(text) -> str:
    """text as literal text for matplotlib (no mathtext), on one line."""
    return "".join(c if c.isprintable() else " " for c in str(text)).replace("$", r"\$")


def label_problem(label) -> str | None:
    """Why a user's run label cannot be taken (None: it can): compare's rule, printable text
    of 1 to MAX_LABEL characters without leading or trailing spaces."""
    if not isinstance(label, str) or not 0 < len(label) <= MAX_LABEL:
        return f"its label must be text of 1 to {MAX_LABEL} characters"
    if not label.isprintable() or label.strip() != label:
        return "its label has characters that are not printable or leading/trailing spaces"
    return None


def board_case(board: Board) -> dict:
    """What a run of the board's case is, before anything runs: the reference's dimension
    and nodes, h (s), steps and end time (s)."""
    entry = get_entry(board.benchmark)
    end_time = board.end_time if board.end_time is not None else entry.end_time
    steps = step_count(entry.dt, end_time)
    return {
        "gdim": entry.gdim,
        "nodes": entry.nodes(board.mesh_size or entry.mesh_size),
        "h": entry.dt,
        "steps": steps,
        "end_time": steps * entry.dt,
    }


DEFAULT_OPTIONS = {"load_scale": 1.0, "needle_width": 0.0}  # an option not given is this


def same_options(a: dict, b: dict) -> bool:
    """Whether two benchmark option sets pose the same case (an option not given is its
    default, DEFAULT_OPTIONS; numbers compared to TOLERANCE)."""
    for key in {*a, *b} | set(DEFAULT_OPTIONS):
        x, y = a.get(key, DEFAULT_OPTIONS.get(key)), b.get(key, DEFAULT_OPTIONS.get(key))
        if real(x) and real(y):
            if not math.isclose(x, y, rel_tol=TOLERANCE, abs_tol=1e-12):
                return False
        elif x != y:
            return False
    return True


RERUN_COMPARE = "rerun tissuebench compare (with --force) into it"


def reference_problem(summary: dict, case: dict, board: Board | None = None) -> str | None:
    """Why a compare summary was not graded on the case (None: it was): its h, steps and end
    time, and the fingerprint of its reference (grading.reference_fingerprint: benchmark,
    options, material, model, mesh size, dimension and nodes, or the truth case) against the
    case's. Each reason ends with what to do."""
    h, steps, end = (summary.get(k) for k in ("h", "steps", "end_time"))
    if not (finite(h) and h > 0 and finite(end) and end > 0):
        return f"its summary.json has no positive numbers h and end_time: {RERUN_COMPARE}"
    if not (isinstance(steps, int) and not isinstance(steps, bool) and steps > 0):
        return f"its summary.json has no positive whole number of steps: {RERUN_COMPARE}"
    close = [
        math.isclose(a, b, rel_tol=TOLERANCE) for a, b in ((h, case["h"]), (end, case["end_time"]))
    ]
    if steps != case["steps"] or not all(close):
        return (
            f"graded over {steps} steps of h = {h:.6g} s to T = {end:.6g} s; the case is "
            f"{case['steps']} steps of h = {case['h']:.6g} s to T = {case['end_time']:.6g} s: "
            "run your simulator with that h and T and compare again"
        )
    reference = summary.get("reference")
    fp = reference.get("fingerprint") if isinstance(reference, dict) else None
    if not isinstance(fp, dict) or "source" not in fp:
        return (
            "graded by an older compare, which records no fingerprint of its reference: "
            f"{RERUN_COMPARE}"
        )
    if board is None:
        return None
    where = f"this case ({board.name}: {board.benchmark} {board.material} {board.model}"
    where += f", {board.options or 'default options'}, {case['gdim']}D, {case['nodes']} nodes)"
    move = f"compare against {board.name}'s reference, or move the folder under its own case"
    if fp.get("source") == "truth":
        if fp.get("truth") != board.truth:
            has = f"the truth {board.truth}" if board.truth else "no truth"
            truth = one_line(fp.get("truth"))[:40]
            return f"graded against the truth {truth}; {where} has {has}: {move}"
        return None
    if fp.get("benchmark") is None:
        return (
            f"its reference {one_line(reference.get('file'))[:200]} is neither in a run folder "
            "of ours nor an export's (NAME.reference.xdmf beside NAME.json), so its case is "
            f"not known: compare against the reference `tissuebench export` writes for {board.name}"
        )
    got = (
        f"{fp.get('benchmark')} {fp.get('material')} {fp.get('model')}, "
        f"{fp.get('options') or 'default options'}, {fp.get('dimension')}D, {fp.get('nodes')} nodes"
    )
    size = board.mesh_size or get_entry(board.benchmark).mesh_size
    if (
        fp.get("benchmark") != board.benchmark
        or fp.get("material") != board.material
        or fp.get("model") != board.model
        or not same_options(fp.get("options") or {}, board.options)
        or fp.get("dimension") != case["gdim"]
        or fp.get("nodes") != case["nodes"]
        or (fp.get("mesh_size") is not None and fp.get("mesh_size") != size)
    ):
        return f"graded against {one_line(got)[:160]}, not {where}: {move}"
    return None


def user_mesh(summary: dict) -> tuple[str, int]:
    """A user's run's mesh ("TYPE: C cells, N nodes") and dofs, as compare recorded them
    ("?", 0 when it did not)."""
    cand = summary.get("candidate")
    mesh = cand.get("mesh") if isinstance(cand, dict) else None
    if not isinstance(mesh, dict):
        return "?", 0
    cells, nodes, dofs = (mesh.get(k) for k in ("cells", "nodes", "dofs"))
    kind = mesh.get("cell_type")
    if not (
        isinstance(kind, str) and all(isinstance(x, int) and x > 0 for x in (cells, nodes, dofs))
    ):
        return "?", 0
    plural = {"hexahedron": "hexahedra", "tetrahedron": "tetrahedra"}.get(kind, f"{kind}s")
    return f"{one_line(plural)[:40]}: {cells:,} cells, {nodes:,} nodes", dofs


def run_problem(label, run) -> str | None:
    """Why one run of a compare summary cannot be a row (None: it can): its label, status,
    wall time (s; null when none was given) and every metric (null, or a number >= 0; an
    infinite one only for a run that did not finish)."""
    problem = label_problem(label)
    if problem:
        return f"{problem}: rerun compare with --label NAME (and --force)"
    if not isinstance(run, dict):
        return f"not a run (an object) in summary.json: {RERUN_COMPARE}"
    if run.get("status") not in STATUSES:
        return (
            f"status {one_line(repr(run.get('status')))[:40]} is not one of "
            f"{', '.join(STATUSES)}: {RERUN_COMPARE}"
        )
    if "wall_time_s" not in run:
        return f"no wall_time_s: {RERUN_COMPARE}"
    wall = run["wall_time_s"]
    if wall is not None and not (finite(wall) and wall >= 0):
        return (
            f"wall_time_s {one_line(repr(wall))[:40]} is not a finite number of seconds >= 0: "
            "rerun compare with --wall-time SECONDS (and --force)"
        )
    for key in error_keys():
        if key not in run:
            return f"no {key}: {RERUN_COMPARE}"
        value = run[key]
        if value is None:
            continue
        if not real(value) or math.isnan(value) or value < 0:
            return f"{key} {one_line(repr(value))[:40]} is not a number >= 0: {RERUN_COMPARE}"
        if math.isinf(value) and run["status"] == "ok":
            return f"{key} is infinite in a run whose status is ok: {RERUN_COMPARE}"
    return None


def user_rows(board: Board, folder: Path) -> tuple[list[Row], list[str]]:
    """Rows of the compare folders in folder (CASE/user/NAME/summary.json, kind "compare"),
    and one line for each folder or run left out and why (see reference_problem and
    run_problem). Reads files only; rank 0."""
    rows, skipped = [], []
    folder = Path(folder)
    if not folder.is_dir():
        return rows, skipped
    case = board_case(board)
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        where = one_line(sub)
        summary = read_summary(sub)
        if summary is None:
            skipped.append(
                f"{where}: left out: no readable summary.json of compare: grade the run with "
                f"`tissuebench compare REFERENCE CANDIDATE --out {where}`"
            )
            continue
        if summary.get("kind") != "compare":
            skipped.append(
                f"{where}: left out: its summary.json is not compare's: put only folders that "
                "`tissuebench compare --out` wrote under user/"
            )
            continue
        problem = reference_problem(summary, case, board)
        runs = summary.get("runs")
        if problem is None and (not isinstance(runs, dict) or not runs):
            problem = f"its summary.json has no runs: {RERUN_COMPARE}"
        if problem:
            skipped.append(f"{where}: left out: {problem}")
            continue
        for label, run in runs.items():
            problem = run_problem(label, run)
            if problem:
                skipped.append(f"{where}: run {one_line(label)[:80]} left out: {problem}")
                continue
            if run["wall_time_s"] is None:
                skipped.append(
                    f"{where}: run {one_line(label)[:80]} is listed but not ranked: compare was "
                    "given no wall time; rerun it with --wall-time SECONDS (and --force)"
                )
            mesh, dofs = user_mesh(summary)
            errors = {k: None if run[k] is None else float(run[k]) for k in error_keys()}
            truth = {}
            fp = summary["reference"]["fingerprint"]
            if fp.get("source") == "truth":  # graded against the truth: those are its columns
                truth = {k: errors[k] for k in TRUTH_KEYS}
                errors = dict.fromkeys(errors)
            rows.append(
                Row(
                    board.name,
                    label,
                    "user",
                    f"graded by compare ({sub.name}) against "
                    + (f"the truth {fp.get('truth')}" if truth else "the case's reference"),
                    mesh,
                    dofs,
                    run["status"],
                    None,
                    errors,
                    None if run["wall_time_s"] is None else float(run["wall_time_s"]),
                    float(summary["end_time"]),
                    "reported by the user",
                    truth=truth,
                    **candidate_of(summary),
                )
            )
    return rows, skipped


def candidate_of(summary: dict) -> dict:
    """The series file and field a compare summary records as its candidate ({} when it names
    none): {"series": path, "series_field": field or None}."""
    cand = summary.get("candidate")
    file = cand.get("file") if isinstance(cand, dict) else None
    if not isinstance(file, str) or not file:
        return {}
    field = cand.get("field")
    return {"series": file, "series_field": field if isinstance(field, str) else None}


def error_keys() -> list[str]:
    return [f"{name}_{kind}" for name in METRICS for kind in ("max", "mean")]


def pareto(points: list[tuple[float, float]]) -> list[bool]:
    """For each (cost, error): True when no other point is at most as costly and at most as
    wrong, and better in one of the two (the non-dominated set)."""
    flags = []
    for i, (c, e) in enumerate(points):
        if not (finite(c) and finite(e)):
            flags.append(False)  # a NaN or infinity never ranks
            continue
        dominated = any(
            c2 <= c and e2 <= e and (c2 < c or e2 < e)
            for j, (c2, e2) in enumerate(points)
            if j != i
        )
        flags.append(not dominated)
    return flags


def ranked_error(r: Row, kind: str) -> float | None:
    """The E_i (time-mean or max: kind) by which a row ranks, or None when it does not rank:
    the reference, a run that did not finish, and a NaN, infinite or negative cost or error."""
    error = r.errors.get(f"{E_I}_{kind}")
    if r.reference or r.status != "ok" or not finite(r.cost) or not finite(error):
        return None
    return error if error >= 0 and r.cost >= 0 else None


def mark_pareto(rows: list[Row]) -> None:
    """Set row.pareto["mean"|"max"] on the runs that finished with a finite cost and error,
    the reference left out (its error is zero by definition)."""
    for kind in ("mean", "max"):
        ranked = [r for r in rows if ranked_error(r, kind) is not None]
        flags = pareto([(r.cost, ranked_error(r, kind)) for r in ranked])
        for r in rows:
            r.pareto.pop(kind, None)
        for r, flag in zip(ranked, flags, strict=True):
            r.pareto[kind] = flag


# --- against the truth (SPEC 10) ----------------------------------------------------------------

TRUTH_KEYS = [f"{name}_{kind}" for name in (E_N, E_I) for kind in ("max", "mean")]


def truth_error(r: Row, kind: str) -> float | None:
    """A row's E_i (time-mean or max: kind) against the truth by which it ranks there, or None:
    a run that did not finish, no grade against the truth, and a NaN, infinite or negative
    cost or error. Our `implicit` ranks too: against the truth its error is not zero."""
    error = r.truth.get(f"{E_I}_{kind}")
    if r.status != "ok" or not finite(r.cost) or not finite(error):
        return None
    return error if error >= 0 and r.cost >= 0 else None


def mark_truth_pareto(rows: list[Row]) -> None:
    """Set row.truth_pareto["mean"|"max"] on the rows graded against the truth (truth_error)."""
    for kind in ("mean", "max"):
        ranked = [r for r in rows if truth_error(r, kind) is not None]
        flags = pareto([(r.cost, truth_error(r, kind)) for r in ranked])
        for r in rows:
            r.truth_pareto.pop(kind, None)
        for r, flag in zip(ranked, flags, strict=True):
            r.truth_pareto[kind] = flag


# --- files ------------------------------------------------------------------------------------


def fmt(x: float | None, spec: str = ".3g") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def write_csv(path: Path, rows: list[Row]) -> None:
    names = ["case", "label", "source", "description", "mesh", "dofs", "status", "reason"]
    names += error_keys() + ["wall_time_s", "wall_per_simulated_s", "us_per_dof_per_simulated_s"]
    names += ["timing", "reference", "pareto_mean", "pareto_max"]
    names += [f"truth_{k}" for k in TRUTH_KEYS] + ["truth_pareto_mean", "truth_pareto_max"]
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(names)
        for r in rows:
            out.writerow(
                [r.case, r.label, r.source, r.description, r.mesh, r.dofs, r.status, r.reason or ""]
                + ["" if r.errors[k] is None else repr(r.errors[k]) for k in error_keys()]
                + ["" if x is None else repr(x) for x in (r.wall_time_s, r.cost, r.cost_per_dof)]
                + [r.timing, r.reference, r.pareto.get("mean", False), r.pareto.get("max", False)]
                + ["" if r.truth.get(k) is None else repr(r.truth[k]) for k in TRUTH_KEYS]
                + [r.truth_pareto.get("mean", False), r.truth_pareto.get("max", False)]
            )


LABELLED = 24  # a case with more runs shown labels its Pareto front only


@interrupt.drawing  # a signal while drawing: raised once drawn (solvers/interrupt.py)
def plot_case(path: Path, board: Board, rows: list[Row]) -> None:
    """Two panels, time-mean and maximum E_i against wall time per simulated second (log-log),
    one marker per source, the Pareto front as a dashed staircase, the reference's cost as a
    dotted line (in the legend); labels on every point, or on the front's when more than
    LABELLED are shown; a group of rows (our runs on simplices) has its own marker, and labels
    on the front only. When rows were graded against the truth (SPEC 10), a second row of two
    panels: the same against the truth, with the truth's own error band as a dotted line."""
    from matplotlib.figure import Figure

    against_truth = any(truth_error(r, k) for r in rows for k in ("mean", "max"))
    fig = Figure(figsize=(12, 10.4 if against_truth else 5.2), layout="constrained")
    axes = fig.subplots(2 if against_truth else 1, 2, squeeze=False)
    reference = next((r for r in rows if r.reference), None)
    not_shown = [r for r in rows if not r.reference and (r.status != "ok" or r.cost is None)]
    for ax, kind in zip(axes[0], ("mean", "max"), strict=True):
        _panel(
            ax,
            rows,
            lambda r, kind=kind: ranked_error(r, kind),
            lambda r, kind=kind: r.pareto.get(kind),
            f"{'time-mean' if kind == 'mean' else 'maximum'} interior error E_i, same mesh "
            f"against {plain(reference.label) if reference else 'the reference'}",
        )
        if reference is not None and reference.cost is not None:
            ax.axvline(
                reference.cost,
                ls=":",
                color="0.5",
                lw=1,
                label=f"cost of the reference {plain(reference.label)} (E = 0)",
            )
        ax.legend(fontsize=8, loc="best")
    if against_truth:
        band = board.truth_band
        for ax, kind in zip(axes[1], ("mean", "max"), strict=True):
            _panel(
                ax,
                rows,
                lambda r, kind=kind: truth_error(r, kind),
                lambda r, kind=kind: r.truth_pareto.get(kind),
                f"{'time-mean' if kind == 'mean' else 'maximum'} E_i against the truth "
                f"{plain(board.truth)} (SPEC 10); front labelled",
                front_only=True,
            )
            if finite(band) and band > 0:
                ax.axhline(
                    band, ls=":", color="0.5", lw=1, label=f"the truth's own E_i max {band:.2g}"
                )
            ax.legend(fontsize=8, loc="best")
    title = textwrap.wrap(f"{board.name}: {board.description}", 150)
    if not_shown:
        title += textwrap.wrap(
            f"not shown (failed or diverged): {', '.join(plain(r.label) for r in not_shown)}",
            150,
        )
    fig.suptitle("\n".join(title), fontsize=10)
    fig.savefig(path, format="png", dpi=110)


def _panel(ax, rows: list[Row], error_of, on_front, ylabel: str, front_only=False) -> None:
    """One log-log panel of plot_case: error_of(row) (None: not shown) against cost, one marker
    per source or group, the front (on_front(row)) as a dashed staircase, labels (the front's
    only when front_only: against the truth, runs of one mesh crowd one error)."""
    markers = {"tissuebench": "o", "CalculiX": "s", "SfePy": "^", "Newton": "D", "user": "*"}
    shown = [r for r in rows if (error_of(r) or 0) > 0 and r.cost > 0]
    placed = []
    crowded = front_only or sum(r.group is None for r in shown) > LABELLED
    for source in dict.fromkeys(r.group or r.source for r in shown):
        group = [r for r in shown if (r.group or r.source) == source]
        marker = "v" if group[0].group else markers.get(source.split()[0], "P")
        ax.scatter(
            [r.cost for r in group],
            [error_of(r) for r in group],
            marker=marker,
            s=46,
            label=plain(source),
            zorder=3,
        )
        for r in group:
            if (crowded or r.group) and not on_front(r):
                continue  # a crowd, or a group: only its front is labelled (the table has all)
            xy = (r.cost, error_of(r))
            near = sum(  # labels already placed next to this point go above it
                abs(math.log(xy[0] / p[0])) < 0.25 and abs(math.log(xy[1] / p[1])) < 0.25
                for p in placed
            )
            placed.append(xy)
            ax.annotate(  # a simulator's variant without the simulator's name
                plain(r.label if r.source == "user" else r.label.split(":", 1)[-1]),
                xy,
                textcoords="offset points",
                xytext=(4, 3 + 9 * near),
                fontsize=7,
            )
    front = sorted((r for r in shown if on_front(r)), key=lambda r: r.cost)
    if front:
        ax.step(
            [r.cost for r in front],
            [error_of(r) for r in front],
            where="post",
            ls="--",
            color="0.3",
            lw=1,
            label="Pareto front",
            zorder=2,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("wall time per simulated second (s/s), this machine")
    ax.set_ylabel(ylabel, fontsize=9)
    ax.grid(True, which="both", alpha=0.25)


def table(rows: list[Row]) -> list[str]:
    """The markdown table of one case's rows, the best time-mean E_i first."""
    head = (
        "| run | source | mesh, dofs | status | E_i mean | E_i max | E_n max | wall (s) "
        "| s per simulated s | µs per dof per simulated s | Pareto (mean/max) |"
    )
    lines = [head, "|" + "---|" * 11]

    def key(r: Row):
        mean = r.errors.get(f"{E_I}_mean")
        return (not r.reference, r.status != "ok", mean if finite(mean) else math.inf)

    for r in sorted(rows, key=key):
        status = md(r.status if not r.reason else f"{r.status}: {r.reason}")
        front = "/".join("yes" if r.pareto.get(k) else "-" for k in ("mean", "max"))
        lines.append(
            f"| {md(r.label)}{' (reference)' if r.reference else ''} | {md(r.source)} | "
            f"{md(r.mesh)}, {r.dofs} | {status} | {fmt(r.errors.get(f'{E_I}_mean'))} | "
            f"{fmt(r.errors.get(f'{E_I}_max'))} | {fmt(r.errors.get(f'{E_N}_max'))} | "
            f"{fmt(r.wall_time_s)} | {fmt(r.cost)} | {fmt(r.cost_per_dof)} | {front} |"
        )
    return lines


def truth_table(rows: list[Row]) -> list[str]:
    """The markdown table of one case's rows graded against the truth, the best time-mean E_i
    against the truth first; the same-mesh E_i mean (SPEC 6) beside it, unchanged."""
    head = (
        "| run | source | mesh, dofs | E_i mean, truth | E_i max, truth | E_n max, truth "
        "| E_i mean, same mesh (SPEC 6) | s per simulated s | Pareto against the truth "
        "(mean/max) |"
    )
    lines = [head, "|" + "---|" * 9]
    graded = [r for r in rows if r.truth]

    def key(r: Row):
        mean = r.truth.get(f"{E_I}_mean")
        return (r.status != "ok", mean if finite(mean) else math.inf)

    for r in sorted(graded, key=key):
        front = "/".join("yes" if r.truth_pareto.get(k) else "-" for k in ("mean", "max"))
        same = "0 (the reference)" if r.reference else fmt(r.errors.get(f"{E_I}_mean"))
        status = "" if r.status == "ok" else f" ({md(r.status)})"
        lines.append(
            f"| {md(r.label)}{status} | {md(r.source)} | {md(r.mesh)}, {r.dofs} | "
            f"{fmt(r.truth.get(f'{E_I}_mean'))} | {fmt(r.truth.get(f'{E_I}_max'))} | "
            f"{fmt(r.truth.get(f'{E_N}_max'))} | {same} | {fmt(r.cost)} | {front} |"
        )
    return lines


BUDGET_PARTS = ("total", "discretisation", "algorithm", "model")


def budget_table(rows: list[Row]) -> list[str]:
    """The error budget (SPEC 10) of the rows that have one: each part's time-mean E_i, how it
    was measured, and the part that dominates (the largest of discretisation, algorithm and
    model)."""
    lines = [
        "| run | total: against the truth | discretisation: our implicit on its mesh against "
        "the truth | algorithm: against our implicit on its mesh | model | dominates |",
        "|" + "---|" * 6,
    ]
    for r in sorted(
        (r for r in rows if r.budget),
        key=lambda r: r.budget.get("total") if finite(r.budget.get("total")) else math.inf,
    ):
        b = r.budget
        cells = []
        for part in BUDGET_PARTS:
            how = b.get(f"{part}_how")
            cells.append(fmt(b.get(part)) + (f" ({md(how)})" if how else ""))
        lines.append(f"| {md(r.label)} | {' | '.join(cells)} | {md(dominant(b))} |")
    return lines


def dominant(budget: dict) -> str:
    """The part of an error budget that dominates (the largest finite one of discretisation,
    algorithm, model) with its share of their sum, or "-" when none is known."""
    parts = {p: budget.get(p) for p in BUDGET_PARTS[1:] if finite(budget.get(p))}
    if not parts:
        return "-"
    top = max(parts, key=parts.get)
    total = sum(parts.values())
    return top if total == 0 else f"{top} ({100 * parts[top] / total:.0f} %)"


def unit_of(board: Board) -> str:
    """The unit of E_i on a case (SPEC 6): m^3 in 3D, m^2 in 2D."""
    return "m^3" if get_entry(board.benchmark).gdim == 3 else "m^2"


def truth_header(board: Board, rows: list[Row]) -> str:
    """One line for the case's header on its truth (SPEC 10): the truth and its own error band,
    or why there is none (board.truth_note)."""
    if board.truth is not None and any(r.truth for r in rows):
        return (
            f"Truth (SPEC 10): `{md(board.truth)}`, its own E_i max {fmt(board.truth_band)} "
            f"{unit_of(board)}; every run is also ranked against it (below the table)."
        )
    return f"Truth (SPEC 10): {md(board.truth_note or 'none')}"


def truth_lines(board: Board, rows: list[Row]) -> list[str]:
    """The part of a case's section in leaderboard.md against the truth (SPEC 10): one line
    when the case has none or it is not computed, else its own error band, the table ranked
    against the truth, the rows not graded against it and why, and the error budget."""
    if board.truth is None or not any(r.truth for r in rows):
        return []
    unit = unit_of(board)
    out = [
        f"### Against the truth `{md(board.truth)}` (SPEC 10)",
        "",
        f"Every run graded on its own mesh against the truth {md(board.truth)} (E_i by "
        "quadrature on the truth's cells, E_n at its vertices; metrics/truth.py). The truth's "
        f"own error band: E_i max {fmt(board.truth_band)} {unit} (estimated from its levels, "
        "results/truth.md): an E_i against the truth below it is not resolved. Our `implicit` "
        "ranks here too.",
        "",
        *truth_table(rows),
    ]
    missing = [r for r in rows if not r.truth and r.truth_note]
    if missing:
        out += ["", "Not graded against the truth:", ""]
        out += [f"- {md(r.label)}: {md(r.truth_note)}" for r in missing]
    if any(r.budget for r in rows):
        out += [
            "",
            "#### Error budget (SPEC 10), time-mean E_i (" + unit + ")",
            "",
            "total: the run against the truth; discretisation: our `implicit` on the run's mesh "
            "against the truth; algorithm: the run against our `implicit` on its mesh (SPEC 6); "
            "model: our `implicit` with the run's model against it with the truth's (none here: "
            "the case is linear and so is the truth). The parts are not additive (the total is "
            "at most their sum).",
            "",
            *(
                [f"![{board.name}: error budget](leaderboard/{board.name}-budget.png)", ""]
                if budget_rows(rows)
                else []
            ),
            *budget_table(rows),
        ]
    return out + [""]


def size_series(boards: list[Board]) -> list[list[Board]]:
    """The cases of each series of mesh sizes (Board.sizes), ordered by mesh size (series of
    two cases or more)."""
    groups: dict[str, list[tuple[int, Board]]] = {}
    for b in boards:
        if b.sizes is not None:
            size = b.mesh_size or get_entry(b.benchmark).mesh_size
            groups.setdefault(b.sizes, []).append((size, b))
    return [[b for _, b in sorted(g, key=lambda x: x[0])] for g in groups.values() if len(g) > 1]


def size_rows(series: list[Board], rows: dict[str, list[Row]]) -> dict[str, list[Row | None]]:
    """label -> its row at each mesh size of the series (None where it did not run), for the
    runs (ours and the simulators') that ran at two sizes or more; users' rows left out."""
    found: dict[str, list[Row | None]] = {}
    for k, board in enumerate(series):
        for r in rows.get(board.name, []):
            if r.source != "user":
                found.setdefault(r.label, [None] * len(series))[k] = r
    return {label: rs for label, rs in found.items() if sum(r is not None for r in rs) > 1}


def size_table(series: list[Board], rows: dict[str, list[Row]]) -> list[str]:
    """The markdown table of the runs across the mesh sizes of one series: against the truth
    (E_i max, m^gdim) and cost (s per simulated s) at each size, the finest's best first."""
    sizes = [b.mesh_size or get_entry(b.benchmark).mesh_size for b in series]
    dofs = []
    for b in series:
        ours = [r for r in rows.get(b.name, []) if r.reference]
        dofs.append(ours[0].dofs if ours else 0)
    head = "| run | " + " | ".join(
        f"n = {n} ({d:,} dofs): E_i max, truth | s per s" for n, d in zip(sizes, dofs, strict=True)
    )
    lines = [head + " |", "|" + "---|" * (1 + 2 * len(series))]
    found = size_rows(series, rows)

    def finest(label: str) -> float:
        for r in reversed(found[label]):
            if r is not None:
                value = r.truth.get(f"{E_I}_max") if r.status == "ok" else None
                return value if finite(value) else math.inf
        return math.inf

    for label in sorted(found, key=finest):
        cells = []
        for r in found[label]:
            if r is None:
                cells += ["not run", ""]
            elif r.status != "ok":
                cells += [md(r.status), fmt(r.cost)]
            else:
                cells += [fmt(r.truth.get(f"{E_I}_max")), fmt(r.cost)]
        lines.append(f"| {md(label)} | " + " | ".join(cells) + " |")
    return lines


def machine() -> str:
    """One line on where the wall times were measured."""
    import os

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{platform.node() or 'this machine'}, {cpu}, {os.cpu_count()} cores, {platform.system()}"
    )


def sessions_line(boards: list[Board], session: str) -> str:
    """Where and when the wall times were measured: one session, or each case's (its section
    names it: a case rerun alone, `--rerun CASE`, is timed in its own)."""
    sessions = {b.session or session for b in boards}
    machines = {b.machine or machine() for b in boards}
    where = (
        f"on {next(iter(machines))}" if len(machines) == 1 else "on the machine its section names"
    )
    if len(sessions) == 1:
        return f"measured in one session ({next(iter(sessions))}) {where}"
    return f"measured case by case, each in the session its section names, {where}"


def markdown(
    boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]], session: str
) -> str:
    """leaderboard.md."""
    out = [
        "# Leaderboard: accuracy against cost",
        "",
        "Written by `tissuebench leaderboard --out results`. Every run of a case is graded "
        "against the same reference (our `implicit`, with the case's model) by the same code "
        "as `tissuebench compare`: E_i is the interior error (SPEC 6), E_n the relative nodal "
        "error; time-mean and maximum over steps 1..N. Cost is the wall time per simulated "
        "second, and per dof.",
        "",
        f"Wall times: {sessions_line(boards, session)}; serial (1 rank, 1 "
        "thread). Ours: assembly of M, K and f, the integrator's setup (factorisations) and "
        "its time loop, in process. CalculiX: the whole `ccx` process, including its reading "
        "of the deck and writing of .frd and .dat. SfePy, Newton, Drake and MuJoCo: their "
        "setup and time loop in process (Newton's kernel compilation excluded). Kratos: its "
        "model's creation and time loop in a child process (interpreter start and import "
        "excluded). Each outside run's own line below says what its time covers. A user's "
        "run (`user/`) carries the wall time given to compare. The paper's meshes are small "
        "(336 dofs on the rod): there fixed costs weigh heavily, and single timings of runs "
        "under 0.2 s vary by tens of per cent between sessions; the rod at n = 6 and 12 "
        "shows how each cost grows with the dofs.",
        "",
        "Pareto: a run is on the front when no other finished run is at most as costly and "
        "at most as wrong (better in one); the reference is left out (its error is 0).",
        "",
    ]
    for board in boards:
        out += [
            f"## {board.name}",
            "",
            board.description,
            "",
            truth_header(board, rows[board.name]),
            "",
            f"Timed in the session of {md(board.session or session)}"
            + (f" on {md(board.machine)}." if board.machine else "."),
            "",
            f"![{board.name}](leaderboard/{board.name}.png)",
            "",
        ]
        out += table(rows[board.name])
        outside = [r for r in rows[board.name] if r.source != "tissuebench"]
        if outside:
            out += ["", "What each outside run is:", ""]
            out += [
                f"- **{md(r.label)}**: {md(r.description)}; mesh: {md(r.mesh)}; timing: "
                f"{md(r.timing)}"
                for r in outside
            ]
        if notes.get(board.name):
            out += ["", *[f"- {md(n)}" for n in notes[board.name]]]
        against = truth_lines(board, rows[board.name])
        if against:
            out += ["", *against[:-1]]
        out.append("")
    for series in size_series(boards):
        names = ", ".join(b.name for b in series)
        out += [
            f"## Against mesh size: {names}",
            "",
            "Each run that ran at several of these mesh sizes: its E_i max against the truth "
            f"({unit_of(series[0])}) and its cost (wall time per simulated second) at each. "
            "The coarse cases' costs are mostly fixed costs (start-up, set-up); the finest "
            "shows how each run's cost grows with its dofs and where refining stops paying "
            "(its E_i stops falling: the run's own algorithm or model error, not its mesh's).",
            "",
            *size_table(series, rows),
            "",
        ]
    return "\n".join(out)
