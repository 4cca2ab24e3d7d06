"""The speed-accuracy leaderboard (`tissuebench leaderboard`): for each case, our algorithms
and models (a study case, workflows/study.py), every outside simulator's variants that pose it
(workflows/simulators/runner.py) and any run a user graded with `compare` into the case's `user/`
folder, as rows: read, checked and ranked (accuracy, time-mean and maximum E_i, against cost,
wall time per simulated second, with the Pareto front marked). The page is page.py's,
leaderboard.md document.py's and the figures figures.py's (this package).

Cost: the whole run's wall time per simulated second, every row alike. Ours (and the SPEC 11
frontier's runs, frontier_rows.py): M, K and f assembled (System), the integrator set up
(factorisations, an explicit scheme's critical step) and its time loop, in process, 1 rank.
CalculiX: the `ccx` process, 1 thread, its file output included.
SfePy, Newton, Drake, MuJoCo: their setup and time loop in process; Kratos: in a child
process (see each entry's `timing`). A case's
runs in one session on one machine (Board.session; `--rerun CASE` re-times one case alone); a
user's run carries the wall time they gave compare.

The cases are BOARDS (workflows/boards.py; `tissuebench export` names the case its options pose:
posed_board).
OUT/leaderboard/CASE/ours, OUT/leaderboard/CASE/SIMULATOR: the case's folders (ours);
OUT/leaderboard/CASE/user/NAME: compare folders a user put there (read only); any other
folder under OUT/leaderboard that may be meant to be read is named with what to do
(misplaced);
OUT/leaderboard/index.html, OUT/leaderboard.md, OUT/leaderboard.csv,
OUT/leaderboard/CASE.png: the leaderboard; OUT/leaderboard.json: its record (record.py), from
which it is rendered again.

Nothing read is trusted, and no number of a user's row is taken from its folder: the
leaderboard grades the series again (workflows/leaderboard/grading.py), and summary.json only
says which series, field, label and wall time. A user's folder is checked against its case
(dimension and nodes of the reference it was graded against, h, steps, end time), against its
own manifest (a file changed since compare wrote it: edited; the manifest is a guard against
accidents, not a signature: anyone can compute it again, so it proves nothing about the
numbers), for symbolic links (none is followed: the folder is left out), and its series
against the hashes compare recorded of it (a series changed since compare graded it is left
out); each of its rows is checked for its label, status, wall time and metrics; its
reference's fingerprint (compare's summary.json) must be the case's; what fails is left out
with one line saying why. Users' rows of one case with the same label are told apart by their
folder's name (`label (NAME)`). Every text that was read is escaped for Markdown and HTML in
leaderboard.md (md) and for matplotlib in the figures (plain); a user's label is never taken
for a simulator's name. A NaN or infinite cost or error never ranks.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeGuard, cast

from tissuebench.meshes import get_entry
from tissuebench.metrics.table import METRICS
from tissuebench.workflows.boards import (  # noqa: F401 (the cases, read here and by others)
    BOARDS,
    N12_NOTE,
    N12_VARIANTS,
    Board,
)
from tissuebench.workflows.io.tables import write_table
from tissuebench.workflows.limits import step_count
from tissuebench.workflows.output import MANIFEST, changes, file_hash
from tissuebench.workflows.simulators import SIMULATORS
from tissuebench.workflows.summary import CaseSummary, read_summary

if TYPE_CHECKING:
    from tissuebench.solvers.materials import Material
    from tissuebench.workflows.summary import CompareSummary

E_I = "interior_error"
E_N = "relative_error"


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
    # a user's row: the SHA-256 of its series' files (series_hash), which its grades are of
    series_hash: str | None = None
    # a contact case's row (SPEC 12; {} on other cases): "force_error" (dimensionless) and
    # "interpenetration_max" (m), numbers or None, and "force_error_how" (words: against what,
    # or why none)
    contact: dict = field(default_factory=dict)
    force: str | None = None  # a contact case's row: its needle force file (write_force_csv)
    model: str | None = None  # a user's row: its model as stated to compare (None: the case's)

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


def external_rows(case: str, summary: Mapping[str, Any]) -> list[Row]:
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


def real(x: object) -> TypeGuard[float]:
    """True for a real number that is not a bool (it may be NaN or infinite)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def finite(x: object) -> TypeGuard[float]:
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


