"""A rerun's finished cases, kept as each ends, so that a `--rerun` stopped part way (Ctrl-C, a
lost session, a crash in a later case) resumes from them instead of running them again: a
contact case alone runs for 2 to 11 minutes here, and a rerun of several for hours.

OUT/leaderboard/rerun-cases.json is a leaderboard record (record.record_of) of the cases this
rerun has finished (run, timed and graded against the truth), with the SHA-256 of the
tissuebench sources that ran them (`code`). A later rerun into the same OUT takes a case from
it only where the sources are the same and the case's definition (its Board but for what a run
sets: session, machine, load, the truth's band and note) is today's; the file goes once the
whole rerun is written. The series files the rows point at stay where the first run wrote them
(OUT/leaderboard/CASE/)."""

from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from tissuebench.solvers.truth.store import PACKAGE, code_hash
from tissuebench.workflows.io.manifest import unchanged
from tissuebench.workflows.io.output import check_owned, write_owned
from tissuebench.workflows.leaderboard.record import (
    FOLDER,
    LeaderboardError,
    parse_record,
    record_of,
)
from tissuebench.workflows.leaderboard.rows import Board, Row

DONE = "rerun-cases.json"  # in OUT/leaderboard: the cases this rerun finished (resumed from)
RUN_SETS = ("session", "machine", "load", "truth_band", "truth_note")  # a Board's, set by a run
PACKAGES = ("core", "meshes", "metrics", "solvers", "workflows")  # tissuebench's sources


def source_code() -> str:
    """SHA-256 of the code of every tissuebench source (.py), as the truth's cache key hashes
    its own (store.code_hash: docstrings, type hints and layout aside): what ran a case."""
    files = (p.relative_to(PACKAGE) for name in PACKAGES for p in (PACKAGE / name).rglob("*.py"))
    return code_hash(tuple(sorted(f.as_posix() for f in files)))


def definition(board: Board) -> str:
    """A case as posed (its Board without what a run sets), as text to compare."""
    return json.dumps({k: v for k, v in asdict(board).items() if k not in RUN_SETS}, default=list)


class Finished:
    """The cases of this rerun finished so far: `take(board)` gives one kept by an earlier run
    of the same sources, `keep(board, rows, notes)` records one as it ends, `done()` removes the
    file once the whole rerun is written. Rank 0. A file there that tissuebench did not write,
    or that was changed since, is refused at once (OutputError, one line), as any output is."""

    def __init__(self, out: Path, log=print):
        self.path, self.log = out / FOLDER / DONE, log
        check_owned(self.path)  # one we did not write is refused now, before anything runs
        self.code = source_code()
        self.boards: list[Board] = []
        self.rows: dict[str, list[Row]] = {}
        self.notes: dict[str, list[str]] = {}
        self.earlier = self._read()

    def _read(self) -> dict[str, tuple[Board, list[Row], list[str]]]:
        """The file as we wrote it (its hash in the folder's manifest) and of today's sources;
        {} otherwise (a file of other sources: one line says it is not taken)."""
        if not unchanged(self.path):
            return {}
        try:
            text = self.path.read_text()
            code = json.loads(text).get("code")
            boards, rows, notes = parse_record(text, str(self.path), "it is not taken")
        except (OSError, ValueError, AttributeError, LeaderboardError):
            return {}
        if code != self.code:
            self.log(
                f"tissuebench leaderboard: {self.path}: cases of a rerun by other sources "
                f"({', '.join(b.name for b in boards)}): not taken, run again"
            )
            return {}
        return {b.name: (b, rows[b.name], notes[b.name]) for b in boards}

    def take(self, board: Board) -> tuple[Board, list[Row], list[str]] | None:
        """(the Board as run, its rows, its notes) of `board` finished by an earlier run of
        this rerun, kept again in this one; None where there is none (or it was posed
        otherwise)."""
        found = self.earlier.get(board.name)
        if found is None or definition(found[0]) != definition(board):
            return None
        kept, rows, notes = found
        self.keep(kept, rows, notes)
        self.log(
            f"tissuebench leaderboard: {board.name}: taken as an earlier run of this rerun "
            f"finished it ({kept.session}; {self.path}), not run again"
        )
        return found

    def keep(self, board: Board, rows: list[Row], notes: list[str]) -> None:
        """Record a finished case (its rows graded against the truth)."""
        self.boards = [b for b in self.boards if b.name != board.name] + [board]
        self.rows[board.name], self.notes[board.name] = rows, notes
        record = {**record_of(self.boards, self.rows, self.notes), "code": self.code}
        text = json.dumps(record)
        write_owned(self.path, lambda tmp: tmp.write_text(text))

    def done(self) -> None:
        """Every case is in the record now: the file is no longer needed."""
        self.path.unlink(missing_ok=True)
