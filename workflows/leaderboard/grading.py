"""Every row of a case graded against its truth (SPEC 10), loaded from the cache, with its
error budget; the users' rows joined to their cases and graded. Rank 0, serial."""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

import numpy as np

from tissuebench.workflows.leaderboard import users as user_folders
from tissuebench.workflows.leaderboard.rows import (
    E_I,
    E_N,
    Board,
    Row,
    finite,
    mark_pareto,
    mark_truth_pareto,
    truth_error,
)
from tissuebench.workflows.leaderboard.users import user_key

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples


STUDY_TRUTHS = {"mesh-sensitivity-rod-MP3": "rod", "mesh-sensitivity-block-MP1": "block-MP1-w0.2"}


STUDY = re.compile(r"(?P<algorithm>\S+) \((?P<shape>.+), size (?P<size>\d+)\)")


def study_series(out: Path, board: Board, rows: list[Row]) -> None:
    """The series file of each row of a mesh-sensitivity board, where `tissuebench
    sensitivity` writes it (OUT/mesh-sensitivity/STUDY/SHAPE-SIZE-ALGORITHM.xdmf), and its
    board's truth case."""
    from tissuebench.workflows.mesh_sensitivity import NAME

    board.truth = STUDY_TRUTHS.get(board.name)
    study = board.name.removeprefix(f"{NAME}-")
    for row in rows:
        m = STUDY.fullmatch(row.label)
        if m:
            stem = f"{m['shape'].replace(' ', '-')}-{m['size']}-{m['algorithm']}"
            row.series = str(out / NAME / study / f"{stem}.xdmf")


def summarized(curve) -> tuple[float | None, float | None]:
    """(max, time-mean) of an error curve over steps 1..N, None for NaN."""
    from tissuebench.metrics.compare import summarize

    peak, mean = (None if not finite(x) else float(x) for x in summarize(curve))
    return peak, mean


def grade_row_truth(truth, row: Row) -> None:
    """Grade a row's own series against the truth (metrics/truth.py), into row.truth; or say in
    row.truth_note why it is not graded. Rank 0 (serial)."""
    from tissuebench.metrics.truth import grade_truth
    from tissuebench.workflows.io.series import read_series

    if not row.series:
        row.truth_note = "no series file of it is recorded"
        return
    if not Path(row.series).is_file():
        row.truth_note = f"its series {row.series} is not on this machine"
        return
    try:
        cand = read_series(row.series, row.series_field)
        # E_n and E_i only (the leaderboard's columns): E_s's boolean is most of the cost
        g = grade_truth(truth, cand, MPI.COMM_SELF, label=row.label, surface=False)
    except Exception as exc:  # anything a file can do: this row is not graded, the rest are
        row.truth_note = f"not graded: {type(exc).__name__}: {' '.join(str(exc).split())[:200]}"
        return
    for metric in (E_N, E_I):
        row.truth[f"{metric}_max"], row.truth[f"{metric}_mean"] = summarized(g.curves[metric])


