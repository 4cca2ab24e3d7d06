"""`tissuebench leaderboard --out results`: every algorithm and model of ours and every
outside simulator that poses each case, graded against one reference and timed in one
session: OUT/leaderboard.md, OUT/leaderboard.csv and a figure per case (workflows/ranking.py).
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

from mpi4py import MPI

from tissuebench.solvers import ALGORITHMS, MODELS, interrupt
from tissuebench.solvers.external import get_simulator
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.models import run_label
from tissuebench.workflows.arguments import add_common, check_common
from tissuebench.workflows.output import OutputError, check_writable, collective, write_owned
from tissuebench.workflows.ranking import (
    Board,
    Row,
    external_rows,
    mark_pareto,
    markdown,
    our_rows,
    plot_case,
    user_rows,
    write_csv,
)
from tissuebench.workflows.sensitivity import leaderboard_boards
from tissuebench.workflows.simulators import SimulatorError, run_external
from tissuebench.workflows.study import model_case, run_case

FOLDER = "leaderboard"
MARKER = "# Leaderboard: accuracy against cost"

# The cases: the paper's block and rod (linear), and SPEC 8's rod at three times its load
# (neo-Hookean reference, every model of ours), at each benchmark's default mesh, h and T.
BOARDS = [
    Board(
        "block-MP1",
        "block",
        "MP1",
        "linear",
        description="Block and needle (SPEC 4), MP1, 20 x 20 quadrilaterals, plane strain, "
        "h = 1/30 s, T = 10 s, linear model.",
    ),
    Board(
        "rod-MP3",
        "rod",
        "MP3",
        "linear",
        description="Bending rod (SPEC 5), MP3, 6 x 3 x 3 hexahedra, h = 1/30 s, T = 10 s, "
        "linear model.",
    ),
    Board(
        "rod-MP3-s3",
        "rod",
        "MP3",
        "neo-hookean",
        models=tuple(MODELS),
        options={"load_scale": 3.0},
        description="Bending rod, MP3, load scale s = 3 (SPEC 8): large deformation, against "
        "implicit+neo-hookean; ours with every model, the simulators with the neo-Hookean one.",
    ),
]


def add_parser(sub):
    p = sub.add_parser(
        "leaderboard",
        help="accuracy against cost of our algorithms and outside simulators, one session",
        description="Run every algorithm and model of ours and every variant of every outside "
        "simulator installed here that poses the case (CalculiX, SfePy, Newton) on each "
        "leaderboard case, grade each against the case's reference, and write "
        "OUT/leaderboard.md, OUT/leaderboard.csv and OUT/leaderboard/CASE.png. Runs that a "
        "user graded with `tissuebench compare --label NAME --wall-time S --out "
        "OUT/leaderboard/CASE/user/NAME` join their case. Everything is rerun and timed in "
        "this session.",
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    add_common(p)
    p.set_defaults(func=main)


def check_target(out: Path, available: set[str], force: bool) -> None:
    """Refuse to replace a leaderboard.md we did not write, or, without force, one with rows of
    a simulator that is not installed here (a partial run never replaces a full one)."""
    md = out / "leaderboard.md"
    if md.exists() and not md.read_text(errors="replace").startswith(MARKER):
        raise OutputError(f"{md}: exists and was not written by tissuebench leaderboard")
    old = out / "leaderboard.csv"
    if force or not old.is_file():
        return
    with open(old, newline="", errors="replace") as f:
        try:  # a simulator's rows only: a user's label or ours never names a simulator
            labels = [
                row.get("label") or ""
                for row in csv.DictReader(f)
                if row.get("source") not in ("user", "tissuebench")
            ]
        except csv.Error:
            labels = []  # not a leaderboard's table: nothing in it to keep
    lost = sorted({lab.split(":")[0] for lab in labels if ":" in lab} - available)
    if lost:
        raise OutputError(
            f"{old}: has rows of {', '.join(lost)}, which cannot run here; install it "
            "(make external-tools) or pass --force to replace the leaderboard without them"
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
    if board.models == ("linear",):
        rows += simplex_rows(board, case, folder, summary, comm, log)
    notes = []
    for name in board.simulators:
        missing = comm.bcast(get_simulator(name).available() if comm.rank == 0 else None, root=0)
        if missing:
            notes.append(f"{name}: not run on this machine ({missing})")
            continue
        try:
            result = run_external(
                name,
                folder / name,
                benchmark=board.benchmark,
                mesh_size=int(summary["mesh_size"]),
                options=board.options,
                material=get_material(board.material),
                model=board.model,
                h=float(summary["h"]),
                steps=int(summary["steps"]),
                solver=solver,
                petsc=petsc,
                force=True,
                comm=comm,
                log=log,
            )
        except SimulatorError as exc:
            notes.append(str(exc))
            continue
        rows += external_rows(board.name, result)
        for variant, why in (result.get("skipped_variants") or {}).items():
            notes.append(f"{name}:{variant} not posed: {why}")
    rows += users or []
    mark_pareto(rows)
    return rows, notes


def simplex_rows(board: Board, case, folder: Path, summary: dict, comm, log=print) -> list[Row]:
    """Our algorithms on the board's mesh size in simplices (the grid split, and gmsh's
    unstructured mesh: SPEC 9), each graded on its own mesh against the board's reference."""
    from dataclasses import replace

    from tissuebench.meshes import get_entry
    from tissuebench.metrics.compare import grade, summarize
    from tissuebench.workflows.sensitivity import shapes

    reference = folder / "ours" / f"{summary['reference']}.xdmf"
    gdim = get_entry(board.benchmark).gdim
    rows = []
    for shape, options in list(shapes(gdim).items())[1:]:
        name = shape.replace(" ", "-")
        sub = replace(case, name=f"{board.name}-{name}", options={**board.options, **options})
        on_shape = run_case(sub, folder / f"ours-{name}", comm, log, force=True)
        for row in our_rows(board.name, on_shape):
            graded = grade(reference, folder / f"ours-{name}" / f"{row.label}.xdmf", comm=comm)
            for metric, curve in graded.curves.items():
                row.errors[f"{metric}_max"], row.errors[f"{metric}_mean"] = summarize(curve)
            row.label = f"{row.label} ({shape})"
            row.mesh = f"{shape}: {on_shape['num_dofs'] // gdim} nodes"
            row.reference = False
            row.group = "tissuebench on simplices"
            rows.append(row)
    return rows


