"""`tissuebench export BENCHMARK --format json|inp|vtu|msh --out FILE`: a benchmark posed for
another simulator, with our reference's history beside it (workflows/io/exported.py)."""

import argparse
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS, get_entry
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_common, add_posed_options
from tissuebench.workflows.compare.posing import (
    FORMATS,
    PROCEDURES,
    export,
    reference_path,
    step_note,
)
from tissuebench.workflows.io.calculix_deck import ELEMENTS
from tissuebench.workflows.io.exported import SCHEMA, SCHEMA_VERSION, ExportError
from tissuebench.workflows.io.limits import check as check_limits
from tissuebench.workflows.io.limits import estimate
from tissuebench.workflows.leaderboard.boards import is_contact
from tissuebench.workflows.leaderboard.rows import BOARDS, Board, export_options, posed_board
from tissuebench.workflows.run.checks import check_common, posed


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "export",
        help=HELP["export"],
        description="Write a benchmark for another simulator: json (mesh, node sets, the "
        "prescribed motion at every t_i, body force, material, model, h, T; schema "
        f"{SCHEMA} version {SCHEMA_VERSION}, units and regions stated), inp (a CalculiX deck "
        "ready for `ccx -i NAME`), or "
        "the mesh alone (vtu, msh). Beside a json or inp, our reference's displacement history "
        "(NAME.reference.xdmf + .h5: implicit, or quasi-static with --procedure static), so "
        "that `tissuebench compare NAME.reference.xdmf NAME.frd --out DIR` grades the result.",
    )
    p.add_argument("benchmark", help=f"{', '.join(BENCHMARKS)}")
    p.add_argument("--format", choices=FORMATS, help="default: the suffix of --out")
    p.add_argument("--out", required=True, type=Path, help="the file to write (.json, .inp, ...)")
    add_posed_options(p, BENCHMARKS)
    p.add_argument(
        "--procedure",
        choices=list(PROCEDURES),
        default="dynamic",
        help="dynamic (default: *DYNAMIC, against implicit) or static (*STATIC at every t_i, "
        "against quasi-static)",
    )
    p.add_argument(
        "--element",
        help=f"inp only: the CalculiX element, {', '.join(ELEMENTS)} (default C3D8 in 3D, "
        "CPE4 in plane strain, CPS4 in plane stress)",
    )
    p.add_argument(
        "--no-reference",
        action="store_true",
        help="json and inp: do not run and write our reference beside it",
    )
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    comm = MPI.COMM_WORLD
    fmt = args.format or args.out.suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise ExportError(
            f"output {args.out}: cannot tell the format from its suffix; give --format "
            f"{'|'.join(FORMATS)}"
        )
    bench = posed(args, BENCHMARKS)
    entry = get_entry(bench.benchmark)
    steps = bench.steps
    check_common(args)
    reference = not args.no_reference and fmt in ("json", "inp")
    runs = 1 if reference else 0
    check_limits(
        estimate(
            entry.gdim, entry.nodes(bench.mesh_size), steps if reference else 0, runs, comm.size
        ),
        args.out.absolute().parent,
        comm,
    )
    note = step_note(bench.h, bench.end_time, steps)
    if note and comm.rank == 0:
        print(note)
    written = export(
        args.benchmark,
        fmt,
        args.out,
        mesh_size=bench.mesh_size,
        options=bench.options,
        material=bench.material,
        model=bench.model,
        h=bench.h,
        steps=steps,
        plane=bench.plane,
        procedure=args.procedure,
        element=args.element,
        reference=reference,
        solver=args.solver,
        force=args.force,
        comm=comm,
    )
    if comm.rank == 0:
        print(f"wrote {', '.join(str(p) for p in written)}")
        board = posed_board(
            bench.benchmark,
            bench.material,
            bench.model,
            bench.options,
            bench.mesh_size,
            bench.h,
            steps,
            bench.plane,
        )
        if args.procedure != "dynamic":  # the leaderboard's references are dynamic (implicit)
            board = None
            print(
                "leaderboard case: none (a static export is graded against quasi-static; the "
                "leaderboard's cases are dynamic: --procedure dynamic)"
            )
        else:
            print(case_line(board))
        if reference:
            print(next_line(board, args.out, fmt))
    return 0


def case_line(board: Board | None) -> str:
    """One line: the leaderboard case an export poses and its truth, or that it poses none
    and the options of each case."""
    from tissuebench.solvers.truth.store import cache_path, expected_words

    if board is None:
        cases = "; ".join(f"{b.name}: export {export_options(b)}" for b in BOARDS)
        return (
            "leaderboard case: none (these options pose none of its cases; a run of them is "
            f"graded by compare alone). The cases: {cases}"
        )
    from tissuebench.solvers.truth.fallbacks import fallbacks_of

    truth = "it has no truth (a point needle)"
    if board.truth and fallbacks_of(board.truth):  # its levels do not converge
        truth = (
            f"its truth case {board.truth} has levels that do not converge (`tissuebench truth` "
            "says why): the leaderboard grades a run against our implicit on your mesh only"
        )
    elif board.truth and cache_path(board.truth).is_file():
        truth = f"its truth {board.truth} is cached here, and the leaderboard grades against it"
    elif board.truth:
        truth = (
            f"its truth {board.truth} is computed once by `tissuebench truth {board.truth}` "
            f"({expected_words(board.truth)} on one core) before the leaderboard grades against it"
        )
    return f"leaderboard case: {board.name}; {truth}"


def next_line(board: Board | None, out: Path, fmt: str) -> str:
    """One line: the commands that grade a run of the export (and rank it, for a case)."""
    from tissuebench.workflows.leaderboard.record import clone_results

    job = out.absolute().with_suffix("")  # absolute: the lines run from any folder
    run = f"ccx -i {job}; " if fmt == "inp" else "run your simulator; "
    series = f"{job}.frd" if fmt == "inp" else "YOUR_SERIES"
    grade = f"tissuebench compare {reference_path(out.absolute())} {series}"
    if board is not None and is_contact(board):  # SPEC 12: the force, if you have it
        series += " [--needle-force YOUR_FORCE.csv]"
        grade = f"tissuebench compare {reference_path(out.absolute())} {series}"
    if board is None:
        return f"next: {run}{grade} --out {job.name}-graded"
    clone = clone_results()
    record = (
        f"the leaderboard renders the record of {clone} with your row into it"
        if clone is not None
        else "the leaderboard renders a clone's record, named with --results DIR, into it"
    )
    return (
        f"next: {run}{grade} --out results/leaderboard/{board.name}/user/NAME --label NAME "
        "--wall-time SECONDS; tissuebench leaderboard --out results (these two in the same "
        f"folder, any: its results/ is yours, and {record})"
    )
