"""The full mesh-sensitivity study's runs (mesh-sensitivity.md and .csv in OUT) read back as
leaderboard cases, each row checked to be a run of the study (leaderboard_boards)."""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from pathlib import Path

from tissuebench.meshes import get_entry
from tissuebench.meshes.benchmark import CELLS
from tissuebench.solvers import ALGORITHMS
from tissuebench.workflows.io.tables import CSVError, read_rows
from tissuebench.workflows.leaderboard.mesh_sensitivity_cases import (
    MARKER,
    NAME,
    STUDIES,
    Study,
    shapes,
)
from tissuebench.workflows.leaderboard.row import OUR_SOURCE, Kind
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, fmt


def leaderboard_boards(out: Path, log: Callable[[str], None] = lambda line: None) -> list[tuple]:
    """The full study's runs in OUT as leaderboard cases: [(Board, [Row])], one
    per case (none without a full study's report). Nothing read is trusted: a report or table
    that cannot be read, and each row of the table that is not a run of the study, is left
    out with one line to `log`."""
    md, table = out / f"{NAME}.md", out / f"{NAME}.csv"
    if not (md.is_file() and table.is_file()):
        return []
    try:
        first = md.read_text(errors="replace").split("\n", 1)[0]
        if first == MARKER:
            every = read_rows(table, errors="replace")
    except (OSError, CSVError) as exc:
        log(f"{md.parent / NAME}.md and .csv: cannot be read ({type(exc).__name__}); left out")
        return []
    if first != MARKER:
        if not first.startswith(MARKER):
            log(f"{md}: not a report of tissuebench sensitivity; its runs are left out")
        return []  # a quick check: never on the leaderboard
    boards = []
    for study in STUDIES:
        mine = []
        for number, raw in enumerate(every, start=1):
            if raw.get("case") != study.name:
                continue
            try:
                mine.append(study_row(study, raw))
            except (TypeError, ValueError) as exc:
                log(f"{table}, row {number}: not a run of the study ({exc}); left out")
        if not mine:
            continue
        sessions = sorted({r["session"] for r in mine})
        entry = get_entry(study.benchmark)
        options = ", ".join(f"{k} = {v}" for k, v in study.options.items())
        board = Board(
            f"{NAME}-{study.name}",
            study.benchmark,
            study.material,
            "linear",
            options=study.options,
            simulators=(),
            description=f"`tissuebench sensitivity` ({NAME}.md): {study.benchmark}, "
            f"{study.material}{', ' + options if options else ''}, linear; ours on grids of "
            f"size {', '.join(map(str, study.sizes))} in three shapes, graded on their own "
            f"meshes against implicit on the {CELLS[entry.gdim][0]} grid of size "
            f"{2 * study.size}. Timed in that study's session ({', '.join(sessions)}), not "
            "this leaderboard's; E_s not graded.",
        )
        rows = []
        for r in mine:
            rows.append(
                Row(
                    board.name,
                    f"{r['algorithm']} ({r['shape']}, size {r['size']})",
                    OUR_SOURCE,
                    f"{r['algorithm']}, linear (SPEC 3), on its own mesh (SPEC 9)",
                    f"{r['shape']}: {r['nodes']} nodes",
                    r["dofs"],
                    r["status"],
                    None
                    if r["status"] == "ok"
                    else f"diverged at t = {fmt(r['diverged_time_s'], '.3g')} s",
                    r["errors"],
                    r["wall_time_s"],
                    r["end_time_s"],
                    f"tissuebench sensitivity, {', '.join(sessions)}",
                    kind=Kind.OURS,
                )
            )
        boards.append((board, rows))
    return boards


SESSION = re.compile(r"[0-9A-Za-z :+\-./]{1,40}")  # a session's time, as main writes it


def study_row(study: Study, r: dict) -> dict:
    """One row of mesh-sensitivity.csv (text) as numbers, checked to be a run of the study:
    its algorithm, shape and size, counts >= 0, finite times >= 0 (s), errors empty or "nan"
    (None: never ranked) or finite numbers >= 0. ValueError or TypeError says what is wrong."""

    def count(key):
        value = int(r.get(key))
        if value < 0:
            raise ValueError(f"{key} is negative")
        return value

    def seconds(key, positive=False):
        value = float(r.get(key))
        if not math.isfinite(value) or value < 0 or (positive and value == 0):
            raise ValueError(f"{key} is not a finite number of seconds > 0")
        return value

    def error(key):
        text = (r.get(key) or "").strip()
        if text.lower() in ("", "nan"):
            return None
        value = float(text)
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{key} is not a finite number >= 0")
        return value

    if r.get("algorithm") not in ALGORITHMS:
        raise ValueError(f"algorithm {str(r.get('algorithm'))[:40]!r} is not one of ours")
    if r.get("shape") not in shapes(get_entry(study.benchmark).gdim):
        raise ValueError(f"shape {str(r.get('shape'))[:40]!r} is not one of the study's")
    if count("size") not in study.sizes:
        raise ValueError(f"size {r.get('size')} is not one of the study's")
    status = r.get("status")
    if status not in ("ok", "diverged"):
        raise ValueError(f"status {str(status)[:40]!r} is neither ok nor diverged")
    return {
        "algorithm": r["algorithm"],
        "shape": r["shape"],
        "size": count("size"),
        "nodes": count("nodes"),
        "dofs": count("dofs"),
        "status": status,
        "diverged_time_s": None if status == "ok" else seconds("diverged_time_s"),
        "errors": {k: error(k) for k in error_keys()},
        "wall_time_s": seconds("wall_time_s"),
        "end_time_s": seconds("end_time_s", positive=True),
        "session": r["session"] if SESSION.fullmatch(r.get("session") or "") else "?",
    }