def read_users(out: Path, boards: list[Board]) -> tuple[dict, dict]:
    """Every user's compare folder of every case (OUT/leaderboard/CASE/user/NAME), read and
    checked (ranking.user_rows): ({case: [Row]}, {case: [one line per folder or run left
    out]}); each line left out is also printed on stderr. Rank 0."""
    rows, skipped = {}, {}
    for board in boards:
        rows[board.name], skipped[board.name] = user_rows(board, out / FOLDER / board.name / "user")
        for line in skipped[board.name]:
            warn(line)
    return rows, skipped


def warn(line: str) -> None:
    """One line on stderr: something read was left out, and why."""
    print(f"tissuebench leaderboard: {line}", file=sys.stderr)


def main(args) -> int:
    import time

    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    check_writable(out, comm, owned=["leaderboard.md", "leaderboard.csv"])
    available = set()
    for board in BOARDS:
        for name in board.simulators:
            if comm.rank == 0 and get_simulator(name).available() is None:
                available.add(name)
    collective(comm, lambda: check_target(out, available, args.force))
    session = time.strftime("%Y-%m-%d %H:%M %Z")
    # what is read is read and checked before anything runs (rank 0 reads and writes)
    users, left_out = read_users(out, BOARDS) if comm.rank == 0 else ({}, {})
    studied = leaderboard_boards(out, log=warn) if comm.rank == 0 else []
    rows, notes = {}, {}
    interrupt.will_write(  # named on a signal: the old ones stay as they were
        [out / "leaderboard.md", out / "leaderboard.csv", out / FOLDER / "*.png"]
    )
    for board in BOARDS:
        rows[board.name], notes[board.name] = run_board(
            board, out, args.solver, args.petsc, comm, users=users.get(board.name)
        )
        notes[board.name] += left_out.get(board.name, [])
    boards = list(BOARDS)
    for board, board_rows in studied:
        mark_pareto(board_rows)  # the mesh-sensitivity study's runs
        boards.append(board)
        rows[board.name], notes[board.name] = board_rows, []

    def write():
        (out / FOLDER).mkdir(parents=True, exist_ok=True)
        for board in boards:
            write_owned(
                out / FOLDER / f"{board.name}.png",
                lambda tmp, board=board: plot_case(tmp, board, rows[board.name]),
            )
        every = [r for board in boards for r in rows[board.name]]
        write_owned(out / "leaderboard.csv", lambda tmp: write_csv(tmp, every))
        text = markdown(boards, rows, notes, session)
        write_owned(out / "leaderboard.md", lambda tmp: tmp.write_text(text))

    collective(comm, write, out)
    interrupt.will_write([])  # all written
    if comm.rank == 0:
        print(f"wrote {out / 'leaderboard.md'}, {out / 'leaderboard.csv'} and {out / FOLDER}/*.png")
    return 0
