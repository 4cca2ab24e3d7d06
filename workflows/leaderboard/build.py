"""`tissuebench leaderboard`: the record read (or cases rerun), the users' folders read and
checked, everything graded, then every output written as one set (write_set)."""

from __future__ import annotations

import argparse
import json
import os
import shutil
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.workflows.io.manifest import unchanged
from tissuebench.workflows.io.output import (
    OutputError,
    check_writable,
    collective,
    write_set,
)
from tissuebench.workflows.io.tables import CSVError, read_rows
from tissuebench.workflows.leaderboard import document, frontier_rows, page, resume, users
from tissuebench.workflows.leaderboard.boards import is_contact
from tissuebench.workflows.leaderboard.figures import (
    drawing_code,
    machine,
    plot_case,
    stamp_of,
    unit_of,
)
from tissuebench.workflows.leaderboard.force_figure import (
    force_drawing_code,
    force_png,
    plot_force,
)
from tissuebench.workflows.leaderboard.frontier_rows import (
    COMMITTED,
    join_frontier,
    strip_frontier,
)
from tissuebench.workflows.leaderboard.grading import grade_truths, grade_users, study_series
from tissuebench.workflows.leaderboard.mesh_sensitivity import NAME as SENSITIVITY
from tissuebench.workflows.leaderboard.mesh_sensitivity_board import leaderboard_boards
from tissuebench.workflows.leaderboard.record import (
    FOLDER,
    MARKER,
    OWNED,
    RECORD,
    LeaderboardError,
    Record,
    committed_record,
    read_record,
    record_folder,
    record_of,
    record_text,
    with_committed_rows,
)
from tissuebench.workflows.leaderboard.row import Kind, kind_of
from tissuebench.workflows.leaderboard.rows import (
    BOARDS,
    mark_pareto,
    write_csv,
)
from tissuebench.workflows.leaderboard.runs import run_board
from tissuebench.workflows.leaderboard.users import read_users, user_key
from tissuebench.workflows.run.checks import check_common
from tissuebench.workflows.simulators import get_simulator

STAGED_HOOK = None  # called once every output is staged (tests: a signal at that moment)


def check_target(
    out: Path,
    available: set[str],
    force: bool,
    record: tuple | None = None,
    rerun: list[str] | None = None,
) -> None:
    """Refuse to replace a leaderboard.md we did not write; a partial rerun where there is a
    leaderboard but no record of the other cases; and, without force, a rerun of cases whose
    recorded rows (or, without a record, leaderboard.csv's) include a simulator that is not
    installed here (a rerun never drops what it cannot run again)."""
    md = out / "leaderboard.md"
    if md.exists() and not md.read_text(errors="replace").startswith(MARKER):
        raise OutputError(
            f"{md}: exists and was not written by tissuebench leaderboard; move it or choose "
            "another --out"
        )
    old = out / "leaderboard.csv"
    partial = rerun is not None and len(rerun) < len(BOARDS)
    if record is None and partial and old.is_file() and not force:
        raise OutputError(
            f"{out / 'leaderboard.json'}: no record of the cases not named, which a partial "
            "rerun would drop from the leaderboard: `--rerun` with no case reruns them all "
            "(or pass --force to write the named cases alone)"
        )
    if force:
        return
    if record is not None:
        labels = [
            r.label
            for name, rows in record[1].items()
            if rerun is None or name in rerun
            for r in rows
            if r.kind not in (Kind.USER, Kind.OURS)
        ]
    elif old.is_file():
        try:  # a simulator's rows only: a user's label or ours never names a simulator
            labels = [
                row.get("label") or ""
                for row in read_rows(old, errors="replace")
                if kind_of(row.get("source") or "") not in (Kind.USER, Kind.OURS)
            ]
        except CSVError:
            labels = []  # not a leaderboard's table: nothing in it to keep
    else:
        return
    lost = sorted({lab.split(":")[0] for lab in labels if ":" in lab} - available)
    if lost:
        raise OutputError(
            f"{out}: the leaderboard has rows of {', '.join(lost)}, which cannot run here: "
            "install it (make external-tools), or rerun only the cases without it (--rerun "
            "CASE), or pass --force to replace those rows"
        )


