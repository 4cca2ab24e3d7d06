"""`tissuebench leaderboard --out results`: OUT/leaderboard.md, OUT/leaderboard.csv and a
figure per case (workflows/ranking.py), rendered from the record OUT/leaderboard.json with the
users' compare folders read, checked against their case and graded against its truth (no
rerun: seconds; a user's row new to the record gets our implicit run on its own mesh for its
error budget, workflows/user_mesh.py: a few seconds on the rod). `--rerun [CASE ...]`: every
algorithm and model of ours and every outside simulator that poses those cases (all when none
is named) run, graded against one reference and timed in this session; the other cases keep
their recorded rows and say when they were timed.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import re
import sys
from dataclasses import asdict, fields
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

import numpy as np

from tissuebench.meshes.errors import UserError
from tissuebench.solvers import ALGORITHMS, interrupt
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.models import run_label
from tissuebench.workflows.commands.arguments import add_common, check_common
from tissuebench.workflows.leaderboard import document, page
from tissuebench.workflows.mesh_sensitivity import leaderboard_boards
from tissuebench.workflows.output import (
    OutputError,
    check_writable,
    collective,
    file_hash,
    read_manifest,
    read_summary,
    write_owned,
)
from tissuebench.workflows.ranking import (
    BOARDS,
    E_I,
    E_N,
    Board,
    Row,
    candidate_of,
    external_rows,
    finite,
    mark_pareto,
    mark_truth_pareto,
    misplaced,
    our_rows,
    truth_error,
    user_rows,
    write_csv,
)
from tissuebench.workflows.reports.budget import budget_rows, plot_budget
from tissuebench.workflows.reports.leaderboard import machine, plot_case, unit_of
from tissuebench.workflows.simulators import get_simulator
from tissuebench.workflows.simulators.runner import SimulatorError, run_external
from tissuebench.workflows.study import model_case, run_case
from tissuebench.workflows.summary import CaseSummary

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples

FOLDER = "leaderboard"
MARKER = "# Leaderboard: accuracy against cost"
# The cases are ranking.BOARDS (tissuebench export names the one its options pose).


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "leaderboard",
        help="accuracy against cost of our algorithms, outside simulators and users' runs",
        description="Render OUT/leaderboard.md, OUT/leaderboard.csv and OUT/leaderboard/CASE.png "
        "from the record OUT/leaderboard.json, with the runs that users graded with "
        "`tissuebench compare --label NAME --wall-time S --out OUT/leaderboard/CASE/user/NAME` "
        "(read, checked against their case, graded against its truth: seconds, nothing is "
        "rerun). --rerun runs and times every algorithm and model of ours and every variant of "
        "every outside simulator installed here on each case (or on the cases named) in this "
        "session, grades each against the case's reference and its truth, and writes the "
        "record; the cases not named keep their recorded rows.",
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    p.add_argument(
        "--rerun",
        nargs="*",
        metavar="CASE",
        help=f"rerun and re-time these cases (none named: all; {', '.join(b.name for b in BOARDS)})"
        " instead of taking their rows from the record",
    )
    add_common(p)
    p.set_defaults(func=main)


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
            if r.source not in ("user", "tissuebench")
        ]
    elif old.is_file():
        with open(old, newline="", errors="replace") as f:
            try:  # a simulator's rows only: a user's label or ours never names a simulator
                labels = [
                    row.get("label") or ""
                    for row in csv.DictReader(f)
                    if row.get("source") not in ("user", "tissuebench")
                ]
            except csv.Error:
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


def run_board(
    board: Board,
    out: Path,
    solver: str,
    petsc: str,
    comm,
    log=print,
    users: list[Row] | None = None,
):
    """Our runs, then every simulator's, of one case, with the users' rows (read and checked
    before anything runs: read_users); returns (rows, notes)."""
    folder = out / FOLDER / board.name
    reference = run_label("implicit", board.model)
    case = model_case(
        board.name,
        board.benchmark,
        board.material,
        list(ALGORITHMS),
        list(board.models),
        reference,
        options=board.options,
        mesh_size=board.mesh_size,
        end_time=board.end_time,
        solver=solver,
        petsc=petsc,
        description=board.description,
    )
    summary = run_case(case, folder / "ours", comm, log, force=True)
    rows: list[Row] = our_rows(board.name, summary)
    for row in rows:
        row.series = str(folder / "ours" / f"{row.label}.xdmf")
    if board.models == ("linear",):
        rows += simplex_rows(board, case, folder, summary, comm, log)
    notes = []
    if board.skip_note:
        notes.append(board.skip_note)
    for name in board.simulators:
        missing = comm.bcast(get_simulator(name).available() if comm.rank == 0 else None, root=0)
        if missing:
            notes.append(f"{name}: not run on this machine ({missing})")
            continue
        chosen = board.variants.get(name)
        if chosen is not None and not chosen:
            continue  # none at this size: the board's skip_note says why
        try:
            result = run_external(
                name,
                folder / name,
                benchmark=board.benchmark,
                mesh_size=summary.mesh_size,
                options=board.options,
                material=get_material(board.material),
                model=board.simulator_model or board.model,
                h=summary.h,
                steps=summary.steps,
                variants=list(chosen) if chosen is not None else None,
                solver=solver,
                petsc=petsc,
                force=True,
                comm=comm,
                log=log,
            )
        except SimulatorError as exc:
            notes.append(str(exc))
            continue
        graded = external_rows(board.name, result)
        for row, run in zip(graded, result["runs"].values(), strict=True):
            row.series, row.series_field = external_series(folder / name, run.get("variant"))
        rows += graded
        for variant, why in (result.get("skipped_variants") or {}).items():
            notes.append(f"{name}:{variant} not posed: {why}")
    rows += users or []
    mark_pareto(rows)
    return rows, notes


def simplex_rows(
    board: Board, case, folder: Path, summary: CaseSummary, comm, log=print
) -> list[Row]:
    """Our algorithms on the board's mesh size in simplices (the grid split, and gmsh's
    unstructured mesh: SPEC 9), each graded on its own mesh against the board's reference."""
    from dataclasses import replace

    from tissuebench.meshes import get_entry
    from tissuebench.metrics.compare import summarize
    from tissuebench.workflows.grading import grade
    from tissuebench.workflows.mesh_sensitivity import shapes

    reference = folder / "ours" / f"{summary.reference}.xdmf"
    gdim = get_entry(board.benchmark).gdim
    rows = []
    for shape, options in list(shapes(gdim).items())[1:]:
        name = shape.replace(" ", "-")
        sub = replace(case, name=f"{board.name}-{name}", options={**board.options, **options})
        on_shape = run_case(sub, folder / f"ours-{name}", comm, log, force=True)
        for row in our_rows(board.name, on_shape):
            row.series = str(folder / f"ours-{name}" / f"{row.label}.xdmf")
            graded = grade(reference, row.series, comm=comm)
            for metric, curve in graded.curves.items():
                row.errors[f"{metric}_max"], row.errors[f"{metric}_mean"] = summarize(curve)
            row.label = f"{row.label} ({shape})"
            row.mesh = f"{shape}: {on_shape.num_dofs // gdim} nodes"
            row.reference = False
            row.group = "tissuebench on simplices"
            rows.append(row)
    return rows


