"""The users' compare folders of every case (OUT/leaderboard/CASE/user/NAME): read and checked
(workflows/leaderboard/rows.py's user_rows), each against its own manifest; what is left out is
said in one line."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from tissuebench.workflows.leaderboard.record import FOLDER
from tissuebench.workflows.leaderboard.rows import (
    Board,
    Row,
    misplaced,
    user_rows,
)

if TYPE_CHECKING:
    pass


def read_users(out: Path, boards: list[Board]) -> tuple[dict, dict]:
    """Every user's compare folder of every case (OUT/leaderboard/CASE/user/NAME), read and
    checked (rows.user_rows): ({case: [Row]}, {case: [one line per folder or run left
    out]}); each line left out is also printed on stderr, and so is every folder under
    OUT/leaderboard that is not read although it may be meant to be (rows.misplaced: not
    a case, or a compare folder outside user/). Rank 0."""
    rows, skipped = {}, {}
    for board in boards:
        folder = out / FOLDER / board.name / "user"
        rows[board.name], skipped[board.name] = user_rows(board, folder, boards)
        for line in skipped[board.name]:
            warn(line)
    if (out / FOLDER).is_dir():
        for line in misplaced(out / FOLDER, boards):
            warn(line)
    return rows, skipped


def warn(line: str) -> None:
    """One line on stderr: something read was left out, and why."""
    print(f"tissuebench leaderboard: {line}", file=sys.stderr)


def user_key(row: Row) -> str:
    """What makes a user's row the same run graded the same way: case, label, series, field,
    same-mesh grades and wall time."""
    return json.dumps(
        [row.case, row.label, row.series, row.series_field, row.errors, row.wall_time_s]
    )
