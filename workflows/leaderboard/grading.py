"""Every row of a case graded against its truth (SPEC 10), loaded from the cache, with its
error budget (rank 0, serial); the users' rows joined to their cases and graded, shared out
among the ranks.

A user's row is graded here from its series, never from its folder's summary.json, whose
numbers anyone can write (and its manifest recompute): against the case's reference (E_n, E_s
and E_i, its status and its mesh: case_reference), against the case's truth, and its error
budget. Grades are kept by the series' content hash (rows.series_hash): rows of one series
are graded once in a run, and a row the record (or graded-users.json) holds for the same
series keeps its grades.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core import interrupt
from tissuebench.solvers.truth.fallbacks import FALLBACKS
from tissuebench.workflows.leaderboard import users as user_folders
from tissuebench.workflows.leaderboard.boards import BOARDS, is_contact
from tissuebench.workflows.leaderboard.caches import (  # noqa: F401 (read here before)
    Caches,
    Recent,
    case_reference,
)
from tissuebench.workflows.leaderboard.error_budget import complete, error_budget, summarized
from tissuebench.workflows.leaderboard.force_curve import force_hash
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import (
    E_I,
    E_N,
    UNGRADED,
    Board,
    Row,
    mark_pareto,
    mark_truth_pareto,
    truth_error,
    user_mesh,
)
from tissuebench.workflows.leaderboard.users import user_key

CONTACT_MODEL_HOW = (
    "not measured on a contact case: the contact law's share (a penalty, kappa = 10 for ours, "
    "against the truth's penalty limit) lies inside the discretisation and algorithm parts"
)
STUDY_TRUTHS = {"mesh-sensitivity-rod-MP3": "rod", "mesh-sensitivity-block-MP1": "block-MP1-w0.2"}


STUDY = re.compile(r"(?P<algorithm>\S+) \((?P<shape>.+), size (?P<size>\d+)\)")


def study_series(out: Path, board: Board, rows: list[Row]) -> None:
    """The series file of each row of a mesh-sensitivity board, where `tissuebench
    sensitivity` writes it (OUT/mesh-sensitivity/STUDY/SHAPE-SIZE-ALGORITHM.xdmf), and its
    board's truth case."""
    from tissuebench.workflows.leaderboard.mesh_sensitivity import NAME

    board.truth = STUDY_TRUTHS.get(board.name)
    study = board.name.removeprefix(f"{NAME}-")
    for row in rows:
        m = STUDY.fullmatch(row.label)
        if m:
            stem = f"{m['shape'].replace(' ', '-')}-{m['size']}-{m['algorithm']}"
            row.series = str(out / NAME / study / f"{stem}.xdmf")


def grade_row_reference(board: Board, row: Row, caches: Caches) -> None:
    """Grade a user's row's own series against the case's reference (Caches.reference), as
    compare grades it (metrics/compare.py: E_n, E_s, E_i, on its own mesh where it has one):
    its errors, status (the worst step's; a series that diverged, ended early, ...) and
    reason, and its mesh and dofs as the series holds them. Where it cannot be graded the
    row keeps status UNGRADED (it never ranks) and its reason says why in one line."""
    from tissuebench.metrics.compare import grade_series
    from tissuebench.metrics.table import METRICS
    from tissuebench.workflows.compare.fingerprint import mesh_of

    def why(what: str, exc: Exception) -> str:
        return f"{what}: {type(exc).__name__}: {' '.join(str(exc).split())[:200]}"

    if not row.series:
        row.reason = "not graded: no series file of it is recorded"
        return
    try:
        cand = caches.series(row.series, row.series_field)
    except Exception as exc:  # anything a file can do: this row is not graded, the rest are
        row.reason = why("not graded: its series cannot be read", exc)
        return
    row.mesh, row.dofs = user_mesh(mesh_of(cand))
    try:
        reference = caches.reference(board)
        g = grade_series(reference, cand, MPI.COMM_SELF, label=row.label)
    except Exception as exc:
        row.reason = why("not graded against the case's reference", exc)
        return
    if row.mesh != "?" and on_case_mesh(cand, reference):
        row.mesh = f"{row.mesh} ({CASE_MESH})"
    for name in METRICS:
        row.errors[f"{name}_max"], row.errors[f"{name}_mean"] = summarized(g.curves[name])
    row.status = next((s for s in g.status if s != "ok"), "ok")
    row.reason = g.candidate_reason or (
        g.reference_reason if row.status == "reference diverged" else None
    )


CASE_MESH = "the case's mesh"  # said after a user's mesh that is the export's (on_case_mesh)