# an option not given is this (kappa: the contact benchmark's penalty, SPEC 12)
DEFAULT_OPTIONS = {"load_scale": 1.0, "needle_width": 0.0, "kappa": 10.0}


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


def reference_problem(
    summary: dict, case: dict, board: Board | None = None, home: str | None = None
) -> str | None:
    """Why a compare summary was not graded on the case (None: it was): its h, steps and end
    time, and the fingerprint of its reference (grading.reference_fingerprint: benchmark,
    options, material, model, mesh size, dimension and nodes, or the truth case) against the
    case's. Each reason ends with what to do; `home`, where known, says where the folder
    belongs (the case it was graded for and its user/ folder)."""
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
    where += f", {options_words(board.options)}, {case['gdim']}D, {case['nodes']} nodes)"
    move = f"compare against {board.name}'s reference, or move the folder under its own case"
    if home:
        move = f"it belongs to {home}, or compare against {board.name}'s reference"
    if fp.get("source") == "truth":
        if fp.get("truth") != board.truth:
            has = f"the truth {board.truth}" if board.truth else "no truth"
            truth = one_line(fp.get("truth"))[:40]
            return f"graded against the truth {truth}; {where} has {has}: {move}"
        return None
    if fp.get("benchmark") is None:
        assert isinstance(reference, dict)  # fp came from it
        return (
            f"its reference {one_line(reference.get('file'))[:200]} is neither in a run folder "
            "of ours nor an export's (NAME.reference.xdmf beside NAME.json), so its case is "
            f"not known: compare against the reference `tissuebench export` writes for {board.name}"
        )
    options = fp.get("options")
    got = (
        f"{fp.get('benchmark')} {fp.get('material')} {fp.get('model')}, "
        f"{options_words(options if isinstance(options, dict) else {})}, "
        f"{fp.get('dimension')}D, {fp.get('nodes')} nodes"
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


def user_mesh(mesh: dict | None) -> tuple[str, int]:
    """A user's run's mesh ("TYPE: C cells, N nodes") and dofs from its series' mesh
    (grading.mesh_of: cell_type, cells, nodes, dofs); ("?", 0) when it is not known."""
    if not isinstance(mesh, dict):
        return "?", 0
    cells, nodes, dofs = (mesh.get(k) for k in ("cells", "nodes", "dofs"))
    kind = mesh.get("cell_type")
    if not (
        isinstance(kind, str) and all(isinstance(x, int) and x > 0 for x in (cells, nodes, dofs))
    ):
        return "?", 0
    plural = {"hexahedron": "hexahedra", "tetrahedron": "tetrahedra"}.get(kind, f"{kind}s")
    return f"{one_line(plural)[:40]}: {cells:,} cells, {nodes:,} nodes", cast(int, dofs)


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


OPTION_WORDS = {"load_scale": ("load scale s", ""), "needle_width": ("needle width w", " m")}


def options_words(options: dict) -> str:
    """A case's benchmark options in words ("load scale s = 3"; "default options" when every
    one is its default, DEFAULT_OPTIONS)."""
    words = []
    for key, value in sorted(options.items()):
        if real(value) and real(DEFAULT_OPTIONS.get(key)) and value == DEFAULT_OPTIONS[key]:
            continue
        name, unit = OPTION_WORDS.get(key, (key.replace("_", " "), ""))
        words.append(f"{name} = {value:g}{unit}" if real(value) else f"{name} = {value}")
    return one_line(", ".join(words) or "default options")


def export_options(board: Board) -> str:
    """The `tissuebench export` arguments that pose a case's benchmark (the file and format
    left out): `rod --material MP3 --mesh-size 6`."""
    words = [board.benchmark, "--material", board.material]
    if board.model != "linear":
        words += ["--models", board.model]
    if board.mesh_size is not None:
        words += ["--mesh-size", str(board.mesh_size)]
    if board.end_time is not None:
        words += ["--end-time", f"{board.end_time:g}"]
    for key, value in sorted(board.options.items()):
        if value != DEFAULT_OPTIONS.get(key):
            words += [f"--{key.replace('_', '-')}", f"{value:g}"]
    return " ".join(words)


def posed_board(
    benchmark: str,
    material: Material,
    model: str,
    options: dict,
    mesh_size: int,
    h: float,
    steps: int,
    plane: str = "strain",
    boards: list[Board] | None = None,
) -> Board | None:
    """The leaderboard case (of `boards`, default BOARDS) that a benchmark posed with these
    inputs is (an export's: its material's values, model, options, mesh size, h in s and
    steps; plane strain in 2D), or None."""
    from tissuebench.solvers.materials import get_material

    for b in BOARDS if boards is None else boards:
        case, mine = board_case(b), get_material(b.material)
        if not (
            b.benchmark == benchmark
            and b.model == model
            and (b.mesh_size or get_entry(benchmark).mesh_size) == mesh_size
            and same_options(options, b.options)
            and math.isclose(h, case["h"], rel_tol=TOLERANCE)
            and steps == case["steps"]
            and plane == "strain"
        ):
            continue
        values = ("E", "nu", "rho", "alpha", "beta")
        if all(math.isclose(getattr(material, k), getattr(mine, k)) for k in values):
            return b
    return None


def owners(summary: dict, boards: list[Board]) -> list[Board]:
    """The cases among `boards` that take a compare summary (graded against their reference or
    their truth)."""
    return [b for b in boards if reference_problem(summary, board_case(b), b) is None]


def home_of(summary: dict, boards: list[Board], leaderboard: Path, name: str) -> str | None:
    """Where a compare folder called `name` belongs under the leaderboard folder, in words
    ("rod-MP3-s3: move it to OUT/leaderboard/rod-MP3-s3/user/NAME"), or None when it was
    graded for none of `boards`."""
    found = owners(summary, boards)
    if not found:
        return None
    names = " or ".join(b.name for b in found)
    return f"{names}: move it to {one_line(leaderboard / found[0].name / 'user' / name)}"


def is_compare(folder: Path) -> bool:
    """Whether a folder holds a summary.json that compare wrote."""
    summary = read_summary(folder)
    return summary is not None and summary.get("kind") == "compare"


def _folders(folder: Path) -> list[Path]:
    """The folders in folder, sorted, without hidden ones (ours: partial, old, locks)."""
    try:
        return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return []


def misplaced(leaderboard: Path, boards: list[Board]) -> list[str]:
    """One line for every folder under the leaderboard folder (OUT/leaderboard) that is not
    read although it may be meant to be: a folder that is not one of the cases (each compare
    folder in it, up to two levels down, else the folder itself), and a compare folder directly
    in a case's folder instead of its user/. Each line says what to do. Reads files only."""
    known = [b.name for b in boards]
    ours = {"ours", "user", *SIMULATORS}
    cases = ", ".join(known)
    lines = []
    for sub in _folders(leaderboard):
        if sub.name in known:
            for inner in _folders(sub):
                if inner.name in ours or inner.name.startswith("ours-") or not is_compare(inner):
                    continue
                home = home_of(read_summary(inner) or {}, boards, leaderboard, inner.name)
                lines.append(
                    f"{one_line(inner)}: a compare folder outside {sub.name}/user/, not read: "
                    f"move it to {one_line(sub / 'user' / inner.name)}"
                    + (f" (it was graded for {home.split(':')[0]})" if home else "")
                )
            continue
        inside = [sub] + _folders(sub) + [p for q in _folders(sub) for p in _folders(q)]
        found = [p for p in inside if is_compare(p)]
        why = f"{sub.name!r} is not a leaderboard case (cases: {cases})"
        for folder in found:
            home = home_of(read_summary(folder) or {}, boards, leaderboard, folder.name)
            lines.append(
                f"{one_line(folder)}: {one_line(why)}, not read: "
                + (f"it belongs to {home}" if home else f"move it under {leaderboard}/CASE/user/")
            )
        if not found:
            lines.append(
                f"{one_line(sub)}: {one_line(why)}, not read: put each compare folder under "
                f"{one_line(leaderboard)}/CASE/user/NAME"
            )
    return lines


UNGRADED = "not graded"  # a user's row's status until the leaderboard grades its series


def user_rows(
    board: Board, folder: Path, boards: list[Board] | None = None
) -> tuple[list[Row], list[str]]:
    """Rows of the compare folders in folder (CASE/user/NAME/summary.json, kind "compare"),
    and one line for each folder or run left out and why (see reference_problem, run_problem,
    links, edited and series_problem); a folder graded for another of `boards` is told where it
    belongs. No number of a row is taken from the folder: each row names its series (found and
    hashed here: series_hash), field, label and wall time, with no grade (status UNGRADED, every
    error None): the leaderboard grades the series (grading.py). Rows of the same label are
    told apart by their folder's name (told_apart). Reads files only; rank 0."""
    rows: list[Row] = []
    skipped: list[str] = []
    folders: list[str] = []  # each row's folder name
    folder = Path(folder)
    if not folder.is_dir():
        return rows, skipped
    case = board_case(board)
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() or p.is_symlink()):
        where = one_line(sub)
        problem = links(sub)
        if problem:
            skipped.append(f"{where}: left out: {problem}")
            continue
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
        if problem and boards:
            others = [b for b in boards if b.name != board.name]
            home = home_of(summary, others, folder.parent.parent, sub.name)
            problem = reference_problem(summary, case, board, home)
        runs = summary.get("runs")
        if problem is None and (not isinstance(runs, dict) or not runs):
            problem = f"its summary.json has no runs: {RERUN_COMPARE}"
        if problem is None:
            problem = edited(sub)
        found: dict = {}
        if problem is None:
            found = candidate_of(summary, sub)
            problem = series_problem(summary, found) or model_problem(summary)
        if problem:
            skipped.append(f"{where}: left out: {problem}")
            continue
        assert isinstance(runs, dict)  # a summary with runs: checked above
        given = user_force(summary)  # a contact case's: the force file compare graded
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
            rows.append(
                Row(
                    board.name,
                    label,
                    "user",
                    f"{one_line(sub.name)[:80]}: its series graded by the leaderboard",
                    "?",
                    0,
                    UNGRADED,
                    None,
                    dict.fromkeys(error_keys()),
                    None if run["wall_time_s"] is None else float(run["wall_time_s"]),
                    float(case["end_time"]),
                    "reported by the user",
                    **found,
                    force=given,
                )
            )
            folders.append(sub.name)
    told_apart(rows, folders)
    return rows, skipped