def load_average() -> float:
    """The machine's one-minute load average (runnable processes; above the core count, the
    timed runs shared their cores with other work); NaN where the system does not say."""
    try:
        return round(os.getloadavg()[0], 2)
    except (OSError, AttributeError):
        return float("nan")


def as_drawn_now(png: Path, code: str | None = None) -> bool:
    """Whether a figure is in place as we wrote it and drawn by today's code: `code`, the hash
    of the code that draws it (default: a case figure's, drawing_code())."""
    return unchanged(png) and stamp_of(png) == (drawing_code() if code is None else code)


def keep_or_draw(files: dict, png: Path, theirs: Path, same: bool, code: str, draw) -> None:
    """Stage `png` in `files`: kept where it is drawn of the same rows (`same`) by today's code
    (`code`, as_drawn_now), else copied from the record's own figure `theirs` where that one
    is, else drawn (`draw(tmp)`): seconds saved per case."""
    if same and as_drawn_now(png, code):
        return
    if same and as_drawn_now(theirs, code):
        files[png] = lambda tmp: shutil.copyfile(theirs, tmp)
    else:
        files[png] = draw


def check_rerun(names: list[str] | None) -> list[str] | None:
    """The cases to rerun (None: none; all of BOARDS when --rerun names none); an unknown name
    is refused in one line that lists the cases."""
    if names is None:
        return None
    known = [b.name for b in BOARDS]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise LeaderboardError(
            f"--rerun {unknown[0]}: no such case; name some of {', '.join(known)}, or none for all"
        )
    return list(dict.fromkeys(names)) or known


def frontier_table(out: Path, warn) -> dict[str, list[dict]]:
    """The SPEC 11 frontier's runs the page shows: the clone's committed frontier.csv only
    (frontier_rows.committed_frontier: from git, never a file anyone can write); OUT's own
    frontier.csv, where it is another file, is not read, and `warn` is told so in one line."""
    mine = out / "frontier" / "frontier.csv"
    if mine.is_file() and mine.resolve() != (frontier_rows.clone_root() / COMMITTED).resolve():
        warn(
            f"{mine}: not read: the leaderboard shows the committed frontier rows only "
            f"({COMMITTED} as the clone's git holds it)"
        )
    return frontier_rows.committed_frontier(warn)


def committed_rows(record: Record, source: Path, out: Path) -> Record:
    """The record read from `source` with the rows of ours and the simulators as the clone's
    git holds them (record.with_committed_rows; each case that was not, one line). Where the
    record read is the clone's own working copy and is to be written over (`source` is OUT),
    a copy of it is kept first as OUT/leaderboard.json.uncommitted: a rerun not yet committed
    is not lost."""
    committed, why = committed_record()
    said: list[str] = []
    held, changed = with_committed_rows(record, committed, why, said.append)
    for line in said:
        print(f"tissuebench leaderboard: {line}")
    clone = frontier_rows.clone_root() / "results"
    if changed and source == out and source.resolve() == clone.resolve():
        kept = out / f"{RECORD}.uncommitted"
        shutil.copyfile(out / RECORD, kept)
        print(f"tissuebench leaderboard: the working copy's record kept as {kept}")
    return held


