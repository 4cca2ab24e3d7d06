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

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.workflows.commands.arguments import add_common
from tissuebench.workflows.io.output import (
    check_owned,
    check_writable,
    collective,
    write_owned,
)
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.run.case import Case, run_case
from tissuebench.workflows.run.checks import check_common
from tissuebench.workflows.study import report
from tissuebench.workflows.study import truth as paper_truth
from tissuebench.workflows.study.cases import cases, model_cases
from tissuebench.workflows.truth.jobs import TruthJobs

LARGE = report.LARGE_DEFORMATION  # the folder of part 2 in OUT


def explicit_limits(case: Case, comm: MPI.Comm) -> dict:
    """{algorithm: critical step in s} of the explicit schemes with the linear model on the
    case's mesh, material and constraints (SPEC section 3's Newmark analysis, as in
    stability.md): the step above which central differences diverge. Collective."""
    from tissuebench.meshes import get_benchmark, get_entry
    from tissuebench.solvers.stability import explicit_schemes, stability_limits
    from tissuebench.solvers.system import System

    entry = get_entry(case.benchmark)
    size = entry.mesh_size if case.mesh_size is None else case.mesh_size
    bench = get_benchmark(case.benchmark, mesh_size=size, comm=comm, **case.options)
    material = case.runs[0].material
    limits = stability_limits(System(bench, material), list(explicit_schemes()))
    return {name: limit.critical_dt for name, limit in limits.items()}


def select(
    names: list[str] | None, first: list[Case], truth: list[Case], second: list[Case]
) -> tuple[list[Case], list[Case], list[Case]]:
    """Part 1's, the truth's and part 2's cases that --cases names (None: all of them); the
    truth's cases run together (paper_truth grades them as one) when either is named. A name
    of no case, or none of part 1 (the report's claims rest on them), is refused in one line."""
    if names is None:
        return first, truth, second
    known = [c.name for c in first + truth + second]
    unknown = [n for n in names if n not in known]
    if unknown:
        raise UserError(f"--cases {unknown[0]}: no such case; name some of {', '.join(known)}")
    if not any(c.name in names for c in first):
        raise UserError(
            f"--cases: name at least one case of part 1 ({', '.join(c.name for c in first)}): "
            "the report's claims rest on them"
        )
    return (
        [c for c in first if c.name in names],
        truth if any(c.name in names for c in truth) else [],
        [c for c in second if c.name in names],
    )


def add_parser(sub: argparse._SubParsersAction) -> None:
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
    p.add_argument(
        "--jobs",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="processes, one core each, that compute the truths not cached while the cases "
        "run (a linear truth's runs side by side; default: the cores, at most 2; one rank "
        "only)",
    )
    p.add_argument(
        "--cases",
        nargs="+",
        metavar="CASE",
        help="run and report only these cases (default: all of them; the truth's two run "
        "together), at least one of part 1",
    )
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    check_common(args)
    if args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, not {args.jobs}")
    comm = MPI.COMM_WORLD
    out = args.out
    check_writable(out, comm)
    collective(comm, lambda: check_owned(out / "README.md"))
    summaries: dict[str, CaseSummary] = {}
    large: dict[str, CaseSummary] = {}
    limits: dict[str, dict[str, float]] = {}
    first, truth_cases, second = select(
        getattr(args, "cases", None),
        cases(args.solver, args.petsc),
        paper_truth.cases(args.solver, args.petsc),
        model_cases(args.solver, args.petsc),
    )
    parts = [out / c.name for c in first + truth_cases] + [out / LARGE / c.name for c in second]
    interrupt.will_write([*parts, out / "README.md"])  # named on a signal if not written
    uncached = paper_truth.missing(comm) if truth_cases else []
    jobs = args.jobs if comm.size == 1 else 1  # under mpiexec the ranks share each truth
    if uncached and comm.rank == 0:
        print(paper_truth.first_run_line(uncached, jobs), flush=True)
    # the truths not cached: computed side by side in workers while this process runs the
    # cases that need none (a failed one is computed again, and fails again in one line, where
    # paper_truth.compute reads it); on one process, by paper_truth.compute after them
    work = TruthJobs(
        uncached if jobs > 1 else [], False, jobs, lambda line: print(line, flush=True)
    )
    try:
        if work.pending:
            work.start()
        for case in first:
            summaries[case.name] = run_case(case, out / case.name, comm, force=args.force)
            interrupt.written(out / case.name)
            work.poll()
        for case in second:
            large[case.name] = run_case(case, out / LARGE / case.name, comm, force=args.force)
            limits[case.name] = explicit_limits(case, comm)
            interrupt.written(out / LARGE / case.name)
            work.poll()
        work.wait()
    finally:
        work.stop()
    # the paper against the truth (SPEC 10): its runs, graded against the truths
    truth = None
    if truth_cases:
        truth = paper_truth.compute(out, comm, args.solver, args.petsc, force=args.force)
    for case in truth_cases:
        interrupt.written(out / case.name)

    def write():
        text = report.paper_report(out, summaries, large, limits, truth)
        write_owned(out / "README.md", lambda tmp: tmp.write_text(text))

    collective(comm, write, out)
    interrupt.written(out / "README.md")
    if comm.rank == 0:
        print(f"report: {out / 'README.md'}")
    return 0