def external_series(folder: Path, variant) -> tuple[str | None, str | None]:
    """The series file (and its field) that a simulator variant's compare graded, as its
    summary.json (FOLDER/VARIANT/summary.json) records it; the file was recorded in the
    folder's partial copy, so its path is taken from the variant's folder on (None, None
    when nothing is recorded). Rank 0 reads."""
    if not isinstance(variant, str) or not variant:
        return None, None
    summary = read_summary(folder / variant)
    recorded = candidate_of(summary) if isinstance(summary, dict) else {}
    file = recorded.get("series")
    if file is None:
        return None, None
    parts = Path(file).parts
    if variant in parts:  # .../<partial folder>/VARIANT/...: the same under the final folder
        at = len(parts) - 1 - parts[::-1].index(variant)
        moved = folder.joinpath(*parts[at:])
        if moved.is_file() or not Path(file).is_file():
            file = str(moved)
    return file, recorded.get("series_field")


# --- against the truth (SPEC 10) ----------------------------------------------------------------

# the truth case (SPEC 10) of each mesh-sensitivity study's board (the block's study is w = 0.2)
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

    return tuple(None if not finite(x) else float(x) for x in summarize(curve))


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
        g = grade_truth(truth, cand, MPI.COMM_SELF, label=row.label)
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

    cases = {}
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


