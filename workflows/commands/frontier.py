"""`tissuebench frontier --out results`: the real-time frontier of SPEC 11.

For block-MP2-w0.2, block-MP1-w0.2, rod-MP2 and the rod in MP3 (the compressible control),
every scheme of solvers/schemes/ (listed below, with the parameters swept on the middle size)
with implicit, explicit-lumped (at h = 1/30 s, and with the sub-steps that keep it stable) and
explicit (consistent mass, with the sub-steps that keep it stable, on the two smaller sizes) on
four mesh sizes, graded against the truth (E_i, E_n) and timed on one core. Writes
OUT/frontier/frontier.csv (a row as each run ends: an interrupted study resumes from it),
OUT/frontier/frontier.md and a figure per case, OUT/frontier/frontier-CASE.png (about 45 min
here, the truths cached; missing truths are computed first)."""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.core.errors import UserError
from tissuebench.solvers.truth.cases import CASES
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import schemes_described
from tissuebench.workflows.frontier.report import MARKER, markdown, plot
from tissuebench.workflows.frontier.runs import (
    FRONTIER_CASES,
    RETIME,
    SWEEPS,
    read_rows,
    retime,
    row_key,
    run_study,
    side_by_side,
)
from tissuebench.workflows.io.output import write_owned
from tissuebench.workflows.io.tables import write_rows


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "frontier",
        help=HELP["frontier"],
        description=__doc__.split("\n\n")[1],
        epilog=f"The schemes, each at its defaults: {schemes_described()}. Swept on the middle "
        f"size: {', '.join(s for swept in SWEEPS.values() for s in swept)}.",
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    p.add_argument(
        "--cases",
        default=",".join(FRONTIER_CASES),
        help=f"comma-separated truth cases (default {','.join(FRONTIER_CASES)})",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="the smallest mesh size only, no sweeps, into OUT/frontier-quick: checks the "
        "workflow; never touches a full study's folder",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    if MPI.COMM_WORLD.size > 1:
        raise UserError("frontier times every run on one core: run it without mpiexec")
    cases = tuple(c.strip() for c in args.cases.split(",") if c.strip())
    unknown = [c for c in cases if c not in CASES]
    if unknown or not cases:
        raise UserError(
            f"--cases: {', '.join(unknown) or 'none'}; the truth cases are {', '.join(CASES)}"
        )
    folder = args.out / ("frontier-quick" if args.quick else "frontier")
    report = folder / "frontier.md"
    if report.exists() and not report.read_text(errors="replace").startswith(MARKER):
        raise UserError(f"{report}: exists and was not written by tissuebench frontier")
    folder.mkdir(parents=True, exist_ok=True)
    started, load = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), os.getloadavg()[0]
    kept = {row_key(r) for r in read_rows(folder / "frontier.csv", lambda line: None)}
    run_study(folder, cases, args.quick)
    rows = [r for r in retime(folder) if r["case"] in cases]
    new = sum(row_key(r) not in kept for r in rows)
    timing = [t for case in cases for t in side_by_side(case, 2 if args.quick else 5)]
    write_owned(folder / "frontier-timing.csv", lambda tmp: write_rows(tmp, timing))
    ended = os.getloadavg()[0]
    header = (
        f"Written by `tissuebench frontier{' --quick' if args.quick else ''}` (this session "
        f"from {started}, one core: {new} run(s) and the side-by-side timing; the other "
        f"{len(rows) - new} rows of frontier.csv as the sessions that ran them timed them"
        + f"; load average {load:.2f} as it began, {ended:.2f} as it ended: "
        "costs measured while other jobs ran are upper bounds; a finished run whose cost lay "
        f"within {RETIME[0]:g} to {RETIME[1]:g} s per simulated s was timed twice, the smaller "
        "time kept). Rows: frontier.csv."
    )
    every = tuple(c for c in cases if any(r["case"] == c for r in rows))
    for case in every:

        def draw(tmp: Path, case: str = case) -> None:
            plot(tmp, case, [r for r in rows if r["case"] == case])

        write_owned(folder / f"frontier-{case}.png", draw)
    text = markdown(rows, every, header, timing)
    write_owned(report, lambda tmp: tmp.write_text(text))
    print(f"wrote {report}, {folder / 'frontier.csv'} and {folder}/frontier-*.png")
    return 0
