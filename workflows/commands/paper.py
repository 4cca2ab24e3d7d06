"""`tissuebench paper --out results/`: the paper's study (SPEC sections 4, 5 and 7) and its report.

Cases: block-MP1, block-MP2 and rod-MP3 (all five algorithms against implicit on the same
material) and block-MP2-vs-MP1 (the paper's Figure 11: every MP1 run and quasi-static MP2
against implicit MP2); then block-MP1-40s and rod-MP3-30s, the same runs as block-MP1 and
rod-MP3 taken on to 40 s and 30 s, on which the report checks claims 3 (every scheme settles
on the quasi-static solution) and 6 (the rod oscillates about its static shape). A case whose
directory is complete is skipped unless --force.

The paper against the truth (SPEC section 10, workflows/paper_truth.py): truth-rod-MP3 and
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
"""

import argparse
import os
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.meshes import get_entry
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.models import REFERENCE_MODEL, run_label
from tissuebench.workflows import paper_truth
from tissuebench.workflows.checks import check_common
from tissuebench.workflows.commands.arguments import add_common
from tissuebench.workflows.output import (
    check_owned,
    check_writable,
    collective,
    write_owned,
)
from tissuebench.workflows.reports import paper as report
from tissuebench.workflows.study import Case, algorithm_case, model_case, run_case
from tissuebench.workflows.summary import CaseSummary
from tissuebench.workflows.truth_jobs import TruthJobs

LARGE = report.LARGE_DEFORMATION  # the folder of part 2 in OUT


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
            description=(
                "Block and needle, MP1: the five algorithms against implicit MP1 (paper Figs. 5-7)"
            ),
        ),
        algorithm_case(
            "block-MP2",
            "block",
            "MP2",
            names,
            solver=solver,
            petsc=petsc,
            description=(
                "Block and needle, MP2 (human prostate): the five algorithms against implicit MP2"
            ),
        ),
        algorithm_case(
            "rod-MP3",
            "rod",
            "MP3",
            names,
            solver=solver,
            petsc=petsc,
            description=(
                "Bending rod, MP3: the five algorithms against implicit MP3 (paper Figs. 8-10)"
            ),
        ),
        Case(
            "block-MP2-vs-MP1",
            "block",
            vs,
            "implicit-MP2",
            solver=solver,
            petsc=petsc,
            description=(
                "Block: every MP1 run and quasi-static MP2 against implicit MP2 (paper Fig. 11)"
            ),
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
            description=(
                "Block and needle, MP1, as block-MP1 but run to 40 s: do all schemes settle on "
                "the quasi-static solution? (claim 3)"
            ),
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
            description=(
                "Bending rod, MP3, implicit and quasi-static as in rod-MP3 but run to 30 s: the "
                "oscillation about the static shape (claim 6)"
            ),
        ),
    ]


# SPEC section 8's named cases: (name, benchmark, material, load scale s, needle width w,
# the reference's model: neo-hookean at the paper's loads, neo-hookean-barrier at large ones)
LARGE_CASES = [
    ("block-MP1-s1", "block", "MP1", 1.0, 0.0, REFERENCE_MODEL),
    ("block-MP1-s2-w0.2", "block", "MP1", 2.0, 0.2, "neo-hookean-barrier"),
    ("rod-MP3-s1", "rod", "MP3", 1.0, None, REFERENCE_MODEL),
    ("rod-MP3-s3", "rod", "MP3", 3.0, None, "neo-hookean-barrier"),
]


def model_cases(solver: str = "direct", petsc: str = "") -> list[Case]:
    """Part 2 (SPEC section 8): the five algorithms times every model on each named case,
    against implicit with the case's reference model (SPEC 8's table)."""
    result = []
    for name, benchmark, material, scale, width, model in LARGE_CASES:
        reference = run_label("implicit", model)
        options = {"load_scale": scale}
        load = f"s = {scale:g}"
        if width is not None:
            options["needle_width"] = width
            load += f", needle width w = {width:g} m" if width else ", point needle (w = 0)"
        what = get_entry(benchmark).title
        result.append(
            model_case(
                name,
                benchmark,
                material,
                list(ALGORITHMS),
                list(MODELS),
                reference,
                options=options,
                solver=solver,
                petsc=petsc,
                description=f"{what}, {material}, load scale {load}: the five algorithms with the "
                f"{len(MODELS)} elastic models against {reference} (SPEC section 8)",
            )
        )
    return result


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
    first, second = cases(args.solver, args.petsc), model_cases(args.solver, args.petsc)
    truth_cases = paper_truth.cases(args.solver, args.petsc)
    parts = [out / c.name for c in first + truth_cases] + [out / LARGE / c.name for c in second]
    interrupt.will_write([*parts, out / "README.md"])  # named on a signal if not written
    uncached = paper_truth.missing(comm)
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