def on_case_mesh(cand, reference) -> bool:
    """Whether a series (metrics.series.Series) is on the case's own mesh, the one `tissuebench
    export` hands out (the reference's): the same cell type, and the same points (within
    SAME_NODE of the extent) and cells, in any numbering."""
    from tissuebench.metrics.cells import match_points
    from tissuebench.metrics.series import SAME_NODE

    a, b = np.asarray(cand.points, dtype=float), np.asarray(reference.points, dtype=float)
    cells, theirs = np.asarray(cand.cells), np.asarray(reference.cells)
    if cand.cell_type != reference.cell_type or a.shape != b.shape or cells.shape != theirs.shape:
        return False
    if not len(a) or not len(cells):
        return False
    tol = SAME_NODE * float(np.ptp(b, axis=0).max()) or SAME_NODE
    match = match_points(a, b, tol)  # candidate node i -> the reference's node match[i]
    if (match < 0).any() or len(np.unique(match)) != len(match):
        return False
    mine = np.sort(match[cells], axis=1)  # each cell as its set of the reference's nodes
    theirs = np.sort(theirs, axis=1)
    return bool(np.array_equal(np.unique(mine, axis=0), np.unique(theirs, axis=0)))


GRADES = ("errors", "status", "reason", "mesh", "dofs", "truth", "truth_note", "budget")


def grades_of(row: Row) -> dict:
    """What grading a user's row gives it (GRADES, and on a contact case its contact
    columns), copied."""
    contact = {"contact": dict(row.contact)} if row.contact else {}
    return {**{k: json_copy(getattr(row, k)) for k in GRADES}, **contact}


def take_grades(row: Row, grades: dict) -> None:
    """Put a user's row's grades (grades_of) into it, copied."""
    for k in GRADES:
        setattr(row, k, json_copy(grades[k]))
    row.contact = dict(grades.get("contact") or {})


def json_copy(value):
    return dict(value) if isinstance(value, dict) else value


