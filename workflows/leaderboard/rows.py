"""The speed-accuracy leaderboard (`tissuebench leaderboard`): for each case, our algorithms
and models (a study case, workflows/run/case.py), every outside simulator's variants that pose it
(workflows/simulators/runner.py) and any run a user graded with `compare` into the case's `user/`
folder, as rows: read, checked and ranked (accuracy, time-mean and maximum E_i, against cost,
wall time per simulated second, with the Pareto front marked). The page is page.py's,
leaderboard.md document.py's and the figures figures.py's (this package). Here: our runs' and
the simulators' rows, their ranking and leaderboard.csv; the Row itself is row.py's, a case as
run and posed cases.py's, and a user's folder read and checked checks.py's.

Cost: the whole run's wall time per simulated second, every row alike. Ours (and the SPEC 11
frontier's runs, frontier_rows.py): M, K and f assembled (System), the integrator set up
(factorisations, an explicit scheme's critical step) and its time loop, in process, 1 rank.
CalculiX: the `ccx` process, 1 thread, its file output included.
SfePy, Newton, Drake, MuJoCo: their setup and time loop in process; Kratos: in a child
process (see each entry's `timing`). A case's
runs in one session on one machine (Board.session; `--rerun CASE` re-times one case alone); a
user's run carries the wall time they gave compare.

The cases are BOARDS (workflows/leaderboard/boards.py; `tissuebench export` names the case its
options pose: posed_board).
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

from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.tables import write_table
from tissuebench.workflows.leaderboard.boards import (  # noqa: F401 (the cases, read here and by others)
    BOARDS,
    N12_NOTE,
    N12_VARIANTS,
    Board,
)
from tissuebench.workflows.leaderboard.cases import (  # noqa: F401 (read here before)
    board_case,
    export_options,
    posed_board,
)
from tissuebench.workflows.leaderboard.checks import (  # noqa: F401 (read here before)
    MAX_LABEL,
    UNGRADED,
    candidate_of,
    misplaced,
    series_hash,
    user_mesh,
    user_rows,
)
from tissuebench.workflows.leaderboard.row import (  # noqa: F401 (read here before)
    E_I,
    E_N,
    OUR_SOURCE,
    TRUTH_KEYS,
    Kind,
    Row,
    error_keys,
    finite,
    fmt,
    md,
    one_line,
    plain,
    real,
)


def our_rows(case: str, summary: CaseSummary) -> list[Row]:
    """Rows of our runs from a study case's summary (workflows/io/summary.py): the cost (s) is
    the System's assembly, the integrator's setup and its time loop."""
    rows = []
    for label, run in summary.runs.items():
        wall = run.wall_time_s + (run.setup_time_s + summary.system_time_s)
        rows.append(
            Row(
                case,
                label,
                OUR_SOURCE,
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
                kind=Kind.OURS,
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
                kind=Kind.SIMULATOR,
            )
        )
    return rows


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


RANKED_BY = "max"  # the E_i (over the steps) every board and division ranks by (issue 59)
RANK_RULE = (
    "ranked by E_i max over the steps (against the truth where the case has one); "
    "the time-mean beside it"
)  # in words: a run right only on average (quasi-static on a dynamic case) does not lead


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


# --- the table -----------------------------------------------------------------------------------


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
