"""The users' compare folders of every case (OUT/leaderboard/CASE/user/NAME): read and checked
(workflows/leaderboard/rows.py's user_rows: its case, its manifest, which guards against
accidents and is no signature, its links, its series' hashes); what is left out is said in one
line. No number is taken from a folder: grading.py grades each row's series."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from tissuebench.workflows.io.manifest import file_hash, read_manifest
from tissuebench.workflows.io.output import write_owned
from tissuebench.workflows.leaderboard.force_curve import force_hash
from tissuebench.workflows.leaderboard.record import FOLDER, Invalid, row_fields, row_of
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import Board, Row, misplaced, user_rows

GRADED = "graded-users.json"  # in OUT/leaderboard: the users' rows graded so far (resumed from)


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
    """What makes a user's row's grades the same: its case, its series by content hash
    (rows.series_hash: the files themselves, wherever they are) and the field read. The label
    and wall time are the folder's, read again each time; no grade is. A stated model (its
    error budget's) is part of it where there is one, and so is a contact case's force, by its
    curve's content hash (force_curve.force_hash), where the row carries one."""
    stated = [row.model] if row.model is not None else []  # none: the key as it always was
    force = force_hash(row)
    forced = [f"force sha256:{force}"] if force is not None else []
    return json.dumps([row.case, row.series_hash, row.series_field, *stated, *forced])


class Progress:
    """The users' rows graded in this run, each said in one line as it ends (seconds, k of n)
    and recorded in OUT/leaderboard/graded-users.json (listed in that folder's manifest), so
    that a run stopped part way resumes from the rows it finished (`resumed`)."""

    def __init__(self, out: Path, total: int, log=print):
        self.path, self.total, self.log = out / FOLDER / GRADED, total, log
        self.rows: list[Row] = []

    def resumed(self) -> dict[str, Row]:
        """{user_key: Row} of the rows graded by an earlier run (the file as we wrote it, each
        row valid), {} otherwise."""
        listed = read_manifest(self.path.parent, "files") or {}
        if not self.path.is_file() or listed.get(GRADED) != file_hash(self.path):
            return {}
        try:
            found = [row_of(d) for d in json.loads(self.path.read_text())]
        except (OSError, ValueError, TypeError, RecursionError, Invalid):
            return {}
        return {user_key(r): r for r in found if r.kind is Kind.USER}

    def __call__(self, board: Board, row: Row, seconds: float) -> None:
        self.rows.append(row)
        text = json.dumps([row_fields(r) for r in self.rows])
        write_owned(self.path, lambda tmp: tmp.write_text(text))
        self.log(
            f"graded user row {len(self.rows)} (of {self.total} user rows): {row.label} "
            f"({board.name}) in {seconds:.1f} s"
        )

    def done(self) -> None:
        """Every row is in the record now: the file is no longer needed."""
        if self.rows:
            self.path.unlink(missing_ok=True)
