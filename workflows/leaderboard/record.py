"""The leaderboard's record, leaderboard.json: every case's Board, its notes and every Row,
from which the leaderboard is rendered again; read back and validated row by row (validate)."""

from __future__ import annotations

import json
from dataclasses import asdict, fields
from pathlib import Path
from typing import TYPE_CHECKING

from tissuebench.meshes.errors import UserError
from tissuebench.workflows.ranking import (
    Board,
    Row,
)

if TYPE_CHECKING:
    pass


FOLDER = "leaderboard"


MARKER = "# Leaderboard: accuracy against cost"


RECORD = "leaderboard.json"


RECORD_SCHEMA = "tissuebench.leaderboard"


RECORD_VERSION = 1


OWNED = ["leaderboard.md", "leaderboard.csv", RECORD]


class LeaderboardError(UserError):
    """A leaderboard that cannot be made as asked (no record, an unknown case): one line."""


def board_of(d: dict) -> Board:
    """A Board from its record (lists back to tuples)."""
    known = {f.name for f in fields(Board)}
    b = Board(**{k: v for k, v in d.items() if k in known})
    b.models, b.simulators = tuple(b.models), tuple(b.simulators)
    b.variants = {k: tuple(v) for k, v in (b.variants or {}).items()}
    return b


def row_of(d: dict) -> Row:
    """A Row from its record."""
    known = {f.name for f in fields(Row)}
    return Row(**{k: v for k, v in d.items() if k in known})


def record_of(boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]]) -> dict:
    """leaderboard.json: every case's Board (what renders it: description, truth, its band and
    note, sizes, session, machine), its notes (the run's; the users' refusals are not kept: they
    are read again) and every Row with all its fields (errors in m^gdim or relative, wall times
    in s, truth columns, Pareto flags, error budget)."""
    return {
        "schema": RECORD_SCHEMA,
        "version": RECORD_VERSION,
        "cases": [
            {
                "board": asdict(b),
                "notes": list(notes.get(b.name, [])),
                "rows": [asdict(r) for r in rows[b.name]],
            }
            for b in boards
        ],
    }


def read_record(out: Path) -> tuple[list[Board], dict, dict] | None:
    """The record OUT/leaderboard.json as (boards, {case: rows}, {case: notes}); None when there
    is none. LeaderboardError when it cannot be read. Rank 0."""
    path = out / RECORD
    if not path.is_file():
        return None
    redo = f"`tissuebench leaderboard --out {out} --rerun` writes a new one"
    try:
        doc = json.loads(path.read_text())
        if doc.get("schema") != RECORD_SCHEMA or doc.get("version") != RECORD_VERSION:
            raise ValueError(f"not a {RECORD_SCHEMA} record of version {RECORD_VERSION}")
        boards, rows, notes = [], {}, {}
        for case in doc["cases"]:
            board = board_of(case["board"])
            boards.append(board)
            rows[board.name] = [row_of(r) for r in case["rows"]]
            notes[board.name] = [str(n) for n in case.get("notes", [])]
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        raise LeaderboardError(
            f"{path}: cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())[:160]}); "
            f"{redo}"
        ) from None
    return boards, rows, notes
