"""`tissuebench sensitivity --out results`: how sensitive each algorithm is to mesh density and
mesh shape (the paper's future work; SPEC 9).

For each case (block MP1 with the needle 0.2 m wide, rod MP3), every algorithm runs on the
grids of sizes N/4, N/2 and N in three shapes (the quadrilateral or hexahedral grid, the same
grid split into simplices, gmsh's unstructured simplices at the same spacing), and is graded
on its own mesh (SPEC 9) against `implicit` on the grid of size 2N. The reference's own
discretisation error is the `implicit` grid run of size N against it: no difference below it
is a finding. Each run is timed in this session: the System's assembly, the integrator's set
up and its time loop, per simulated second.

Writes OUT/mesh-sensitivity.md, OUT/mesh-sensitivity.csv and OUT/mesh-sensitivity-CASE.png;
the runs' series (XDMF, for ParaView) and each mesh's graded rows (JSON) go to
OUT/mesh-sensitivity/CASE/, so that a rerun after an interruption redoes only the meshes it
had not finished. Only E_n and E_i are graded (E_s on another mesh needs a boolean of the two
deformed bodies at every step, and the study is about E_i).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_common
from tissuebench.workflows.io.output import OutputError, check_writable, collective, write_owned
from tissuebench.workflows.leaderboard.mesh_sensitivity import run_study
from tissuebench.workflows.leaderboard.mesh_sensitivity_cases import MARKER, NAME, QUICK, STUDIES
from tissuebench.workflows.leaderboard.mesh_sensitivity_report import markdown, plot, write_csv
from tissuebench.workflows.run.checks import check_common


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sensitivity",
        help=HELP["sensitivity"],
        description=__doc__.split("\n\n")[1] + " " + __doc__.split("\n\n")[2],
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="small grids (block N = 8, rod n = 4) and T = 1 s: checks the workflow; never "
        "replaces the results of a full study",
    )
    add_common(p)
    p.set_defaults(func=main)


def check_target(out: Path, quick: bool, force: bool) -> None:
    """Refuse to replace a report we did not write, and, without force, a full study's
    report by a quick one."""
    md = out / f"{NAME}.md"
    if not md.exists():
        return
    text = md.read_text(errors="replace")
    if not text.startswith(MARKER):
        raise OutputError(f"{md}: exists and was not written by tissuebench sensitivity")
    if quick and not force and "(quick check" not in text.splitlines()[0]:
        raise OutputError(
            f"{md}: holds a full study; a --quick run does not replace it (--force does)"
        )


def main(args: argparse.Namespace) -> int:
    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    check_writable(out, comm, owned=[f"{NAME}.md", f"{NAME}.csv"])
    collective(comm, lambda: check_target(out, args.quick, args.force))
    studies = QUICK if args.quick else STUDIES
    session = comm.bcast(time.strftime("%Y-%m-%d %H:%M %Z"))
    # named on a signal (the old ones stay as they were; the finished meshes are kept)
    interrupt.will_write([out / f"{NAME}.md", out / f"{NAME}.csv", out / f"{NAME}-*.png"])
    results = {
        s.name: run_study(s, out, args.solver, args.petsc, comm, quick=args.quick, session=session)
        for s in studies
    }

    def write():
        for study in studies:
            write_owned(
                out / f"{NAME}-{study.name}.png",
                lambda tmp, study=study: plot(tmp, study, results[study.name]["rows"]),
            )
        every = [r for s in studies for r in results[s.name]["rows"]]
        write_owned(out / f"{NAME}.csv", lambda tmp: write_csv(tmp, every))
        text = markdown(studies, results, args.quick, comm.size)
        write_owned(out / f"{NAME}.md", lambda tmp: tmp.write_text(text))

    collective(comm, write, out)
    interrupt.will_write([])  # all written
    if comm.rank == 0:
        print(f"wrote {out / NAME}.md, {out / NAME}.csv and {out / NAME}-*.png")
    return 0
