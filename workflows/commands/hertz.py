"""`tissuebench hertz --out DIR`: the Hertz check of SPEC 12.

The rigid needle pushed 5 mm statically into the linear MP1 block, solved as the truth is
(Taylor-Hood P2-P1 on meshes graded toward the contact, the penalty driven to its limit) on
three meshes and two penalties; the finest against Hertz's line-contact law (p0 within 1 %,
a within 2 %). Writes DIR/contact/hertz.json and DIR/contact/hertz.png (rank 0). Units: N/m,
Pa, m.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.workflows.contact import hertz
from tissuebench.workflows.io.output import check_writable, collective, write_set

FILES = ("hertz.json", "hertz.png")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "hertz",
        help="the needle pushed statically into the block, against Hertz's law (SPEC 12)",
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument("--out", default="results", help="output directory (default: results)")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
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