def grade_row_truth(truth, row: Row, caches: Caches | None = None) -> None:
    """Grade a row's own series against the truth (metrics/truth.py), into row.truth; or say in
    row.truth_note why it is not graded. Rank 0 (serial). `caches`: shared across rows
    (Caches), the same numbers."""
    from tissuebench.metrics.truth import grade_truth
    from tissuebench.workflows.io.series import read_series

    if not row.series:
        row.truth_note = "no series file of it is recorded"
        return
    if not Path(row.series).is_file():
        row.truth_note = f"its series {row.series} is not on this machine"
        return
    try:
        if caches is None:
            cand = read_series(row.series, row.series_field)
        else:
            cand = caches.series(row.series, row.series_field)
        located = None if caches is None else caches.located_for(truth)
        # E_n and E_i only (the leaderboard's columns): E_s's boolean is most of the cost
        g = grade_truth(truth, cand, MPI.COMM_SELF, label=row.label, surface=False, located=located)
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
    from tissuebench.solvers.truth.store import expected_words, load_cached, load_failure

    cases: dict[str, list[Board]] = {}
    for board in boards:
        if board.truth is not None:
            cases.setdefault(board.truth, []).append(board)
    for case, mine in cases.items():
        truth = load_cached(case, comm=MPI.COMM_SELF)
        if truth is None:
            failure = load_failure(case)
            for board in mine:
                board.truth_note = (
                    f"{case}: its computation fails (Newton, on n = {failure['level']} at t = "
                    f"{failure['t']:.3g} s; results/truth.md): no truth columns."
                    if failure
                    else f"{case}, not computed on this machine (tissuebench truth {case}: "
                    f"{expected_words(case)} on one core): no truth columns."
                )
            continue
        if not np.isfinite(own_error(truth)):  # its levels do not converge: no yardstick
            taken: dict[str, list[str]] = {}  # the smaller loads' truths -> their cases
            for b in BOARDS:
                if b.truth and FALLBACKS.get(b.truth, ("",))[0] == case:
                    taken.setdefault(b.truth, []).append(b.name)
            instead = "".join(
                f"; a smaller load is tried instead: {truth} (cases {', '.join(names)})"
                for truth, names in taken.items()
            )
            for board in mine:
                board.truth_note = (
                    f"{case}: computed, but its levels do not converge and it states no own "
                    f"error (results/truth.md){instead}: no truth columns."
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
            if is_contact(board):  # SPEC 12: the force error against the truth's
                from tissuebench.workflows.leaderboard.contact import grade_forces, truth_force

                force = truth_force(case, truth)
                grade_forces(rows[board.name], force.force, case, force.own_error)
                for row in rows[board.name]:
                    if row.budget:
                        row.budget["model_how"] = CONTACT_MODEL_HOW
            log(f"{board.name}: graded against the truth {case}")
        del truth


def grade_users(
    boards: list[Board],
    rows: dict[str, list[Row]],
    users: dict,
    graded: dict | None = None,
    out: Path = Path("results"),
    on_graded=None,
    comm: MPI.Comm = MPI.COMM_SELF,
) -> None:
    """The users' rows joined to their cases and graded from their series (rows.user_rows
    reads them with no grade): against the case's reference (grade_row_reference), against
    each case's truth where it has one (its cached truth loaded once per case), and their
    error budgets; the Pareto fronts marked again. A row of a series that the record holds
    already graded (`graded` {user_key: Row}: the same series by its content hash) keeps the
    record's grades. A truth that is not computed here is named, with the command that
    computes it, in the rows' notes and in one line on stderr per case. Each row is graded
    whole (reference, truth, budget), and `on_graded(board, row, seconds)` is called on rank 0
    as each ends.

    Collective over comm (rank 0's arguments are the ones read, the others' are not used): the
    rows to grade are shared out, the k-th to rank k mod size, each rank grading its share with
    its own copy of the truth (from the cache) and its own Caches (each mesh located, and our
    implicit run on it, once per rank); rank 0 takes each row as it ends. A row's numbers are
    the same whichever rank grades it, and so are the results for any number of ranks."""
    from tissuebench.solvers.truth.store import expected_words, load_cached

    truths = {}
    tasks = []  # (board, row) to grade, in the boards' order (rank 0's)
    if comm.rank == 0:
        for board in boards:
            mine = list(users.get(board.name, []))
            rows[board.name] = [r for r in rows[board.name] if r.kind is not Kind.USER] + mine
            kept = set()  # ids of the rows whose budget the record holds, complete
            for row in mine:
                before = (graded or {}).get(user_key(row)) if row.series_hash else None
                if before is None or before.status == UNGRADED:
                    continue
                take_grades(row, {**grades_of(before), "budget": {}})
                if complete(before.budget):
                    row.budget = dict(before.budget)
                    kept.add(id(row))
            pending = [r for r in mine if id(r) not in kept]
            run_here = any(r.truth and r.series for r in pending)  # our implicit on its mesh
            if board.truth is not None and (any(not r.truth for r in mine) or run_here):
                if board.truth not in truths:
                    truths[board.truth] = load_cached(board.truth, comm=MPI.COMM_SELF)
                truth = truths[board.truth]
                todo = (
                    f"`tissuebench truth {board.truth}` computes it "
                    f"({expected_words(board.truth)} on one core, once), then `tissuebench "
                    f"leaderboard --out {out}` grades against it"
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
            tasks += [(board, row) for row in pending]
    if comm.size == 1:
        caches = Caches(out)
        for board, row in tasks:  # each graded whole (truth, then budget) and said as it ends
            truth = truths.get(board.truth) if board.truth is not None else None
            seconds = grade_user_row(board, rows[board.name], row, truth, caches)
            if on_graded is not None:
                on_graded(board, row, seconds)
    else:
        _grade_shared(comm, tasks, rows, truths, on_graded, out)
    if comm.rank == 0:
        for board in boards:
            mark_pareto(rows[board.name])
            if any(
                truth_error(r, k) is not None for r in rows[board.name] for k in ("mean", "max")
            ):
                mark_truth_pareto(rows[board.name])


def grade_user_row(board: Board, board_rows: list[Row], row: Row, truth, caches: Caches) -> float:
    """One user's row graded whole from its series: against the case's reference (where it
    is not graded yet), against the truth (where it has none yet and the truth is here), then
    its error budget; or its grades taken from a row of the same series (and, on a contact
    case, the same force) graded before in this run (Caches.grades, by content hash). The
    seconds it took."""
    start = time.perf_counter()
    key = (board.name, row.series_hash, row.series_field, truth is not None, row.model)
    key += (force_hash(row),)  # a contact case's: the force graded with it, by its content
    done = caches.grades.get(key) if row.series_hash else None
    if done is not None:
        take_grades(row, done)
        return time.perf_counter() - start
    if row.status == UNGRADED:
        grade_row_reference(board, row, caches)
    if is_contact(board) and not row.contact and row.status != UNGRADED:
        from tissuebench.workflows.leaderboard.contact import user_contact

        series = caches.series(str(row.series), row.series_field)
        user_contact(board, board_rows, row, series, truth)
    if truth is not None and not row.truth:
        grade_row_truth(truth, row, caches)
    if row.truth:
        error_budget(board_rows, only=[row], board=board, truth=truth, caches=caches)
    if row.series_hash and row.status != UNGRADED:
        caches.grades[key] = grades_of(row)
    return time.perf_counter() - start


GRADED_ROW = 35  # the MPI tag of a graded user row sent to rank 0


def _grade_shared(
    comm: MPI.Comm, tasks: list, rows: dict, truths: dict, on_graded, out: Path | None = None
) -> None:
    """grade_users' rows (rank 0's `tasks`, (board, row)) graded on every rank of comm, the k-th
    by rank k mod size; every other rank sends each row's grades (grades_of: reference and
    truth columns, status, mesh, note, budget) to rank 0 as it ends, where they are put into
    rank 0's row and on_graded is called. A rank that cannot load a truth rank 0 has sends its
    rows back ungraded, and rank 0 grades them; an error anywhere is raised on every rank once
    all rows are in. A signal (recorded, under mpiexec, core/interrupt.py) stops each rank
    before its next row, and every rank raises it together once the rows graded so far are in
    (and recorded by on_graded)."""
    from tissuebench.solvers.truth.store import load_cached

    plan = None
    if comm.rank == 0:
        # each case with rows to grade: the board and its rows
        shared: dict[str, tuple[Board, list[Row]]] = {}
        for board, _ in tasks:
            shared.setdefault(board.name, (board, rows[board.name]))
        listed = []
        for board, row in tasks:
            index = next(i for i, r in enumerate(rows[board.name]) if r is row)
            listed.append((board.name, index, truths.get(board.truth) is not None))
        plan = (shared, listed, out)
    shared, listed, out = comm.bcast(plan, root=0)
    caches, held = Caches(out), (None, None)  # held: (case, truth) of this rank
    error, sent, back, received = None, [], [], 0

    def truth_of(board: Board, here: bool):
        nonlocal held
        if not here:
            return None
        if comm.rank == 0:
            return truths[board.truth]
        if held[0] != board.truth:
            held = (None, None)  # the last case's let go first
            held = (board.truth, load_cached(board.truth, comm=MPI.COMM_SELF))
        return held[1]

    def receive() -> None:
        """One row from another rank, taken."""
        nonlocal received
        take(comm.recv(source=MPI.ANY_SOURCE, tag=GRADED_ROW))
        received += 1

    def take(message) -> None:
        nonlocal error
        k, grades, seconds, problem = message
        board, row = tasks[k]
        if problem == "stopped":
            return  # not graded: a signal came (raised on every rank below)
        if problem == "no truth":
            back.append(k)
        elif problem is not None:
            error = error or RuntimeError(problem)
        else:
            take_grades(row, grades)
            if on_graded is not None:
                on_graded(board, row, seconds)

    mine = [k for k in range(len(listed)) if k % comm.size == comm.rank]
    for k in mine:
        name, index, here = listed[k]
        if comm.rank == 0:  # its own rows, graded in place
            board, row = tasks[k]
            board_rows = rows[board.name]
        else:
            board, board_rows = shared[name]
            row = board_rows[index]
        message = (k, None, 0.0, None)
        if interrupt.pending():  # a signal: no more rows; all ranks stop together below
            message = (k, None, 0.0, "stopped")
            if comm.rank != 0:
                sent.append(comm.isend(message, dest=0, tag=GRADED_ROW))
            continue
        try:
            truth = truth_of(board, here)
            if here and truth is None:
                message = (k, None, 0.0, "no truth")
            else:
                seconds = grade_user_row(board, board_rows, row, truth, caches)
                message = (k, grades_of(row), seconds, None)
        except Exception as exc:  # said on every rank once all rows are in
            message = (k, None, 0.0, f"rank {comm.rank}: {type(exc).__name__}: {exc}")
        if comm.rank == 0:
            if message[3] is None:
                if on_graded is not None:
                    on_graded(board, row, message[2])
            else:
                take(message)
            while comm.iprobe(source=MPI.ANY_SOURCE, tag=GRADED_ROW):  # the others' rows
                receive()
        else:
            sent.append(comm.isend(message, dest=0, tag=GRADED_ROW))
    if comm.rank == 0:
        expected = sum(1 for k in range(len(listed)) if k % comm.size != 0)
        while received < expected:
            receive()
        for k in back:  # rows whose rank had no truth: graded here
            if interrupt.pending():
                break
            board, row = tasks[k]
            seconds = grade_user_row(board, rows[board.name], row, truths[board.truth], caches)
            if on_graded is not None:
                on_graded(board, row, seconds)
    MPI.Request.Waitall(sent)
    interrupt.checkpoint(comm)  # a signal on any rank: raised on every rank, the rows so far kept
    error = comm.bcast(error, root=0)
    if error is not None:
        raise error