def read_users(out: Path, boards: list[Board]) -> tuple[dict, dict]:
    """Every user's compare folder of every case (OUT/leaderboard/CASE/user/NAME), read and
    checked (ranking.user_rows): ({case: [Row]}, {case: [one line per folder or run left
    out]}); each line left out is also printed on stderr, and so is every folder under
    OUT/leaderboard that is not read although it may be meant to be (ranking.misplaced: not
    a case, or a compare folder outside user/). Rank 0."""
    rows, skipped = {}, {}
    for board in boards:
        folder = out / FOLDER / board.name / "user"
        rows[board.name], skipped[board.name] = user_rows(board, folder, boards)
        for line in skipped[board.name]:
            warn(line)
    if (out / FOLDER).is_dir():
        for line in misplaced(out / FOLDER, boards):
            warn(line)
    return rows, skipped


def warn(line: str) -> None:
    """One line on stderr: something read was left out, and why."""
    print(f"tissuebench leaderboard: {line}", file=sys.stderr)


# --- the record --------------------------------------------------------------------------------

RECORD = "leaderboard.json"
RECORD_SCHEMA = "tissuebench.leaderboard"
RECORD_VERSION = 1
OWNED = ["leaderboard.md", "leaderboard.csv", RECORD]


class LeaderboardError(UserError):
    """A leaderboard that cannot be made as asked (no record, an unknown case): one line."""


def board_of(d: dict) -> Board:
    """A Board from its record (lists back to tuples)."""
    known = {f.name for f in fields(Board)}
    b = Board(**{k: v for k, v in d.items() if k in known})
    b.models, b.simulators = tuple(b.models), tuple(b.simulators)
    b.variants = {k: tuple(v) for k, v in (b.variants or {}).items()}
    return b


def row_of(d: dict) -> Row:
    """A Row from its record."""
    known = {f.name for f in fields(Row)}
    return Row(**{k: v for k, v in d.items() if k in known})


def record_of(boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]]) -> dict:
    """leaderboard.json: every case's Board (what renders it: description, truth, its band and
    note, sizes, session, machine), its notes (the run's; the users' refusals are not kept: they
    are read again) and every Row with all its fields (errors in m^gdim or relative, wall times
    in s, truth columns, Pareto flags, error budget)."""
    return {
        "schema": RECORD_SCHEMA,
        "version": RECORD_VERSION,
        "cases": [
            {
                "board": asdict(b),
                "notes": list(notes.get(b.name, [])),
                "rows": [asdict(r) for r in rows[b.name]],
            }
            for b in boards
        ],
    }


def load_average() -> float:
    """The machine's one-minute load average (runnable processes; above the core count, the
    timed runs shared their cores with other work); NaN where the system does not say."""
    try:
        return round(os.getloadavg()[0], 2)
    except (OSError, AttributeError):
        return float("nan")