def grade_truths(boards: list[Board], rows: dict[str, list[Row]], log=print) -> None:
    """Every row of every case with a truth graded against it (rank 0, serial): each truth
    case's cached TruthSamples is loaded once, never computed here (a truth not in the cache
    says so in its case's header); then the Pareto flags against the truth and the error
    budget."""
    from tissuebench.metrics.truth import own_error
    from tissuebench.solvers.truth.store import expected_words, load_cached

    cases: dict[str, list[Board]] = {}
    for board in boards:
        if board.truth is not None:
            cases.setdefault(board.truth, []).append(board)
    for case, mine in cases.items():
        truth = load_cached(case, comm=MPI.COMM_SELF)
        if truth is None:
            for board in mine:
                board.truth_note = (
                    f"{case}, not computed on this machine (tissuebench truth {case}: "
                    f"{expected_words(case)} on one core): no truth columns."
                )
            continue
        if not np.isfinite(own_error(truth)):  # its levels do not converge: no yardstick
            for board in mine:
                board.truth_note = (
                    f"{case}: computed, but its levels do not converge and it states no own "
                    f"error (tissuebench truth {case}): no truth columns."
                )
            continue
        for board in mine:
            board.truth_band = own_error(truth)
            for row in rows[board.name]:
                grade_row_truth(truth, row)
            if not any(r.truth for r in rows[board.name]):
                absent = {r.truth_note for r in rows[board.name]}
                folders = sorted({str(Path(r.series).parent) for r in rows[board.name] if r.series})
                board.truth_note = f"{case}; no run of this case graded against it: " + (
                    f"their series files ({', '.join(folders)}) are not on this machine; "
                    "graded against the truth where tissuebench sensitivity ran"
                    if all(n and "not on this machine" in n for n in absent)
                    else "; ".join(sorted(n for n in absent if n))[:300]
                )
                continue
            mark_truth_pareto(rows[board.name])
            error_budget(rows[board.name])
            log(f"{board.name}: graded against the truth {case}")
        del truth


def error_budget(
    rows: list[Row],
    only: list[Row] | None = None,
    board: Board | None = None,
    truth: TruthSamples | None = None,
) -> None:
    """The error budget (SPEC 10) of every row of a case graded against the truth, in
    row.budget (time-mean E_i, m^gdim): total (the row against the truth), discretisation
    (our implicit on the row's mesh against the truth), algorithm (the row against our
    implicit on its mesh: the same-mesh column on our grid; graded here on our simplices),
    model (none: the linear case's model is the truth's). A user's row on a mesh of its own,
    given the case's `board` and its `truth` (TruthSamples), gets our implicit run here on that
    mesh (workflows/user_mesh.py: all four parts, or one line on why not). Only the rows of
    `only` when it is given (the others keep theirs). Rank 0."""
    from tissuebench.workflows.grading import grade

    reference = next((r for r in rows if r.reference and r.truth), None)
    if reference is None and (board is None or truth is None):
        return
    implicit = {
        r.mesh.split(":")[0]: r
        for r in rows
        if reference is not None and r.label.startswith(f"{reference.label} (")
    }
    for row in rows if only is None else only:
        if not row.truth:
            continue
        b = {"total": row.truth.get(f"{E_I}_mean")}
        ours, how = None, None
        if reference is not None and row.mesh == reference.mesh:  # our grid (ours, SfePy's, ...)
            ours = reference
            element = row.label.rsplit("-", 1)[-1] if row.source.startswith("CalculiX") else ""
            if element and element != "C3D8":
                how = f"our element's (Q1) on its mesh: {element} is an element we do not have"
                b["algorithm_how"] = f"against our Q1 implicit: {element}'s difference included"
        elif row.group and row.mesh.split(":")[0] in implicit:  # ours on simplices
            ours = implicit[row.mesh.split(":")[0]]
        elif row.mesh.startswith("tetrahedra, 6 per hexahedron") and "tetrahedron grid" in implicit:
            ours = implicit["tetrahedron grid"]
            how = (
                "our implicit on our tetrahedron grid (6 per hexahedron on the same nodes; "
                "the diagonals may differ)"
            )
        elif row.source == "user" and board is not None and truth is not None and row.series:
            from tissuebench.workflows.user_mesh import budget_on_mesh

            row.budget = {**b, **budget_on_mesh(board, row, truth)}  # our implicit on its mesh
            continue
        elif row.source == "user" and board is not None and truth is None:
            how = f"the truth {board.truth} is not computed here to grade our implicit on its mesh"
        elif row.source == "user" and row.mesh == "?":  # compare recorded no mesh
            how = "its mesh is not known here"
        else:
            how = "no run of our implicit on its mesh in this case"
        b["discretisation"] = None if ours is None else ours.truth.get(f"{E_I}_mean")
        b["discretisation_how"] = how
        if ours is not None and ours is reference:
            b["algorithm"] = 0.0 if row is reference else row.errors.get(f"{E_I}_mean")
        elif ours is row:
            b["algorithm"] = 0.0
        elif ours is not None:
            try:
                if ours.series is None or row.series is None:
                    raise TypeError("a row without its series")  # as grade(None) would
                g = grade(
                    ours.series, row.series, comm=MPI.COMM_SELF, candidate_field=row.series_field
                )
                b["algorithm"] = summarized(g.curves[E_I])[1]
                b["algorithm_how"] = f"against {ours.label}"
            except Exception as exc:
                b["algorithm"] = None
                b["algorithm_how"] = f"not graded: {type(exc).__name__}"
        b["model"] = None
        row.budget = b


