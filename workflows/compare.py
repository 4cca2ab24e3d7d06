"""`tissuebench compare REFERENCE CANDIDATE --out DIR`: grade any simulator's output."""

import argparse
from pathlib import Path

from mpi4py import MPI

from tissuebench.workflows.grading import compare


def add_parser(sub):
    p = sub.add_parser(
        "compare",
        help="the three metrics of two displacement series on one mesh",
        description="Compare two displacement time series (XDMF/HDF5 or ParaView .pvd of .vtu) "
        "on the same mesh: writes DIR/metrics.csv and DIR/metrics.png. A series with "
        "a non-finite displacement from some step on has diverged there: the metrics "
        "are NaN from that step on and the status column says so.",
    )
    p.add_argument("reference", type=Path, help="reference series (.xdmf or .pvd)")
    p.add_argument("candidate", type=Path, help="candidate series (.xdmf or .pvd)")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument(
        "--field", default="displacement", help="point field to compare (default displacement)"
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Print (rank 0) where a series diverged, if it did, and the metrics' one-line summaries."""
    summaries = compare(args.reference, args.candidate, args.out, field=args.field)
    if MPI.COMM_WORLD.rank == 0:
        for line in summaries.values():
            print(line)
        print(f"wrote {args.out / 'metrics.csv'} and {args.out / 'metrics.png'}")
    return 0