SUFFIX = 40  # characters of a folder's name added to a label that another row has too


def told_apart(rows: list[Row], folders: list[str]) -> None:
    """Give each row whose label another row has too its folder's name after it, `label
    (NAME)` (NAME at most SUFFIX characters, made one line), until every label differs (a
    folder holds one row of a label: the names tell them apart)."""
    for _ in range(len(rows)):
        seen: dict[str, int] = {}
        for r in rows:
            seen[r.label] = seen.get(r.label, 0) + 1
        same = [(r, name) for r, name in zip(rows, folders, strict=True) if seen[r.label] > 1]
        if not same:
            return
        for r, name in same:
            r.label = f"{r.label} ({one_line(name)[:SUFFIX]})"


def links(folder: Path) -> str | None:
    """Why a user's folder is not read for the links in it (None: it has none): the folder
    itself, or anything in it (summary.json, the manifest, any file), a symbolic link. The
    leaderboard follows none, wherever it points: compare writes none."""
    if folder.is_symlink():
        return (
            f"it is a symbolic link (to {one_line(os.readlink(folder))[:120]}), which the "
            "leaderboard does not follow: put the compare folder itself there"
        )
    try:
        for root, dirs, files in os.walk(folder):
            for name in sorted(files + dirs):
                path = Path(root, name)
                if path.is_symlink():
                    rel = one_line(path.relative_to(folder).as_posix())[:80]
                    return (
                        f"its {rel} is a symbolic link (to {one_line(os.readlink(path))[:120]}), "
                        "which the leaderboard does not follow (compare writes none): move the "
                        "folder away and grade the run again with tissuebench compare"
                    )
    except OSError as exc:
        return f"it cannot be read ({type(exc).__name__}: {one_line(exc)[:120]})"
    return None


