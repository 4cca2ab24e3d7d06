"""`tissuebench external SIMULATOR BENCHMARK [options] --out DIR`: pose a benchmark in an
outside simulator, run it, and grade it against our reference (workflows/simulators/runner.py)."""

import argparse
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_common, add_posed_options
from tissuebench.workflows.run.checks import check_common, posed
from tissuebench.workflows.simulators import SIMULATORS
from tissuebench.workflows.simulators.runner import run_external


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "external",
        help=HELP["external"],
        description="Export the benchmark, run our reference (implicit, with the model) and "
        "every variant of SIMULATOR that poses it (or those of --variants), each in DIR/VARIANT/"
        "work, and grade each against the reference as `tissuebench compare` does: "
        "DIR/VARIANT/metrics.csv, metrics.png and summary.json, and DIR/summary.json for all. "
        "Wall times are measured around each simulator's run on this machine.",
    )
    p.add_argument("simulator", help=", ".join(SIMULATORS))
    p.add_argument("benchmark", help=", ".join(BENCHMARKS))
    p.add_argument("--out", required=True, type=Path, help="output folder")
    p.add_argument(
        "--variants",
        help="comma-separated variants (default: every variant that poses the benchmark)",
    )
    add_posed_options(p, BENCHMARKS)
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from tissuebench.core.errors import UserError
    from tissuebench.workflows.simulators import get_simulator

    comm = MPI.COMM_WORLD
    try:
        get_simulator(args.simulator)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    bench = posed(args, BENCHMARKS)
    check_common(args)
    variants = None
    if args.variants is not None:
        variants = list(dict.fromkeys(v.strip() for v in args.variants.split(",") if v.strip()))
    summary = run_external(
        args.simulator,
        args.out,
        benchmark=bench.benchmark,
        mesh_size=bench.mesh_size,
        options=bench.options,
        material=bench.material,
        model=bench.model,
        h=bench.h,
        steps=bench.steps,
        plane=bench.plane,
        variants=variants,
        solver=args.solver,
        petsc=args.petsc,
        force=args.force,
        comm=comm,
    )
    if comm.rank == 0:
        print(
            f"{'run':<34} {'status':<9} {'E_n max':>9} {'E_i mean':>9} {'E_i max':>9} {'wall s':>8}"
        )
        for label, e in summary["runs"].items():
            cells = [
                e.get(k)
                for k in ("relative_error_max", "interior_error_mean", "interior_error_max")
            ]
            text = " ".join(f"{x:9.3g}" if x is not None else f"{'-':>9}" for x in cells)
            wall = f"{e['wall_time_s']:8.2f}" if e.get("wall_time_s") is not None else f"{'-':>8}"
            print(f"{label:<34} {e['status']:<9} {text} {wall}")
        for name, why in (summary.get("skipped_variants") or {}).items():
            print(f"not posed: {args.simulator}:{name}: {why}")
        print(f"wrote {args.out}")
    return 0
