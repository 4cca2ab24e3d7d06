"""The paper's study run (`tissuebench paper`, workflows/commands/paper.py parses its options):
part 1's cases, the paper against the truth and part 2's, the truths not cached computed in
worker processes beside the cases that need none, then the report (OUT/README.md).

The cases are workflows/study/cases.py's (with those a benchmark defined elsewhere registered
there); `names` runs and reports only those named (select).
"""

from __future__ import annotations

import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.workflows.io.output import check_owned, check_writable, collective, write_owned
from tissuebench.workflows.io.summary import CaseSummary, read_case_summary
from tissuebench.workflows.run.case import Case, run_case
from tissuebench.workflows.study import report
from tissuebench.workflows.study import truth as paper_truth
from tissuebench.workflows.study.beside import CasesWorker, claim
from tissuebench.workflows.study.cases import cases, model_cases
from tissuebench.workflows.truth.jobs import TruthJobs

LARGE = report.LARGE_DEFORMATION  # the folder of part 2 in OUT
POLL_SECONDS = 0.5  # s, between looks at the truths' workers


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


def run_paper(
    out: Path,
    solver: str = "direct",
    petsc: str = "",
    force: bool = False,
    jobs: int = 1,
    names: list[str] | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    folders_only: bool = False,
    claims: Path | None = None,
) -> None:
    """Run the paper's cases (those of `names`, else all) into `out` and write out/README.md;
    the truths not cached computed `jobs` processes at a time beside the cases (one rank).
    With every truth cached and jobs > 1, part 2's cases are shared with a second process
    beside this one (workflows/study/beside.py). `folders_only`: that process's part, the
    named cases of part 2 that it claims first in `claims`, into their folders; no report."""
    check_writable(out, comm)
    if folders_only:  # the second process's part (beside.py)
        if claims is None:
            raise UserError("--folders-only needs --claims")
        # a case it does not know (registered by the paper's caller alone) is left to the paper
        known = {c.name: c for c in model_cases(solver, petsc)}
        for name in [n for n in names or [] if n in known]:
            if claim(claims, name):
                run_case(known[name], out / LARGE / name, comm, force=force)
                interrupt.written(out / LARGE / name)
        return
    collective(comm, lambda: check_owned(out / "README.md"))
    summaries: dict[str, CaseSummary] = {}
    large: dict[str, CaseSummary] = {}
    limits: dict[str, dict[str, float]] = {}
    first, truth_cases, second = select(
        names,
        cases(solver, petsc),
        paper_truth.cases(solver, petsc),
        model_cases(solver, petsc),
    )
    parts = [out / c.name for c in first + truth_cases] + [out / LARGE / c.name for c in second]
    interrupt.will_write([*parts, out / "README.md"])  # named on a signal if not written
    uncached = paper_truth.missing(comm) if truth_cases else []
    jobs = jobs if comm.size == 1 else 1  # under mpiexec the ranks share each truth
    if uncached and comm.rank == 0:
        print(paper_truth.first_run_line(uncached, jobs), flush=True)
    # the truths not cached: computed side by side in workers while this process runs the
    # cases (a failed one is computed again, and fails again in one line, where
    # paper_truth.grade reads it); on one process, by paper_truth.grade after the cases
    work = TruthJobs(
        uncached if jobs > 1 else [],
        False,
        jobs,
        lambda line: print(line, flush=True),
        beside=paper_truth.BESIDE,
    )
    # the paper against the truth (SPEC 10): its runs, then each graded against its truth as
    # soon as that is cached (beside the workers of the others), the rest after them
    graded: dict[str, tuple] = {}  # truth: paper_truth.grade()'s pair
    # every truth cached: part 2 shared with a second process beside this one (beside.py),
    # which takes its cases from the first on, this one (after part 1 and the truth's) from
    # the last on
    side = None
    if jobs > 1 and comm.size == 1 and not work.pending and second:
        say = lambda line: print(line, flush=True)  # noqa: E731
        side = CasesWorker(out, [c.name for c in second], solver, petsc, force, say)
    try:
        if work.pending:
            work.start()
        for case in first:
            summaries[case.name] = run_case(case, out / case.name, comm, force=force)
            interrupt.written(out / case.name)
            work.poll()
        truth = None
        if side is not None:
            if truth_cases:  # graded here while part 2 runs beside
                folders = paper_truth.run_folders(out, comm, solver, petsc, force=force)
                truth = paper_truth.finish(folders, graded, comm)
            for case in reversed(second):
                if claim(side.claims, case.name):
                    large[case.name] = run_case(case, out / LARGE / case.name, comm, force=force)
            if side.wait():  # the worker's folders, as it wrote them (those it left: run below)
                for case in [c for c in second if c.name not in large]:
                    done = read_case_summary(out / LARGE / case.name)
                    if done is not None:
                        large[case.name] = done
        for case in second:
            if case.name not in large:
                large[case.name] = run_case(case, out / LARGE / case.name, comm, force=force)
            limits[case.name] = explicit_limits(case, comm)
            interrupt.written(out / LARGE / case.name)
            work.poll()
        folders = {}
        if truth_cases and truth is None:
            folders = paper_truth.run_folders(out, comm, solver, petsc, force=force)
        while work.poll():
            for name in [n for n in work.succeeded if n not in graded]:
                graded[name] = paper_truth.grade(name, folders, comm)
            time.sleep(POLL_SECONDS)
            interrupt.checkpoint(MPI.COMM_SELF)
    finally:
        work.stop()
        if side is not None:
            side.stop()
    large = {case.name: large[case.name] for case in second}  # the report's order
    # the others graded now (a failed worker's truth computed here), all in the section's order
    if truth_cases and truth is None:
        truth = paper_truth.finish(folders, graded, comm)
    for case in truth_cases:
        interrupt.written(out / case.name)

    def write():
        text = report.paper_report(out, summaries, large, limits, truth)
        write_owned(out / "README.md", lambda tmp: tmp.write_text(text))

    collective(comm, write, out)
    interrupt.written(out / "README.md")
    if comm.rank == 0:
        print(f"report: {out / 'README.md'}")