def series_hash(files: dict) -> str:
    """The hash of a series by its files ({name: SHA-256}, grading.series_files)."""
    from tissuebench.core.fingerprint import fingerprint

    return fingerprint({"series": files})


def series_problem(summary: dict, found: dict) -> str | None:
    """Why a compare folder's series cannot be graded here (None: it can, and `found`, its
    candidate_of, gets its series_hash): it names none, it is not on this machine, it or a
    file of it is a symbolic link, or its files are not the ones compare graded (the hashes
    summary.json records, inputs.candidate.files: a series changed since would be graded as
    another run than compare's)."""
    from tissuebench.workflows.grading import series_files

    again = "grade the run again with tissuebench compare (with --force)"
    inputs = summary.get("inputs")
    cand = inputs.get("candidate") if isinstance(inputs, dict) else None
    recorded = cand.get("files") if isinstance(cand, dict) else None
    if not found or not isinstance(recorded, dict) or not recorded:
        return f"its summary.json records no series file with its hashes: {again}"
    path = Path(found["series"])
    shown = one_line(path)[:200]
    try:
        if path.is_symlink():
            return (
                f"its series {shown} is a symbolic link, which the leaderboard does not follow: "
                f"put the series file itself there and {again}"
            )
        if not path.is_file():
            return (
                f"its series {shown} is not on this machine, and nothing of the folder is "
                "believed without grading it: put the series there, or grade it with "
                "tissuebench compare on this machine"
            )
        stem = path.name.split(".")[0]
        for p in path.parent.iterdir():
            if p.name.startswith((f"{stem}.", f"{stem}_")) and p.is_symlink():
                return (
                    f"its series' file {one_line(p)[:200]} is a symbolic link, which the "
                    f"leaderboard does not follow: put the file itself there and {again}"
                )
        now = series_files(path)
    except OSError as exc:
        return f"its series {shown} cannot be read ({type(exc).__name__}: {one_line(exc)[:120]})"
    if now != recorded:
        changed = sorted(
            n for n in {*now, *recorded} if now.get(n) != recorded.get(n) and isinstance(n, str)
        )
        named = ", ".join(one_line(n)[:60] for n in changed[:3]) + (
            f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        )
        return (
            f"its series {shown} is not the one compare graded ({named} changed, added or gone "
            f"since: the hashes summary.json records differ): {again}"
        )
    found["series_hash"] = series_hash(now)
    return None


