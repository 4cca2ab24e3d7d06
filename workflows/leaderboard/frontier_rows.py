"""The SPEC 11 frontier's runs (results/frontier/frontier.csv, `tissuebench frontier`) as rows
of the leaderboard: read and checked (read_frontier), then each made a Row of every case whose
truth it was graded against (frontier_rows), so that the Pareto front, the divisions, the page,
leaderboard.md, leaderboard.csv and leaderboard.json take them as they take every other row.

Cost. Every row of a board costs its whole run: wall seconds per simulated second, set-up
included, as compare's --wall-time defines it and as our study's rows count it (the System's
assembly, the integrator's set-up and its time loop, in process, 1 rank). A frontier run's
cost is therefore its whole_s (set-up and loop) over the simulated time, not frontier.csv's
`cost` column (the loop alone, SPEC 11's figure), which its description and tooltip show
beside it. A frontier.csv of an older version, without whole_s, gets it from setup_s and
loop_s, the same two times.

The rows are made again at every render from the committed frontier.csv (join_frontier): the
record keeps them as written, and strip_frontier drops them when it is read back.

Whose frontier.csv. The leaderboard takes no number from a file that anyone can write: not from
OUT/frontier/frontier.csv (a `tissuebench frontier --out OUT` of one's own, or a row added by
hand: issue 60), not from the working copy of the clone's results/frontier/frontier.csv (which
is OUT/frontier/frontier.csv when OUT is the clone's results/), and not from the record it wrote
itself. Its frontier rows are those of results/frontier/frontier.csv as committed, at git's
HEAD of the clone tissuebench is installed from (committed_frontier); a copy installed without
its clone (or without git) shows no frontier rows, and says so in one line. A frontier run of
one's own is for its own report (frontier.md); it reaches the leaderboard when it is committed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from tissuebench.meshes import get_entry
from tissuebench.workflows.io.tables import CSVError, rows_of
from tissuebench.workflows.leaderboard.committed import clone_root, head_text
from tissuebench.workflows.leaderboard.row import FRONTIER_SOURCE, Kind
from tissuebench.workflows.leaderboard.rows import (
    E_I,
    E_N,
    Board,
    Row,
    error_keys,
    finite,
    mark_truth_pareto,
    one_line,
    truth_error,
)

FRONTIER = FRONTIER_SOURCE  # a frontier row's source (and its facet on the page)
TIMING = "tissuebench frontier"  # a frontier row's timing
TEXT_CELLS = {"case": 40, "scheme": 80, "algorithm": 40, "cell": 40, "status": 40}  # characters
WHOLE_CELLS = ("mesh_size", "dofs", "substeps")  # whole numbers >= 1
# cells a finished run has, as finite numbers >= 0 (s per simulated s, m^gdim, s)
NUMBER_CELLS = {
    "cost": "cost",
    "interior_error_mean": "e_mean",
    "interior_error_max": "e_max",
    "setup_s": "setup_s",
    "loop_s": "loop_s",
}
# cells that may be empty (an older file, a run without E_n)
OPTIONAL_CELLS = {
    "relative_error_mean": "n_mean",
    "relative_error_max": "n_max",
    "whole_s": "whole_s",
}


class FrontierRowError(ValueError):
    """A frontier.csv row that is not a run of the frontier: what is wrong with it."""


def _number(r: dict, key: str) -> float:
    text = (r.get(key) or "").strip()
    try:
        return float(text)
    except ValueError:
        return math.nan


def frontier_row(r: dict) -> dict[str, Any]:
    """One frontier.csv row (text) as the leaderboard takes it: its texts printable and short
    (TEXT_CELLS), mesh size, dofs and sub-steps whole numbers >= 1, and its loop's cost (s
    per simulated s), E_i mean and max (m^gdim), set-up and loop times (s) finite numbers
    >= 0 (a finished run's, `ok`, all of them; another's NaN where it has none); whole_s (s:
    the set-up and the loop) from its cell, or setup_s + loop_s in a file without one.
    FrontierRowError says what is wrong."""
    if None in r or any(v is None for v in r.values()):
        raise FrontierRowError("its number of cells is not the header's")
    row: dict[str, Any] = {}
    for key, most in TEXT_CELLS.items():
        text = r.get(key)
        if not isinstance(text, str) or not 0 < len(text) <= most or not text.isprintable():
            shown = repr(text)[:40] + ("..." if len(repr(text)) > 40 else "")
            raise FrontierRowError(
                f"{key} {one_line(shown)} is not printable text of 1 to {most} characters"
            )
        row[key] = text
    for key in WHOLE_CELLS:
        try:
            value = int(r.get(key) or "")
        except ValueError:
            value = 0
        if value < 1:
            raise FrontierRowError(
                f"{key} {one_line(repr(r.get(key)))[:40]} is not a whole number >= 1"
            )
        row[key] = value
    for key, name in NUMBER_CELLS.items():
        text = (r.get(key) or "").strip()
        if not text and row["status"] != "ok":
            row[name] = math.nan  # a run that did not finish: no cost or error
            continue
        value = _number(r, key)
        if not (math.isfinite(value) and value >= 0):
            raise FrontierRowError(
                f"{key} {one_line(repr(text))[:40]} is not a finite number >= 0"
                + (" (the run finished: it has one)" if row["status"] == "ok" else "")
            )
        row[name] = value
    for key, name in OPTIONAL_CELLS.items():
        value = _number(r, key)
        row[name] = value if math.isfinite(value) and value >= 0 else math.nan
    row["requested"] = "auto" if (r.get("requested") or "").strip() == "auto" else "1"
    if not math.isfinite(row["whole_s"]):  # a file of an older version
        row["whole_s"] = row["setup_s"] + row["loop_s"]
    if row["whole_s"] < row["loop_s"]:
        raise FrontierRowError(
            f"whole_s {row['whole_s']!r} is less than its loop's loop_s {row['loop_s']!r}"
        )
    # the simulated time (s): the loop's wall time over its cost per simulated second
    row["simulated"] = row["loop_s"] / row["cost"] if row["cost"] and row["loop_s"] else math.nan
    return row


def read_frontier(path: Path, warn=None) -> dict[str, list[dict]]:
    """A frontier.csv file by truth case (frontier_of): {} without the file, and one line to
    `warn` for a file that cannot be read. The leaderboard reads none of these: its rows are
    the committed ones (committed_frontier)."""
    say = warn or (lambda line: None)
    try:
        if not path.is_file():
            return {}
        with open(path, newline="") as f:
            text = f.read()
    except (OSError, UnicodeDecodeError) as exc:
        say(f"{path}: cannot be read ({type(exc).__name__}: {one_line(exc)[:120]}), not read")
        return {}
    return frontier_of(text, str(path), say)


def frontier_of(text: str, where: str, warn=None) -> dict[str, list[dict]]:
    """A frontier.csv's text by truth case: each run's scheme, algorithm, cell, mesh size,
    dofs, sub-steps, status, E_i mean and max, loop cost (s/s) and times (s). Nothing in it is
    trusted: each row is checked before it is drawn or ranked (frontier_row: a negative,
    infinite or missing error or cost of a finished run, text where a number goes, a text too
    long or not printable), and a row that fails is left out with one line given to `warn`,
    naming `where` (the file) and its row; so is a row cut mid-row (the text's last line not
    ended, as a kill or a full disk leaves a file written in place: `tissuebench frontier`
    runs it again), and a text that is not CSV is one line."""
    say = warn or (lambda line: None)
    try:
        raw = rows_of(text)
    except CSVError as exc:
        say(f"{where}: cannot be read ({type(exc).__name__}: {one_line(exc)[:120]}), not read")
        return {}
    cut = bool(text) and not text.endswith("\n")
    out: dict[str, list[dict]] = {}
    for i, r in enumerate(raw, start=2):  # the header is line 1
        if cut and i == len(raw) + 1:
            say(
                f"{where}, row {i}: cut mid-row (the file's last line is not ended), left out: "
                "`tissuebench frontier` runs it again"
            )
            continue
        try:
            row = frontier_row(r)
        except FrontierRowError as exc:
            say(f"{where}, row {i}: not a run of the frontier ({exc}): left out")
            continue
        out.setdefault(row["case"], []).append(row)
    return out


COMMITTED = "results/frontier/frontier.csv"  # the frontier's table, in the clone


def committed_frontier(warn=None, root: Path | None = None) -> dict[str, list[dict]]:
    """The frontier's runs the leaderboard shows: results/frontier/frontier.csv as committed at
    HEAD in the git repository `root` (default: the clone tissuebench runs from, clone_root),
    read from git itself and checked as any frontier.csv (frontier_of), never from a file that
    anyone can write (OUT's, the working copy's). {} with one line to `warn` where there is no
    committed one (an installed copy without its clone, no git); one line too where the working
    copy differs from it (its rows are not shown until they are committed)."""
    say = warn or (lambda line: None)
    root = clone_root() if root is None else root
    text, why = head_text(COMMITTED, root)
    if text is None:
        say(
            f"no frontier rows: no committed {COMMITTED} in {root} ({why}); the leaderboard "
            "takes them from the clone's git only"
        )
        return {}
    working = root / COMMITTED
    try:
        with open(working, newline="") as f:
            differs = f.read() != text
    except (OSError, UnicodeDecodeError):
        differs = False  # none in the working copy: the committed one is shown
    if differs:
        say(
            f"{working} is not as committed: the leaderboard shows the committed frontier rows "
            "(git HEAD's), not this file's; commit it for its rows to be shown"
        )
    return frontier_of(text, f"{working} (as committed)", say)


def _g(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.3g}"


def as_row(board: Board, f: dict) -> Row:
    """A frontier run (frontier_row) as a Row of `board` (a case of its truth): graded against
    the truth only (no reference of the case's mesh), its wall time the whole run's (s: the
    set-up and the loop) over the simulated time, the loop's own cost in its description."""
    steps = f", {f['substeps']} sub-steps (auto)" if f["requested"] == "auto" else ""
    label = f"{f['scheme']} {f['algorithm']}{steps}, {f['cell']} n={f['mesh_size']}"
    simulated = f["simulated"] if finite(f["simulated"]) and f["simulated"] > 0 else None
    if simulated is None:  # no time measured: the case's own T, no cost
        simulated = board.end_time or get_entry(board.benchmark).end_time
        wall = None
    else:
        wall = f["whole_s"]
    description = (
        f"{FRONTIER} run of {f['case']} (results/frontier/frontier.csv): scheme {f['scheme']}, "
        f"{f['algorithm']}, {f['substeps']} sub-step(s) per h; its time loop alone "
        f"{_g(f['cost'])} s per simulated s (set-up {_g(f['setup_s'])} s); timed: the "
        "System's assembly, the integrator's set-up (factorisations, the critical step) and "
        "its time loop, in process, 1 rank, by tissuebench frontier"
    )
    truth = {
        f"{E_I}_mean": f["e_mean"],
        f"{E_I}_max": f["e_max"],
        f"{E_N}_mean": f["n_mean"],
        f"{E_N}_max": f["n_max"],
    }
    return Row(
        board.name,
        label,
        FRONTIER,
        description,
        f"{f['cell']}, size {f['mesh_size']}",
        f["dofs"],
        f["status"],
        None if f["status"] == "ok" else f"{f['status']} (tissuebench frontier)",
        dict.fromkeys(error_keys()),
        wall,
        float(simulated),
        TIMING,
        truth={k: (v if finite(v) else None) for k, v in truth.items()},
        kind=Kind.FRONTIER,
    )


def strip_frontier(rows: dict[str, list[Row]]) -> dict[str, list[Row]]:
    """The rows of each case without the frontier's (a record's: they are read again)."""
    return {name: [r for r in rs if r.kind is not Kind.FRONTIER] for name, rs in rows.items()}


def join_frontier(
    boards: list[Board], rows: dict[str, list[Row]], frontier: dict[str, list[dict]]
) -> dict[str, list[Row]]:
    """Each case's rows with the frontier's runs of its truth (read_frontier) as rows, where
    the case's runs are graded against that truth (the frontier is graded against it only),
    and the Pareto front against the truth marked again over them all; other cases as they
    are. The rows of `rows` are not copied: their truth_pareto flags are set anew."""
    out = strip_frontier(rows)
    for board in boards:
        mine = out.get(board.name, [])
        graded = any(truth_error(r, k) is not None for r in mine for k in ("mean", "max"))
        runs = frontier.get(board.truth, []) if board.truth else []
        if not (graded and runs):
            continue
        out[board.name] = mine + [as_row(board, f) for f in runs]
        mark_truth_pareto(out[board.name])
    return out