def read_record(out: Path) -> tuple[list[Board], dict, dict] | None:
    """The record OUT/leaderboard.json as (boards, {case: rows}, {case: notes}); None when there
    is none. LeaderboardError when it cannot be read. Rank 0."""
    path = out / RECORD
    if not path.is_file():
        return None
    redo = f"`tissuebench leaderboard --out {out} --rerun` writes a new one"
    try:
        doc = json.loads(path.read_text())
        if doc.get("schema") != RECORD_SCHEMA or doc.get("version") != RECORD_VERSION:
            raise ValueError(f"not a {RECORD_SCHEMA} record of version {RECORD_VERSION}")
        boards, rows, notes = [], {}, {}
        for case in doc["cases"]:
            board = board_of(case["board"])
            boards.append(board)
            rows[board.name] = [row_of(r) for r in case["rows"]]
            notes[board.name] = [str(n) for n in case.get("notes", [])]
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise LeaderboardError(
            f"{path}: cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())[:160]}); "
            f"{redo}"
        ) from None
    return boards, rows, notes


def user_key(row: Row) -> str:
    """What makes a user's row the same run graded the same way: case, label, series, field,
    same-mesh grades and wall time."""
    return json.dumps(
        [row.case, row.label, row.series, row.series_field, row.errors, row.wall_time_s]
    )


def grade_users(
    boards: list[Board],
    rows: dict[str, list[Row]],
    users: dict,
    graded: dict | None = None,
    out: Path = Path("results"),
) -> None:
    """The users' rows joined to their cases, graded against each case's truth where it has one
    (its cached truth loaded once per case; a user's row graded by compare against the truth
    keeps its columns; one the record holds already graded, `graded` {user_key: Row}, keeps the
    record's), the Pareto fronts marked again and the users' error budgets. A truth that is not
    computed here is named, with the command that computes it, in the rows' notes and in one
    line on stderr per case. Rank 0."""
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
                warn(
                    f"{board.name}: {sum(not r.truth for r in mine)} user row(s) not graded "
                    f"against the truth {board.truth}, which is not computed here: " + todo
                )
            for row in mine:
                if truth is None and not row.truth:
                    row.truth_note = (
                        f"the truth {board.truth} is not computed on this machine: {todo}"
                    )
                elif not row.truth:
                    grade_row_truth(truth, row)
        mark_pareto(rows[board.name])
        if any(truth_error(r, k) is not None for r in rows[board.name] for k in ("mean", "max")):
            mark_truth_pareto(rows[board.name])
            truth = truths.get(board.truth)
            error_budget(rows[board.name], only=pending, board=board, truth=truth)


def complete(budget: dict) -> bool:
    """Whether an error budget holds all four parts as finite numbers."""
    return all(
        finite(budget.get(part)) for part in ("total", "discretisation", "algorithm", "model")
    )


def unchanged(path: Path) -> bool:
    """Whether a file of ours is in place as we wrote it (listed in its folder's manifest with
    its present hash)."""
    listed = read_manifest(path.parent, "files") or {}
    return path.is_file() and listed.get(path.name) == file_hash(path)


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


