"""`tissuebench leaderboard --out results`: OUT/leaderboard/index.html (the page),
OUT/leaderboard.md, OUT/leaderboard.csv and a figure per case, rendered from the record
OUT/leaderboard.json with the users' compare folders read, checked against their case and
their own manifest, and graded against its truth (no rerun: seconds; a user's row new to the
record gets our implicit run on its own mesh for its error budget,
workflows/leaderboard/user_mesh.py).
The record is OUT's, or, where OUT holds none, the clone's results/ (the
editable install's repository) or `--results DIR`: only read, the outputs go to OUT.
`--rerun [CASE ...]`: every algorithm and model of ours and every outside simulator that
poses those cases (all when none is named) run, graded against one reference and timed in
this session; the other cases keep their recorded rows and say when they were timed. The
arguments only: the leaderboard is the package workflows/leaderboard/ (build.main).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import add_common
from tissuebench.workflows.leaderboard import build
from tissuebench.workflows.leaderboard.rows import BOARDS


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "leaderboard",
        help=HELP["leaderboard"],
        description="Render OUT/leaderboard/index.html, OUT/leaderboard.md, "
        "OUT/leaderboard.csv and OUT/leaderboard/CASE.png "
        "from the record OUT/leaderboard.json (or, where OUT has none, the clone's "
        "results/leaderboard.json, or --results DIR's: only read), with the runs that users "
        "graded with "
        "`tissuebench compare --label NAME --wall-time S --out OUT/leaderboard/CASE/user/NAME` "
        "(read, checked against their case, graded against its truth: seconds, nothing is "
        "rerun). --rerun runs and times every algorithm and model of ours and every variant of "
        "every outside simulator installed here on each case (or on the cases named) in this "
        "session, grades each against the case's reference and its truth, and writes the "
        "record; the cases not named keep their recorded rows.",
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    p.add_argument(
        "--results",
        type=Path,
        metavar="DIR",
        help="the folder holding the record leaderboard.json to render (only read; default: "
        "OUT when it holds one, else the results/ of the clone tissuebench is installed from, "
        "so that `--out results` works in any folder of your own)",
    )
    p.add_argument(
        "--rerun",
        nargs="*",
        metavar="CASE",
        help=f"rerun and re-time these cases (none named: all; {', '.join(b.name for b in BOARDS)})"
        " instead of taking their rows from the record",
    )
    add_common(p)
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """The leaderboard, as workflows/leaderboard/build.py makes it."""
    return build.main(args)
