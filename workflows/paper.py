"""`tissuebench paper --out results/`: the paper's study (SPEC sections 4, 5 and 7) and its report.

Cases: block-MP1, block-MP2 and rod-MP3 (all five algorithms against implicit on the same
material) and block-MP2-vs-MP1 (the paper's Figure 11: every MP1 run and quasi-static MP2
against implicit MP2); then block-MP1-40s and rod-MP3-30s, the same runs as block-MP1 and
rod-MP3 taken on to 40 s and 30 s, on which the report checks claims 3 (every scheme settles
on the quasi-static solution) and 6 (the rod oscillates about its static shape). A case whose
directory is complete is skipped unless --force.
"""

import os
from pathlib import Path

from mpi4py import MPI

from tissuebench.solvers import ALGORITHMS
from tissuebench.workflows import report
from tissuebench.workflows.output import OutputError, check_writable, collective
from tissuebench.workflows.arguments import add_common, check_common
from tissuebench.workflows.study import Case, algorithm_case, run_case


def cases(solver: str = "direct", petsc: str = "") -> list[Case]:
    names = list(ALGORITHMS)
    vs = [
        ("implicit-MP2", "implicit", "MP2"),
        *((f"{a}-MP1", a, "MP1") for a in names),
        ("quasi-static-MP2", "quasi-static", "MP2"),
    ]
    return [
        algorithm_case(
            "block-MP1",
            "block",
            "MP1",
            names,
            solver=solver,
            petsc=petsc,
            description="Block and needle, MP1: the five algorithms against implicit MP1 (paper Figs. 5-7)",
        ),
        algorithm_case(
            "block-MP2",
            "block",
            "MP2",
            names,
            solver=solver,
            petsc=petsc,
            description="Block and needle, MP2 (human prostate): the five algorithms against implicit MP2",
        ),
        algorithm_case(
            "rod-MP3",
            "rod",
            "MP3",
            names,
            solver=solver,
            petsc=petsc,
            description="Bending rod, MP3: the five algorithms against implicit MP3 (paper Figs. 8-10)",
        ),
        Case(
            "block-MP2-vs-MP1",
            "block",
            vs,
            "implicit-MP2",
            solver=solver,
            petsc=petsc,
            description="Block: every MP1 run and quasi-static MP2 against implicit MP2 (paper Fig. 11)",
        ),
        # Beyond the paper's 10 s, on the same meshes: the checks of claims 3 and 6 (SPEC section 7)
        algorithm_case(
            "block-MP1-40s",
            "block",
            "MP1",
            names,
            end_time=40.0,
            solver=solver,
            petsc=petsc,
            description="Block and needle, MP1, as block-MP1 but run to 40 s: do all schemes settle "
            "on the quasi-static solution? (claim 3)",
        ),
        # the reference and its static deflection only: the rod's surface error costs ~10 ms a step
        algorithm_case(
            "rod-MP3-30s",
            "rod",
            "MP3",
            ["quasi-static"],
            end_time=30.0,
            solver=solver,
            petsc=petsc,
            description="Bending rod, MP3, implicit and quasi-static as in rod-MP3 but run to 30 s: "
            "the oscillation about the static shape (claim 6)",
        ),
    ]


def add_parser(sub):
    p = sub.add_parser(
        "paper",
        help="the paper's study, its figures and report",
        description="Run the paper's study into OUT (default results/) and write OUT/README.md.",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path("results"),
        help="output folder (default results): one case folder each, and README.md",
    )
    add_common(p)
    p.set_defaults(func=main)


def check_report(path: Path) -> None:
    """Refuse to replace a README.md that the paper's report did not write."""
    if path.exists() and (
        not path.is_file() or not path.read_text(errors="replace").startswith(report.MARKER)
    ):
        raise OutputError(
            f"{path}: exists and was not written by tissuebench paper; move it or choose another --out"
        )


def main(args):
    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    check_writable(out, comm)
    collective(comm, lambda: check_report(out / "README.md"))
    summaries = {}
    for case in cases(args.solver, args.petsc):
        summaries[case.name] = run_case(case, out / case.name, comm, force=args.force)

    def write():
        check_report(out / "README.md")
        tmp = out / f".README.md.{os.getpid()}.tmp"
        try:
            tmp.write_text(report.paper_report(out, summaries))
            os.replace(tmp, out / "README.md")
        finally:
            tmp.unlink(missing_ok=True)

    collective(comm, write, out)
    if comm.rank == 0:
        print(f"report: {out / 'README.md'}")
    return 0
