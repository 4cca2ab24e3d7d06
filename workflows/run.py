"""`tissuebench run {block,rod} --out DIR`: one benchmark, the chosen algorithms, one material."""

from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS, get_entry
from tissuebench.solvers import ALGORITHMS
from tissuebench.solvers.linear import SOLVERS, set_petsc_options
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.errors import UserError
from tissuebench.workflows.study import algorithm_case, run_case


def positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise UserError(f"expected a positive number of seconds, got {text!r}")
    return value


def add_common(p):
    p.add_argument("--solver", default="direct", help=f"linear solver: {', '.join(SOLVERS)} (default direct)")
    p.add_argument("--petsc", default="", metavar="OPTIONS",
                   help='PETSc options, prefixed per integrator, e.g. "-implicit_ksp_type cg -implicit_pc_type gamg"')
    p.add_argument("--force", action="store_true",
                   help="rerun and replace results that tissuebench wrote, even complete ones or ones of other inputs")


def add_parser(sub):
    p = sub.add_parser("run", help="run one benchmark with the chosen algorithms",
                       description="Run one benchmark and write XDMF series, metrics.csv, summary.json and figures to DIR.")
    p.add_argument("benchmark", help=f"{' or '.join(BENCHMARKS)}")
    p.add_argument("--out", required=True, type=Path,
                   help="output folder: new, empty, or one that tissuebench wrote")
    p.add_argument("--material", help="MP1, MP2, MP3 or a .toml file (default: the benchmark's)")
    p.add_argument("--mesh-size", type=int, help="block: N (even, default 20); rod: n (default 3)")
    p.add_argument("--dt", type=str, help="time step h in s (default 1/30)")
    p.add_argument("--end-time", type=str, help="end time T in s (default 10)")
    p.add_argument("--algorithms", default=",".join(ALGORITHMS),
                   help="comma-separated, default all five; implicit (the reference) always runs")
    p.add_argument("--needle-width", type=float, help="block only: needle tip width w in m (default 0)")
    p.add_argument("--plane", choices=["strain", "stress"], help="2D benchmarks only: plane strain (default) or stress")
    add_common(p)
    p.set_defaults(func=main)


def parse_algorithms(text: str) -> list[str]:
    names = [a.strip() for a in text.split(",") if a.strip()]
    unknown = [a for a in names if a not in ALGORITHMS]
    if unknown or not names:
        raise UserError(f"unknown algorithm(s) {', '.join(unknown) or '(none given)'}: use {', '.join(ALGORITHMS)}")
    return names


def check_common(args) -> None:
    if args.solver not in SOLVERS:
        raise UserError(f"unknown solver {args.solver!r}: use one of {', '.join(SOLVERS)}")
    if args.petsc:
        set_petsc_options(args.petsc)


def benchmark_options(args, entry) -> dict:
    """The benchmark's own options given on the command line; refuse those it does not take."""
    given = {"needle_width": args.needle_width}
    options = {}
    for name, value in given.items():
        if value is None:
            continue
        if name not in entry.options:
            raise UserError(f"--{name.replace('_', '-')} does not apply to {args.benchmark}")
        options[name] = value
    if args.plane is not None and entry.gdim != 2:
        raise UserError(f"--plane applies to 2D benchmarks only, not to {args.benchmark}")
    return options


def main(args):
    entry = get_entry(args.benchmark)
    options = benchmark_options(args, entry)
    algorithms = parse_algorithms(args.algorithms)
    dt = positive(args.dt) if args.dt is not None else None
    end_time = positive(args.end_time) if args.end_time is not None else None
    material = get_material(args.material or entry.material)
    check_common(args)
    case = algorithm_case(args.out.name or "run", args.benchmark, material, algorithms, mesh_size=args.mesh_size,
                          dt=dt, end_time=end_time, options=options, plane=args.plane or "strain",
                          solver=args.solver, petsc=args.petsc)
    summary = run_case(case, args.out, force=args.force)
    if MPI.COMM_WORLD.rank == 0 and not summary.get("skipped"):
        print(f"results in {args.out}")
    return 0