def edited(folder: Path) -> str | None:
    """Why a compare folder is not as compare wrote it (None: it is): a file of it changed
    since compare wrote it (its manifest, output.MANIFEST, holds another hash: compare itself
    refuses such a folder), or no manifest to check it against. A file added beside them
    changes nothing read and is let be. The manifest is a guard against accidents (a file
    edited by hand, a copy cut short), not a signature: anyone can compute it again, so the
    leaderboard takes no number from the folder and grades its series itself."""
    found = changes(folder)
    again = "move the folder away and grade the run again with tissuebench compare"
    if found is None:
        return f"it has no manifest of compare's ({MANIFEST}) to check its numbers against: {again}"
    modified = found[1]
    if modified:
        more = f" and {len(modified) - 1} more" if len(modified) > 1 else ""
        return (
            f"its {one_line(modified[0])[:80]}{more} was changed since tissuebench wrote it "
            f"(its manifest {MANIFEST} holds another hash), so its numbers are not compare's: "
            + again
        )
    return None


def candidate_of(summary: dict, folder: Path | None = None) -> dict:
    """The series file and field a compare summary records as its candidate ({} when it names
    none): {"series": path, "series_field": field or None}. With the compare `folder`, the
    path is one found from any working folder (grading.candidate_file: an older compare's
    relative path is taken from its inputs or its folder)."""
    cand = summary.get("candidate")
    file = cand.get("file") if isinstance(cand, dict) else None
    if not isinstance(file, str) or not file:
        return {}
    if folder is not None:
        from tissuebench.workflows.grading import candidate_file

        file = candidate_file(cast("CompareSummary", summary), folder) or file
    assert isinstance(cand, dict)  # file came from it
    field, model = cand.get("field"), cand.get("model")  # model: as its user stated it
    return {
        "series": file,
        "series_field": field if isinstance(field, str) else None,
        "model": model if isinstance(model, str) else None,
    }


