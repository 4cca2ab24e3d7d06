"""`tissuebench compare REFERENCE CANDIDATE --out DIR`: grade any simulator's output."""

import argparse
from pathlib import Path

from mpi4py import MPI

from tissuebench.workflows.grading import compare
from tissuebench.workflows.io.series import DEFAULT_FIELDS


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help="the three metrics of two displacement series, on one mesh or two",
        description="Compare two displacement time series of the same body, on the same mesh or "
        "each on its own (first-order triangles, quadrilaterals, tetrahedra or hexahedra; SPEC "
        "9: the candidate is evaluated at the reference's nodes and quadrature points): XDMF/HDF5, "
        "ParaView "
        ".pvd of .vtu, or CalculiX's output as it comes (the ASCII .frd, or the .dat of "
        "*NODE PRINT with its deck, the .inp of the same name, beside it). Writes "
        "DIR/metrics.csv, DIR/metrics.png and DIR/summary.json (DIR: a new or empty folder, or a "
        "compare folder of ours; the same inputs again are skipped). summary.json records what "
        "the reference is (benchmark, case, material, model, h, T, mesh, as its run folder or "
        "the export beside it says, or the truth case) and the candidate's mesh (cells, nodes, "
        "dofs): `tissuebench leaderboard` takes the folder only under that case. A series "
        "that starts at t = h "
        "(CalculiX writes none at t = 0) starts from the zero initial state at t = 0. Time "
        "stamps match within 1e-5 of max(|t|, h) (six printed digits). A series with a "
        "non-finite displacement, or one beyond 100 times the domain's largest extent, has "
        "diverged from that step: the metrics are NaN from that step on and the status column "
        "and summary.json say why. Complex fields, and series whose steps move or renumber "
        "their nodes, are refused.",
    )
    p.add_argument(
        "reference",
        type=Path,
        help="reference series (.xdmf, .pvd, .frd or .dat), or truth:CASE, the converged "
        "reference of a SPEC 10 case (rod, rod-nh-s1, rod-nh-s3, block-MP1-w0.2, block-MP2-w0.2, "
        "block-MP1-nh-s2-w0.2; computed once and cached): the candidate is graded on its own "
        "mesh at the truth's vertices and quadrature points, and needs every t_i = i h",
    )
    p.add_argument("candidate", type=Path, help="candidate series (.xdmf, .pvd, .frd or .dat)")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    names = ", ".join(DEFAULT_FIELDS)
    p.add_argument(
        "--field",
        help=f"point field of both series (default: the first of {names} that each file holds)",
    )
    p.add_argument("--reference-field", help="point field of the reference (overrides --field)")
    p.add_argument("--candidate-field", help="point field of the candidate (overrides --field)")
    p.add_argument(
        "--label",
        help="the candidate's name in metrics.csv and summary.json (default: its file name "
        "without suffix)",
    )
    p.add_argument(
        "--wall-time",
        metavar="SECONDS",
        help="the candidate's wall time in s, recorded in summary.json",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace a compare folder of ours that holds results of other inputs",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Print (rank 0) how the series were read, where a series diverged, if it did, and the
    metrics' one-line summaries."""
    summaries = compare(
        args.reference,
        args.candidate,
        args.out,
        field=args.field,
        reference_field=args.reference_field,
        candidate_field=args.candidate_field,
        label=args.label,
        wall_time=args.wall_time,
        force=args.force,
    )
    if MPI.COMM_WORLD.rank == 0:
        for line in summaries.values():
            print(line)
        if "skipped" not in summaries:
            print(f"wrote {args.out / 'metrics.csv'}, {args.out / 'metrics.png'} and summary.json")
    return 0
