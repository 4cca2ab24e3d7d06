"""`tissuebench run BENCHMARK --out DIR`: one benchmark, the chosen algorithms with the chosen
elastic models (SPEC section 8), one material."""

import argparse
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS, get_entry
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.models import LINEAR
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import (
    add_benchmark_options,
    add_common,
    add_scheme_options,
    scheme_options,
)
from tissuebench.workflows.run.case import model_case, run_case
from tissuebench.workflows.run.checks import (
    benchmark_options,
    check_common,
    check_models_plane,
    parse_algorithms,
    parse_models,
    positive,
)
from tissuebench.workflows.run.phases import phase_lines
from tissuebench.workflows.truth.run import truth_lines


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "run",
        help=HELP["run"],
        description=(
            "Run one benchmark and write XDMF series, metrics.csv, summary.json and figures to "
            "DIR; say the wall time of each phase (also in summary.json)."
        ),
    )
    p.add_argument("benchmark", help=f"{', '.join(BENCHMARKS)}")
    p.add_argument(
        "--out",
        required=True,
        type=Path,
        help="output folder: new, empty, or one that tissuebench wrote",
    )
    p.add_argument("--material", help="MP1, MP2, MP3 or a .toml file (default: the benchmark's)")
    p.add_argument("--dt", type=str, help="time step h in s (default 1/30)")
    p.add_argument("--end-time", type=str, help="end time T in s (default 10)")
    p.add_argument(
        "--algorithms",
        default=",".join(ALGORITHMS),
        help="comma-separated, default all five; implicit (the reference) always runs",
    )
    p.add_argument(
        "--models",
        default=LINEAR,
        help=f"comma-separated elastic models: {', '.join(MODELS)} (default linear); "
        "every algorithm runs with every model",
    )
    p.add_argument(
        "--reference",
        help="the run the others are measured against, ALGORITHM or ALGORITHM+MODEL "
        "(default implicit with the first of linear, neo-hookean and neo-hookean-barrier "
        "among the models; implicit+neo-hookean when none is)",
    )
    add_benchmark_options(p, BENCHMARKS)
    p.add_argument(
        "--plane",
        choices=["strain", "stress"],
        help="2D benchmarks only: plane strain (default) or stress",
    )
    p.add_argument(
        "--no-figures",
        action="store_true",
        help="draw no figures (PNG, GIF); everything else is written as with them",
    )
    add_scheme_options(p)
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    entry = get_entry(args.benchmark)
    options = benchmark_options(args, args.benchmark, BENCHMARKS)
    algorithms = parse_algorithms(args.algorithms)
    models = parse_models(args.models)
    check_models_plane(models, args.plane, entry.gdim)
    scheme, substeps = scheme_options(args, entry.gdim, options, models, algorithms)
    dt = positive(args.dt) if args.dt is not None else None
    end_time = positive(args.end_time) if args.end_time is not None else None
    material = get_material(args.material or entry.material)
    check_common(args)
    case = model_case(
        args.out.name or "run",
        args.benchmark,
        material,
        algorithms,
        models,
        args.reference,
        mesh_size=args.mesh_size,
        dt=dt,
        end_time=end_time,
        options=options,
        plane=args.plane or "strain",
        solver=args.solver,
        petsc=args.petsc,
        scheme=scheme,
        substeps=substeps,
    )
    summary = run_case(case, args.out, force=args.force, figures=not args.no_figures)
    rank0 = MPI.COMM_WORLD.rank == 0
    if rank0 and not summary.skipped and summary.phases_s is not None:
        for line in phase_lines(case.name, summary.phases_s):  # where the wait went
            print(line)
    start = time.perf_counter()
    for line in truth_lines(summary, args.out, material):  # SPEC 10: the error against the physics
        print(line)
    if rank0:
        print(f"{case.name}: {'against the truth':<18} {time.perf_counter() - start:7.2f} s")
    if rank0 and not summary.skipped:
        print(f"results in {args.out}")
    return 0