def main(args: argparse.Namespace) -> int:
    """Render the leaderboard from its record with the users' rows, or rerun (--rerun) the
    cases named; write OUT/leaderboard.md, .csv, .json and the figures (rank 0)."""
    import time

    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    rerun = check_rerun(getattr(args, "rerun", None))
    check_writable(out, comm, owned=OWNED)
    record = collective(comm, lambda: read_record(out))
    if record is None and rerun is None:
        raise LeaderboardError(
            f"{out / RECORD}: no leaderboard record here: `tissuebench leaderboard --out {out} "
            "--rerun` runs and times every case and writes one (10 minutes or more)"
        )
    if rerun is not None:
        available = set()
        for board in BOARDS:
            for name in board.simulators:
                if comm.rank == 0 and get_simulator(name).available() is None:
                    available.add(name)
        collective(comm, lambda: check_target(out, available, args.force, record, rerun))
    session = time.strftime("%Y-%m-%d %H:%M %Z")
    kept_boards, kept_rows, kept_notes = record or ([], {}, {})
    drawn = {c["board"]["name"]: c for c in record_of(kept_boards, kept_rows, kept_notes)["cases"]}
    drawn = {name: json.dumps(c) for name, c in drawn.items()}  # what each figure was drawn of
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
        studied = leaderboard_boards(out, log=warn) if comm.rank == 0 else []
    else:  # the other cases of the record (the mesh-sensitivity study's), as recorded
        names = {b.name for b in BOARDS}
        for board in kept_boards:
            if board.name not in names:
                boards.append(board)
                rows[board.name], notes[board.name] = kept_rows[board.name], kept_notes[board.name]
    # what is read is read and checked before anything runs (rank 0 reads and writes)
    cases = [b for b in boards if b.name in {x.name for x in BOARDS}]  # the study's: no users
    users, left_out = read_users(out, cases) if comm.rank == 0 else ({}, {})
    interrupt.will_write(  # named on a signal: the old ones stay as they were
        [out / name for name in OWNED] + [out / FOLDER / "*.png", out / FOLDER / "index.html"]
    )
    for board in fresh:
        start = load_average()
        rows[board.name], notes[board.name] = run_board(board, out, args.solver, args.petsc, comm)
        board.load = (start, load_average())
    for board, board_rows in studied:
        mark_pareto(board_rows)  # the mesh-sensitivity study's runs
        study_series(out, board, board_rows)
        board.session, board.machine = session, machine()
        boards.append(board)
        rows[board.name], notes[board.name] = board_rows, []
    if comm.rank == 0:  # against the truth: serial, on rank 0, which writes
        grade_truths(fresh + [b for b, _ in studied], rows)
        graded = {  # users' rows of the record graded against the truth of a case not rerun
            user_key(r): r
            for b in kept_boards
            if b.name not in (rerun or [])
            for r in kept_rows[b.name]
            if r.source == "user"
        }
        grade_users(boards, rows, users, graded, out)

    def write():
        (out / FOLDER).mkdir(parents=True, exist_ok=True)
        record = record_of(boards, rows, notes)
        for board, case in zip(boards, record["cases"], strict=True):
            same = drawn.get(board.name) == json.dumps(case)  # drawn of the same rows
            png = out / FOLDER / f"{board.name}.png"
            if not (same and unchanged(png)):  # else still as drawn: seconds saved per case
                write_owned(png, lambda tmp, board=board: plot_case(tmp, board, rows[board.name]))
            budget = out / FOLDER / f"{board.name}-budget.png"
            if budget_rows(rows[board.name]) and not (same and unchanged(budget)):
                write_owned(
                    budget,
                    lambda tmp, board=board: plot_budget(
                        tmp,
                        f"{board.name}: error budget against the truth {board.truth} (SPEC 10)",
                        rows[board.name],
                        unit_of(board),
                    ),
                )
        every = [r for board in boards for r in rows[board.name]]
        write_owned(out / RECORD, lambda tmp: tmp.write_text(json.dumps(record, indent=1) + "\n"))
        write_owned(out / "leaderboard.csv", lambda tmp: write_csv(tmp, every))
        shown = {b.name: notes.get(b.name, []) + left_out.get(b.name, []) for b in boards}
        frontier = page.read_frontier(out / "frontier" / "frontier.csv")
        text = document.markdown(boards, rows, shown, frontier, session)
        write_owned(out / "leaderboard.md", lambda tmp: tmp.write_text(text))
        index = page.render(boards, rows, shown, frontier, session, unit_of)
        write_owned(out / FOLDER / "index.html", lambda tmp: tmp.write_text(index))

    collective(comm, write, out)
    interrupt.will_write([])  # all written
    if comm.rank == 0:
        what = "rerun " + ", ".join(rerun) if rerun else "from the record"
        print(
            f"wrote {out / 'leaderboard.md'}, {out / 'leaderboard.csv'}, {out / RECORD} and "
            f"{out / FOLDER}/*.png ({what}; {sum(len(v) for v in users.values())} user rows)"
        )
    return 0
