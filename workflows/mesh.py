"""`tissuebench mesh {block,rod} --mesh-size N --out FILE.msh`: save a benchmark's gmsh mesh."""

from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS, get_benchmark
from tissuebench.workflows.cli import UsageError


def add_parser(sub):
    p = sub.add_parser("mesh", help="save a benchmark's mesh as a gmsh .msh file",
                       description="Build a benchmark's mesh with gmsh and save it (.msh) for inspection.")
    p.add_argument("benchmark", help=" or ".join(BENCHMARKS))
    p.add_argument("--mesh-size", type=int, help="block: N (even, default 20); rod: n (default 3)")
    p.add_argument("--out", required=True, type=Path, help="the .msh file to write")
    p.set_defaults(func=main)


def main(args):
    if args.out.suffix != ".msh":
        raise UsageError(f"output {args.out} must end in .msh")
    options = {} if args.mesh_size is None else {"mesh_size": args.mesh_size}
    if args.benchmark not in BENCHMARKS:
        raise UsageError(f"unknown benchmark {args.benchmark!r}: use {' or '.join(BENCHMARKS)}")
    bench = get_benchmark(args.benchmark, msh_path=args.out, **options)
    if MPI.COMM_WORLD.rank == 0:
        m = bench.mesh.topology
        print(f"{args.out}: {m.index_map(0).size_global} nodes, {m.index_map(m.dim).size_global} cells, "
              f"physical groups {', '.join(bench.tagged.groups)}")
    return 0
