"""`tissuebench paper --out results/`: the paper's study (SPEC sections 4, 5 and 7) and its report.

Cases: block-MP1, block-MP2 and rod-MP3 (all five algorithms against implicit on the same
material) and block-MP2-vs-MP1 (the paper's Figure 11: every MP1 run and quasi-static MP2
against implicit MP2). A case whose directory is complete is skipped unless --force.
"""

import json
from pathlib import Path

from mpi4py import MPI

from tissuebench.solvers import ALGORITHMS
from tissuebench.workflows import report
from tissuebench.workflows.output import SUMMARY, is_complete
from tissuebench.workflows.run import add_common, check_common
from tissuebench.workflows.study import Case, algorithm_case, run_case


def cases(solver="direct"):
    names = list(ALGORITHMS)
    vs = [("implicit-MP2", "implicit", "MP2"), *((f"{a}-MP1", a, "MP1") for a in names),
          ("quasi-static-MP2", "quasi-static", "MP2")]
    return [
        algorithm_case("block-MP1", "block", "MP1", names, solver=solver,
                       description="Block and needle, MP1: the five algorithms against implicit MP1 (paper Figs. 5-7)"),
        algorithm_case("block-MP2", "block", "MP2", names, solver=solver,
                       description="Block and needle, MP2 (human prostate): the five algorithms against implicit MP2"),
        algorithm_case("rod-MP3", "rod", "MP3", names, solver=solver,
                       description="Bending rod, MP3: the five algorithms against implicit MP3 (paper Figs. 8-10)"),
        Case("block-MP2-vs-MP1", "block", vs, "implicit-MP2", solver=solver,
             description="Block: every MP1 run and quasi-static MP2 against implicit MP2 (paper Fig. 11)"),
    ]


def add_parser(sub):
    p = sub.add_parser("paper", help="the paper's study, its figures and report",
                       description="Run the paper's study into OUT (default results/) and write OUT/README.md.")
    p.add_argument("--out", type=Path, default=Path("results"), help="output directory (default results)")
    add_common(p)
    p.set_defaults(func=main)


def main(args):
    check_common(args)
    comm = MPI.COMM_WORLD
    out = args.out
    summaries = {}
    for case in cases(args.solver):
        target = out / case.name
        if not args.force and is_complete(target):
            if comm.rank == 0:
                print(f"{target}: complete, skipped (--force reruns)")
        else:
            run_case(case, target, comm)
        summaries[case.name] = json.loads((target / SUMMARY).read_text()) if comm.rank == 0 else None
    if comm.rank == 0:
        (out / "README.md").write_text(report.paper_report(out, summaries))
        print(f"report: {out / 'README.md'}")
    return 0
