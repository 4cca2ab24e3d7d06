"""`tissuebench mesh BENCHMARK --mesh-size N [--cell C --mesh KIND] --out FILE.msh`: save a
benchmark's gmsh mesh."""

import argparse
import os
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import BENCHMARKS, get_benchmark, get_entry
from tissuebench.meshes.benchmark import shape_options
from tissuebench.meshes.gmshio import check_positive_int
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_shape_options, mesh_size_help
from tissuebench.workflows.io.limits import check as check_limits
from tissuebench.workflows.io.limits import estimate
from tissuebench.workflows.io.output import PREFIX, check_file_target, collective, write_owned


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "mesh",
        help=HELP["mesh"],
        description="Build a benchmark's mesh with gmsh and save it (.msh) for inspection.",
    )
    p.add_argument("benchmark", help=" or ".join(BENCHMARKS))
    p.add_argument("--mesh-size", type=int, help=mesh_size_help(BENCHMARKS))
    add_shape_options(p)
    p.add_argument(
        "--out", required=True, type=Path, help="the .msh file to write (a new one, unless --force)"
    )
    p.add_argument("--force", action="store_true", help="replace an existing file")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    comm = MPI.COMM_WORLD
    entry = get_entry(args.benchmark)
    mesh_size = entry.mesh_size if args.mesh_size is None else args.mesh_size
    check_positive_int("mesh size", mesh_size)
    shape = shape_options(entry.gdim, args.cell, args.mesh)
    collective(comm, lambda: check_file_target(args.out, "msh", args.force))
    check_limits(
        estimate(entry.gdim, entry.nodes(mesh_size), 0, 0, comm.size),
        args.out.absolute().parent,
        comm,
    )
    tmp = args.out.with_name(f"{PREFIX}{args.out.name}.{os.getpid()}.tmp.msh")
    try:
        bench = get_benchmark(args.benchmark, mesh_size=mesh_size, msh_path=tmp, **shape)
        collective(comm, lambda: write_owned(args.out, lambda p: os.replace(tmp, p)), args.out)
    finally:
        if comm.rank == 0:
            tmp.unlink(missing_ok=True)
    if comm.rank == 0:
        m = bench.mesh.topology
        print(
            f"{args.out}: {m.index_map(0).size_global} nodes, {m.index_map(m.dim).size_global} "
            f"cells, physical groups {', '.join(bench.tagged.groups)}"
        )
    return 0
