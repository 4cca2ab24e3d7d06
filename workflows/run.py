"""`tissuebench run {block,rod} --out DIR`: one benchmark, the chosen algorithms, one material."""

import json
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS
from tissuebench.solvers import ALGORITHMS
from tissuebench.solvers.linear import SOLVERS, set_petsc_options
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.cli import UsageError
from tissuebench.workflows.output import SUMMARY, check_writable, is_complete
from tissuebench.workflows.study import algorithm_case, run_case


def positive(text):
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise UsageError(f"expected a positive number of seconds, got {text!r}")
    return value


def add_common(p):
    p.add_argument("--solver", default="direct", help=f"linear solver: {', '.join(SOLVERS)} (default direct)")
    p.add_argument("--petsc", default="", metavar="OPTIONS",
                   help='PETSc options, prefixed per integrator, e.g. "-implicit_ksp_type cg -implicit_pc_type gamg"')
    p.add_argument("--force", action="store_true", help="rerun even if complete results exist")


def add_parser(sub):
    p = sub.add_parser("run", help="run one benchmark with the chosen algorithms",
                       description="Run one benchmark and write XDMF series, metrics.csv, summary.json and figures to DIR.")
    p.add_argument("benchmark", help=f"{' or '.join(BENCHMARKS)}")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--material", help="MP1, MP2, MP3 or a .toml file (default: the benchmark's)")
    p.add_argument("--mesh-size", type=int, help="block: N (even, default 20); rod: n (default 3)")
    p.add_argument("--dt", type=str, help="time step h in s (default 1/30)")
    p.add_argument("--end-time", type=str, help="end time T in s (default 10)")
    p.add_argument("--algorithms", default=",".join(ALGORITHMS),
                   help="comma-separated, default all five; implicit (the reference) always runs")
    p.add_argument("--needle-width", type=float, default=0.0, help="block needle tip width w in m (default 0)")
    p.add_argument("--plane", choices=["strain", "stress"], default="strain", help="2D assumption (default strain)")
    add_common(p)
    p.set_defaults(func=main)


def parse_algorithms(text):
    names = [a.strip() for a in text.split(",") if a.strip()]
    unknown = [a for a in names if a not in ALGORITHMS]
    if unknown or not names:
        raise UsageError(f"unknown algorithm(s) {', '.join(unknown) or '(none given)'}: use {', '.join(ALGORITHMS)}")
    return names


def check_common(args):
    if args.solver not in SOLVERS:
        raise UsageError(f"unknown solver {args.solver!r}: use one of {', '.join(SOLVERS)}")
    try:
        check_writable(args.out)
    except PermissionError as err:
        raise UsageError(str(err)) from None
    if args.petsc:
        set_petsc_options(args.petsc)


def main(args):
    if args.benchmark not in BENCHMARKS:
        raise UsageError(f"unknown benchmark {args.benchmark!r}: use {' or '.join(BENCHMARKS)}")
    algorithms = parse_algorithms(args.algorithms)
    dt = positive(args.dt) if args.dt is not None else None
    end_time = positive(args.end_time) if args.end_time is not None else None
    material = get_material(args.material) if args.material else None
    check_common(args)
    options = dict(mesh_size=args.mesh_size, dt=dt, end_time=end_time, plane=args.plane, solver=args.solver)
    if args.benchmark == "block":
        options["needle_width"] = args.needle_width
    name = material.name if material else {"block": "MP1", "rod": "MP3"}.get(args.benchmark)
    case = algorithm_case(args.out.name, args.benchmark, args.material or name, algorithms, **options)
    request = {"command": "run", "benchmark": args.benchmark, "material": name, "algorithms": algorithms,
               "petsc": args.petsc, **options}
    if not args.force and same_request(args.out, request):
        if MPI.COMM_WORLD.rank == 0:
            print(f"{args.out}: complete results for these options exist, skipped (--force reruns)")
        return 0
    case.extra["request"] = request
    run_case(case, args.out)
    if MPI.COMM_WORLD.rank == 0:
        print(f"results in {args.out}")
    return 0


def same_request(out, request):
    """True if out holds complete results of the same request."""
    if not is_complete(out):
        return False
    summary = json.loads((Path(out) / SUMMARY).read_text())
    return summary.get("request") == json.loads(json.dumps(request))