def main(args: argparse.Namespace) -> int:
    """Render the leaderboard from its record with the users' rows, or rerun (--rerun) the
    cases named; write OUT/leaderboard.md, .csv, .json and the figures (rank 0)."""
    import time

    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    rerun = check_rerun(getattr(args, "rerun", None))
    check_writable(out, comm, owned=OWNED)
    source = record_folder(out, getattr(args, "results", None))  # read only, unless it is OUT
    record = collective(comm, lambda: read_record(source))
    if record is None and rerun is None:
        raise LeaderboardError(
            f"{out / RECORD}: no leaderboard record here, nor in a clone's results/ that "
            "tissuebench is installed from: name the folder that holds one with --results DIR "
            f"(a clone's results/), or `tissuebench leaderboard --out {out} --rerun` runs and "
            "times every case and writes one (10 minutes or more; only the simulators "
            "installed here)"
        )
    if source != out and comm.rank == 0:
        print(
            f"tissuebench leaderboard: rendering the record {source / RECORD} (only read) "
            f"with the user folders under {out / FOLDER}, into {out}"
        )
    elif comm.rank == 0:  # a render in place says which record it reads too (issue: a second
        # render read the copy the first wrote, and said nothing)
        print(
            f"tissuebench leaderboard: rendering the record {source / RECORD}, the one in "
            f"{out} (a render writes its record beside it; --results DIR renders another), "
            f"with the user folders under {out / FOLDER}"
        )
    if rerun is not None:
        available = set()
        for board in BOARDS:
            for name in board.simulators:
                if comm.rank == 0 and get_simulator(name).available() is None:
                    available.add(name)
        # what a rerun would replace is OUT's own record only (another folder's is only read)
        own = record if source == out else None
        collective(comm, lambda: check_target(out, available, args.force, own, rerun))
    session = time.strftime("%Y-%m-%d %H:%M %Z")
    kept_boards, kept_rows, kept_notes = record or ([], {}, {})
    # what each figure was drawn of: the record's cases as read, the frontier's rows among them
    drawn = {c["board"]["name"]: c for c in record_of(kept_boards, kept_rows, kept_notes)["cases"]}
    drawn = {name: json.dumps(c) for name, c in drawn.items()}
    if record is not None and comm.rank == 0:  # ours and the simulators': as committed only
        kept_boards, kept_rows, kept_notes = committed_rows(record, source, out)
    kept_boards, kept_rows, kept_notes = comm.bcast((kept_boards, kept_rows, kept_notes), root=0)
    kept_rows = strip_frontier(kept_rows)  # the frontier's rows: read again (committed)
    kept = {b.name: b for b in kept_boards}
    rows, notes, boards = {}, {}, []
    fresh = []
    for board in BOARDS:
        if rerun is not None and board.name in rerun:
            board.session, board.machine = session, machine()
            fresh.append(board)
            boards.append(board)
        elif board.name in kept:
            boards.append(kept[board.name])
            rows[board.name] = kept_rows[board.name]
            notes[board.name] = kept_notes[board.name]
    studied = []
    if rerun is not None and len(rerun) == len(BOARDS):  # everything anew: the study read again
        studied = leaderboard_boards(out, log=users.warn) if comm.rank == 0 else []
    else:  # the other cases of the record: the mesh-sensitivity study's, as recorded; a case
        # that BOARDS no longer has (its load changed, say) is dropped, in one line
        names = {b.name for b in BOARDS}
        for board in kept_boards:
            if board.name in names:
                continue
            if not board.name.startswith(f"{SENSITIVITY}-"):
                if comm.rank == 0:
                    print(f"tissuebench leaderboard: {board.name} is no longer a case; dropped")
                continue
            boards.append(board)
            rows[board.name], notes[board.name] = kept_rows[board.name], kept_notes[board.name]
    # what is read is read and checked before anything runs (rank 0 reads and writes)
    cases = [b for b in boards if b.name in {x.name for x in BOARDS}]  # the study's: no users
    found, left_out = read_users(out, cases) if comm.rank == 0 else ({}, {})
    frontier = (  # the SPEC 11 frontier's committed runs, each checked (a bad one: one line)
        frontier_table(out, users.warn) if comm.rank == 0 else {}
    )
    interrupt.will_write(  # named on a signal: the old ones stay as they were
        [out / name for name in OWNED] + [out / FOLDER / "*.png", out / FOLDER / "index.html"]
    )
    # each case rerun is graded against its truth as it ends and kept (resume.Finished), so that
    # a rerun stopped part way resumes from the cases it finished
    finished = resume.Finished(out) if comm.rank == 0 and fresh else None
    for i, board in enumerate(fresh):
        taken = finished.take(board) if finished is not None else None
        if comm.bcast(taken is not None, root=0):
            if taken is not None:  # rank 0: the case as that run left it
                fresh[i] = boards[boards.index(board)] = taken[0]
                rows[board.name], notes[board.name] = taken[1], taken[2]
            else:  # the other ranks: rank 0's rows are the ones read
                rows[board.name], notes[board.name] = [], []
            continue
        start = load_average()
        rows[board.name], notes[board.name] = run_board(board, out, args.solver, args.petsc, comm)
        board.load = (start, load_average())
        if finished is not None:  # rank 0: against the truth (serial), then kept
            grade_truths([board], rows)
            finished.keep(board, rows[board.name], notes[board.name])
    for board, board_rows in studied:
        mark_pareto(board_rows)  # the mesh-sensitivity study's runs
        study_series(out, board, board_rows)
        board.session, board.machine = session, machine()
        boards.append(board)
        rows[board.name], notes[board.name] = board_rows, []
    graded, progress = {}, None
    if comm.rank == 0:  # against the truth: serial, on rank 0, which writes
        grade_truths([b for b, _ in studied], rows)  # the reruns': graded as each ended
        graded = {  # users' rows of the record graded against the truth of a case not rerun
            user_key(r): r
            for b in kept_boards
            if b.name not in (rerun or [])
            for r in kept_rows[b.name]
            if r.kind is Kind.USER
        }
        progress = users.Progress(out, sum(len(v) for v in found.values()))
        graded.update(progress.resumed())
    # the users' rows: shared out among the ranks, each recorded on rank 0 as it ends
    grade_users(boards, rows, found, graded, out, on_graded=progress, comm=comm)
    graded_rows = rows

    def write():
        # every row of the page is in the record and the CSV, the frontier's too (their Pareto
        # front against the truth marked again with them)
        rows = join_frontier(boards, graded_rows, frontier)
        record = record_of(boards, rows, notes)
        files = {}  # every output, staged and then moved into place as one set
        for board, case in zip(boards, record["cases"], strict=True):
            same = drawn.get(board.name) == json.dumps(case)  # drawn of the same rows
            png = out / FOLDER / f"{board.name}.png"
            keep_or_draw(  # beside the record's own figure (OUT's, or another folder's)
                files,
                png,
                source / FOLDER / png.name,
                same,
                drawing_code(),
                lambda tmp, board=board: plot_case(tmp, board, rows[board.name]),
            )
            if is_contact(board):  # SPEC 12: the needle force against time, as the case's
                # figure (drawn from the force curves the record carries: any render draws it)
                keep_or_draw(
                    files,
                    force_png(out, board),
                    force_png(source, board),
                    same,
                    force_drawing_code(),
                    lambda tmp, board=board: plot_force(tmp, board, rows[board.name]),
                )
        every = [r for board in boards for r in rows[board.name]]
        files[out / RECORD] = lambda tmp: tmp.write_text(record_text(record))
        files[out / "leaderboard.csv"] = lambda tmp: write_csv(tmp, every)
        shown = {b.name: notes.get(b.name, []) + left_out.get(b.name, []) for b in boards}
        text = document.markdown(boards, rows, shown, session)
        files[out / "leaderboard.md"] = lambda tmp: tmp.write_text(text)
        index = page.render(boards, rows, shown, session, unit_of)
        files[out / FOLDER / "index.html"] = lambda tmp: tmp.write_text(index)
        write_set(files, staged_hook=STAGED_HOOK)

    collective(comm, write, out)
    if comm.rank == 0:
        assert progress is not None  # rank 0's
        progress.done()
    if finished is not None:
        finished.done()
    interrupt.will_write([])  # all written
    if comm.rank == 0:
        what = "rerun " + ", ".join(rerun) if rerun else f"from the record {source / RECORD}"
        print(
            f"wrote {out / FOLDER / 'index.html'} (the page), {out / 'leaderboard.md'}, "
            f"{out / 'leaderboard.csv'}, {out / RECORD} and {out / FOLDER}/*.png ({what}; "
            f"{sum(len(v) for v in found.values())} user rows)"
        )
    return 0