def grade_users(
    boards: list[Board],
    rows: dict[str, list[Row]],
    users: dict,
    graded: dict | None = None,
    out: Path = Path("results"),
    on_graded=None,
) -> None:
    """The users' rows joined to their cases, graded against each case's truth where it has one
    (its cached truth loaded once per case; a user's row graded by compare against the truth
    keeps its columns; one the record holds already graded, `graded` {user_key: Row}, keeps the
    record's), the Pareto fronts marked again and the users' error budgets. A truth that is not
    computed here is named, with the command that computes it, in the rows' notes and in one
    line on stderr per case. Each row is graded whole (against the truth, then its budget)
    before the next, and `on_graded(board, row, seconds)` is called as it ends. Rank 0."""
    from tissuebench.solvers.truth.store import expected_words, load_cached

    truths = {}
    for board in boards:
        mine = list(users.get(board.name, []))
        rows[board.name] = [r for r in rows[board.name] if r.source != "user"] + mine
        kept = set()  # ids of the rows whose budget the record holds, complete
        for row in mine:
            before = (graded or {}).get(user_key(row))
            if before is not None and before.truth and not row.truth:
                row.truth, row.truth_note = dict(before.truth), before.truth_note
            if before is not None and before.truth == row.truth and complete(before.budget):
                row.budget = dict(before.budget)
                kept.add(id(row))
        pending = [r for r in mine if id(r) not in kept]
        run_here = any(r.truth and r.series for r in pending)  # our implicit on a user's mesh
        if board.truth is not None and (any(not r.truth for r in mine) or run_here):
            if board.truth not in truths:
                truths[board.truth] = load_cached(board.truth, comm=MPI.COMM_SELF)
            truth = truths[board.truth]
            todo = (
                f"`tissuebench truth {board.truth}` computes it ({expected_words(board.truth)} "
                f"on one core, once), then `tissuebench leaderboard --out {out}` grades "
                "against it"
            )
            if truth is None and any(not r.truth for r in mine):
                user_folders.warn(
                    f"{board.name}: {sum(not r.truth for r in mine)} user row(s) not graded "
                    f"against the truth {board.truth}, which is not computed here: " + todo
                )
            for row in mine:
                if truth is None and not row.truth:
                    row.truth_note = (
                        f"the truth {board.truth} is not computed on this machine: {todo}"
                    )
        truth = truths.get(board.truth) if board.truth is not None else None
        for row in pending:  # each graded whole (truth, then budget) and said as it ends
            start = time.perf_counter()
            if truth is not None and not row.truth:
                grade_row_truth(truth, row)
            if row.truth:
                error_budget(rows[board.name], only=[row], board=board, truth=truth)
            if on_graded is not None:
                on_graded(board, row, time.perf_counter() - start)
        mark_pareto(rows[board.name])
        if any(truth_error(r, k) is not None for r in rows[board.name] for k in ("mean", "max")):
            mark_truth_pareto(rows[board.name])


def complete(budget: dict) -> bool:
    """Whether an error budget holds all four parts as finite numbers."""
    return all(
        finite(budget.get(part)) for part in ("total", "discretisation", "algorithm", "model")
    )
