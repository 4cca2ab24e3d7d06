"""`tissuebench hertz --out DIR [--dim 3 [--quick]]`: the Hertz check of SPEC 12 (or 13).

The rigid needle pushed 5 mm statically into the linear MP1 block, solved as the truth is
(Taylor-Hood P2-P1 on meshes graded toward the contact, the penalty driven to its limit) on
three meshes and two penalties; the finest against Hertz's line-contact law (p0 within 1 %,
a within 2 %). Writes DIR/contact/hertz.json and DIR/contact/hertz.png (rank 0). Units: N/m,
Pa, m. With --dim 3, SPEC 13's check: the capsule pushed 5 mm into the cylinder's top face,
solved on the meridian (axisymmetric Q2-Q1), and on cylinders 2, 4 and 8 times as large: Hertz's
sphere and Sneddon's exact sphere judged on the half-space's values extrapolated from them, SPEC
13's own cylinder beside; writes DIR/contact/hertz3d.json and hertz3d.png (units N, Pa, m).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.workflows.commands import HELP
from tissuebench.workflows.contact import hertz, hertz3d
from tissuebench.workflows.io.output import check_writable, collective, write_set

FILES = ("hertz.json", "hertz.png")
FILES_3D = ("hertz3d.json", "hertz3d.png")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "hertz",
        help=HELP["hertz"],
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument("--out", default="results", help="output directory (default: results)")
    p.add_argument(
        "--dim",
        type=int,
        choices=(2, 3),
        default=2,
        help="2: SPEC 12's needle in the block (hertz.json); 3: SPEC 13's capsule in the "
        "cylinder, Hertz's and Sneddon's sphere, on the meridian (hertz3d.json) (default: 2)",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="with --dim 3: the coarser levels n = 16, 32, 64 (seconds, not minutes)",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    if args.dim == 3:
        return main_3d(args)
    comm = MPI.COMM_WORLD
    out = Path(args.out) / "contact"
    check_writable(out, comm, owned=FILES)
    start = time.perf_counter()
    pushes = hertz.compute(comm=comm)
    record = hertz.record(pushes)
    wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)

    def write_json(tmp: Path) -> None:
        tmp.write_text(json.dumps(record, indent=2) + "\n")

    def write() -> None:
        write_set(
            {
                out / "hertz.json": write_json,
                out / "hertz.png": lambda tmp: hertz.figure(tmp, pushes),
            }
        )

    collective(comm, write, out)
    if comm.rank == 0:
        r = record
        print(
            f"P {r['P']:.6g} N/m: p0 {r['p0']:.6g} Pa (Hertz {r['p0_hertz']:.6g}, "
            f"{100 * r['p0_error']:+.2f} %), a {r['a']:.6g} m (Hertz {r['a_hertz']:.6g}, "
            f"{100 * r['a_error']:+.2f} %): {'holds' if r['holds'] else 'DOES NOT HOLD'}"
        )
        print(f"wrote {out / 'hertz.json'} and hertz.png ({wall:.1f} s)")
    return 0


def main_3d(args: argparse.Namespace) -> int:
    """SPEC 13's check: writes DIR/contact/hertz3d.json and hertz3d.png."""
    comm = MPI.COMM_WORLD
    out = Path(args.out) / "contact"
    check_writable(out, comm, owned=FILES_3D)
    start = time.perf_counter()
    levels = hertz3d.QUICK if args.quick else hertz3d.LEVELS
    pushes, study = hertz3d.compute(levels=levels, comm=comm)
    wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    record = hertz3d.record(pushes, study, wall)

    def write_json(tmp: Path) -> None:
        tmp.write_text(json.dumps(record, indent=2) + "\n")

    def write() -> None:
        write_set(
            {
                out / "hertz3d.json": write_json,
                out / "hertz3d.png": lambda tmp: hertz3d.figure(tmp, pushes, study),
            }
        )

    collective(comm, write, out)
    if comm.rank == 0:
        r = record
        for name, v, e in (
            ("half-space (judged)", r["half_space"], r["errors"]),
            ("SPEC 13's cylinder", r["cylinder"], r["cylinder"]["errors"]),
        ):
            print(
                f"{name}: P {v['P']:.6g} N (Hertz {100 * e['P_hertz']:+.2f} %, Sneddon "
                f"{100 * e['P_sneddon']:+.2f} %), a {v['a']:.6g} m ({100 * e['a']:+.2f} %), "
                f"p0 {v['p0']:.6g} Pa ({100 * e['p0']:+.2f} %)"
            )
        print(
            ", ".join(
                f"{k} {'holds' if v else 'DOES NOT HOLD'}" for k, v in r["holds_each"].items()
            )
            + f": {r['why']}"
        )
        print(f"wrote {out / 'hertz3d.json'} and hertz3d.png ({wall:.1f} s)")
    return 0