def model_problem(summary: dict) -> str | None:
    """Why a compare summary's stated candidate model cannot be taken (None: it states none,
    or one of solvers.MODELS)."""
    from tissuebench.solvers.models import MODELS

    cand = summary.get("candidate")
    model = cand.get("model") if isinstance(cand, dict) else None
    if model is None or (isinstance(model, str) and model in MODELS):
        return None
    return f"its candidate's model {one_line(repr(model))[:40]} is not one of {', '.join(MODELS)}"


def user_force(summary: dict) -> str | None:
    """The needle force file that a user's compare graded (--needle-force, a contact case),
    where it is still the file compare hashed (its inputs' sha256); None otherwise (the row
    then has no force error, and says so)."""
    inputs = summary.get("inputs")
    given = inputs.get("needle_force") if isinstance(inputs, dict) else None
    if not isinstance(given, dict) or not isinstance(given.get("file"), str):
        return None
    path = Path(given["file"])
    try:
        same = path.is_file() and file_hash(path) == given.get("sha256")
    except OSError:
        same = False
    return str(path) if same else None


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
        # ranked: rows with a finite cost and error
        flags = pareto([cast(Any, (r.cost, ranked_error(r, kind))) for r in ranked])
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
        # ranked: rows with a finite cost and error
        flags = pareto([cast(Any, (r.cost, truth_error(r, kind))) for r in ranked])
        for r in rows:
            r.truth_pareto.pop(kind, None)
        for r, flag in zip(ranked, flags, strict=True):
            r.truth_pareto[kind] = flag


# --- files ------------------------------------------------------------------------------------


def fmt(x: float | None, spec: str = ".3g") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


CONTACT_KEYS = ("force_error", "interpenetration_max")  # a contact case's row's columns


def write_csv(path: Path, rows: list[Row]) -> None:
    """leaderboard.csv: every row, with what its errors cover (errors_over: every step, or
    the steps before it diverged or failed, budget.covers); with the contact columns
    (CONTACT_KEYS, then how the force was graded) at the end only when a row of a contact
    case is among them, empty for the others."""
    contact = any(r.contact for r in rows)
    from tissuebench.workflows.leaderboard.budget import covers

    names = ["case", "label", "source", "description", "mesh", "dofs", "status", "reason"]
    names += ["errors_over"]  # what its errors cover: every step, or those before it stopped
    names += error_keys() + ["wall_time_s", "wall_per_simulated_s", "us_per_dof_per_simulated_s"]
    names += ["timing", "reference", "pareto_mean", "pareto_max"]
    names += [f"truth_{k}" for k in TRUTH_KEYS] + ["truth_pareto_mean", "truth_pareto_max"]
    names += [*CONTACT_KEYS, "force_error_how"] if contact else []
    write_table(
        path,
        names,
        (
            [r.case, r.label, r.source, r.description, r.mesh, r.dofs, r.status, r.reason or ""]
            + [covers(r.status)]
            + ["" if r.errors[k] is None else repr(r.errors[k]) for k in error_keys()]
            + ["" if x is None else repr(x) for x in (r.wall_time_s, r.cost, r.cost_per_dof)]
            + [r.timing, r.reference, r.pareto.get("mean", False), r.pareto.get("max", False)]
            + ["" if r.truth.get(k) is None else repr(r.truth[k]) for k in TRUTH_KEYS]
            + [r.truth_pareto.get("mean", False), r.truth_pareto.get("max", False)]
            + (contact_cells(r) if contact else [])
            for r in rows
        ),
    )


def contact_cells(r: Row) -> list[str]:
    """A row's contact cells in leaderboard.csv: force error, interpenetration (m), how the
    force was graded (empty for a row of another case)."""
    values = ["" if r.contact.get(k) is None else repr(r.contact[k]) for k in CONTACT_KEYS]
    return values + [r.contact.get("force_error_how") or ""]
