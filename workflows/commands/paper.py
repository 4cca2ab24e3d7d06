"""`tissuebench paper --out results/`: the paper's study (SPEC sections 4, 5 and 7) and its report.

Cases: block-MP1, block-MP2 and rod-MP3 (all five algorithms against implicit on the same
material) and block-MP2-vs-MP1 (the paper's Figure 11: every MP1 run and quasi-static MP2
against implicit MP2); then block-MP1-40s and rod-MP3-30s, the same runs as block-MP1 and
rod-MP3 taken on to 40 s and 30 s, on which the report checks claims 3 (every scheme settles
on the quasi-static solution) and 6 (the rod oscillates about its static shape). A case whose
directory is complete is skipped unless --force.

The paper against the truth (SPEC section 10, workflows/study/truth.py): truth-rod-MP3 and
truth-block-w0.2 (N = 20, needle width w = 0.2 m), each run graded against the truth of its
case; a truth not cached on this machine is computed there once and cached (a first run: said
with its estimate before it starts; with --jobs > 1, in worker processes, a linear case's runs
side by side, --jobs processes at a time, while this process runs the cases that need no truth:
about 7 min for the three on two cores).

Part 2, beyond the paper (SPEC section 8): the four large-deformation cases, every algorithm
with every elastic model against implicit with the case's reference model (SPEC 8:
neo-hookean at the paper's loads, neo-hookean-barrier at the large ones), in
OUT/large-deformation/: the block
(MP1) at the paper's load (s = 1, the point needle) and at s = 2 with a 0.2 m needle, the rod
(MP3) at s = 1 and s = 3. The report also gives the linear critical step of the explicit
schemes on each of their meshes (solvers/stability.py), which says why explicit runs diverge.

The cases are workflows/study/cases.py's (with those a benchmark defined elsewhere registered
there); `--cases NAME ...` runs and reports only those named.
"""

import argparse
import os
from pathlib import Path

from tissuebench.core.errors import UserError
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_common
from tissuebench.workflows.run.checks import check_common
from tissuebench.workflows.study.paper import run_paper


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "paper",
        help=HELP["paper"],
        description="Run the paper's study into OUT (default results/) and write OUT/README.md.",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=Path("results"),
        help="output folder (default results): one case folder each, and README.md",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="processes, one core each, that compute the truths not cached while the cases "
        "run (a linear truth's runs side by side), or, with every truth cached, that run part "
        "2's cases beside part 1's (default: the cores, at most 2; one rank only)",
    )
    p.add_argument(
        "--cases",
        nargs="+",
        metavar="CASE",
        help="run and report only these cases (default: all of them; the truth's two run "
        "together), at least one of part 1",
    )
    # the second process of a warm paper (workflows/study/beside.py)
    p.add_argument("--folders-only", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--claims", type=Path, help=argparse.SUPPRESS)
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    check_common(args)
    if args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, not {args.jobs}")
    run_paper(
        args.out,
        args.solver,
        args.petsc,
        force=args.force,
        jobs=args.jobs,
        names=getattr(args, "cases", None),
        folders_only=getattr(args, "folders_only", False),
        claims=getattr(args, "claims", None),
    )
    return 0
