"""The leaderboard's record, leaderboard.json: every case's Board, its notes and every Row,
from which the leaderboard is rendered again; read back and validated row by row (validate)."""

from __future__ import annotations

import json
import math
import re
import secrets
import sys
from dataclasses import asdict, fields
from pathlib import Path
from typing import Any

from tissuebench.core.errors import UserError
from tissuebench.solvers.models import MODELS
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, one_line, real

FOLDER = "leaderboard"
MARKER = "# Leaderboard: accuracy against cost"
RECORD = "leaderboard.json"
RECORD_SCHEMA = "tissuebench.leaderboard"
RECORD_VERSION = 1
OWNED = ["leaderboard.md", "leaderboard.csv", RECORD]
# bytes: a record larger than this is not ours (ours: a few MB, most of it the contact rows'
# force curves)
MAX_RECORD = 64 * 2**20
MAX_TEXT = 4000  # characters of any text field of a row or case
# characters of a row's label: ours are under 60, a user's at most rows.MAX_LABEL and its
# folder's name when another has the same label (rows.told_apart)
MAX_LABEL = 200


class LeaderboardError(UserError):
    """A leaderboard that cannot be made as asked (no record, an unknown case): one line."""


class Invalid(ValueError):
    """A field of the record that is not of its type or range: its place and what it holds."""


def _text(value, where: str, none: bool = False) -> None:
    if value is None and none:
        return
    if not isinstance(value, str) or len(value) > MAX_TEXT:
        raise Invalid(f"{where} {one_line(repr(value))[:40]} is not text")


def _number(value, where: str, none: bool = True, positive: bool = False) -> None:
    """None (when allowed), or a finite real number (not a bool) >= 0 (> 0 when positive);
    NaN is taken (no number: it never ranks), an infinity, a negative number or text is
    not."""
    if value is None and none:
        return
    if not real(value) or (not math.isnan(value) and (value < 0 or (positive and value == 0))):
        bound = "> 0" if positive else ">= 0"
        raise Invalid(f"{where} {one_line(repr(value))[:40]} is not a number {bound}")
    if math.isinf(value):
        raise Invalid(f"{where} {one_line(repr(value))[:40]} is not a finite number")


def _numbers(value, where: str, keys: list[str] | None = None) -> None:
    """A dict of numbers >= 0 or null (keys: those it must hold, None: any)."""
    if not isinstance(value, dict):
        raise Invalid(f"{where} {one_line(repr(value))[:40]} is not an object of numbers")
    for key in keys or []:
        if key not in value:
            raise Invalid(f"{where} has no {key}")
    for key, x in value.items():
        if isinstance(x, str) and key.endswith("_how"):
            continue  # the budget says how a part was measured
        _number(x, f"{where}.{one_line(key)[:40]}")


def _flags(value, where: str) -> None:
    if not isinstance(value, dict) or not all(isinstance(x, bool) for x in value.values()):
        raise Invalid(f"{where} {one_line(repr(value))[:40]} is not an object of true/false")


def check_row(d) -> None:
    """Raise Invalid unless a recorded row has every field of its type and range: texts (the
    label printable, of at most MAX_LABEL characters), dofs a whole number >= 0, wall time and
    end time finite numbers (s; the end time > 0), errors and truth columns objects of finite
    numbers >= 0 or null, Pareto flags true/false, the budget's parts numbers or null."""
    if not isinstance(d, dict):
        raise Invalid(f"{one_line(repr(d))[:40]} is not an object")
    for key in ("case", "label", "source", "description", "mesh", "status", "timing"):
        _text(d.get(key), key)
    label = d["label"]
    if not 0 < len(label) <= MAX_LABEL or not label.isprintable():
        raise Invalid(
            f"label {one_line(repr(label))[:40]} is not printable text of 1 to {MAX_LABEL} "
            "characters"
        )
    for key in ("reason", "group", "series", "series_field", "truth_note", "series_hash", "folder"):
        _text(d.get(key), key, none=True)
    model = d.get("model")  # a user's row's stated model
    if model is not None and model not in MODELS:
        raise Invalid(f"model {one_line(repr(model))[:40]} is not one of {', '.join(MODELS)}")
    dofs = d.get("dofs")
    if not isinstance(dofs, int) or isinstance(dofs, bool) or dofs < 0:
        raise Invalid(f"dofs {one_line(repr(dofs))[:40]} is not a whole number >= 0")
    _number(d.get("wall_time_s"), "wall_time_s")
    _number(d.get("end_time"), "end_time", none=False, positive=True)
    _numbers(d.get("errors"), "errors", error_keys())
    _numbers(d.get("truth", {}), "truth")
    _numbers(d.get("budget", {}), "budget")
    _numbers(d.get("contact", {}), "contact")  # a contact case's row (SPEC 12)
    _text(d.get("force"), "force", none=True)
    for key in ("pareto", "truth_pareto"):
        _flags(d.get(key, {}), key)
    if not isinstance(d.get("reference", False), bool):
        raise Invalid(f"reference {one_line(repr(d.get('reference')))[:40]} is not true/false")


def check_board(d) -> None:
    """Raise Invalid unless a recorded case has its texts, numbers and lists of their types."""
    if not isinstance(d, dict):
        raise Invalid(f"{one_line(repr(d))[:40]} is not an object")
    for key in ("name", "benchmark", "material", "model"):
        _text(d.get(key), key)
    for key in ("description", "truth_note", "skip_note", "session", "machine"):
        _text(d.get(key, ""), key)
    for key in ("truth", "sizes", "simulator_model"):
        _text(d.get(key), key, none=True)
    _number(d.get("truth_band"), "truth_band")
    _number(d.get("end_time"), "end_time", positive=True)
    size = d.get("mesh_size")
    if size is not None and (not isinstance(size, int) or isinstance(size, bool) or size < 1):
        raise Invalid(f"mesh_size {one_line(repr(size))[:40]} is not a whole number > 0")
    for key in ("models", "simulators"):
        value = d.get(key, [])
        if not isinstance(value, list) or not all(isinstance(x, str) for x in value):
            raise Invalid(f"{key} {one_line(repr(value))[:40]} is not a list of names")
    for key in ("options", "variants"):
        if not isinstance(d.get(key, {}), dict):
            raise Invalid(f"{key} is not an object")
    load = d.get("load", [])
    if not isinstance(load, list) or not all(real(x) for x in load):
        raise Invalid(f"load {one_line(repr(load))[:40]} is not a list of numbers")


def board_of(d: Any) -> Board:
    """A Board from its record (lists back to tuples), checked (check_board)."""
    check_board(d)
    known = {f.name for f in fields(Board)}
    b = Board(**{k: v for k, v in d.items() if k in known})
    b.models, b.simulators = tuple(b.models), tuple(b.simulators)
    b.variants = {k: tuple(v) for k, v in (b.variants or {}).items()}
    b.load = tuple(b.load)
    return b


def row_of(d: dict, where: str = "") -> Row:
    """A Row from its record, checked (check_row). A force curve (force_curve.py) that is
    malformed is dropped, with one line on stderr naming the row (`where`) and why: the row
    then has no force, as a row that hands none."""
    from tissuebench.workflows.leaderboard.force_curve import check_curve

    check_row(d)
    known = {f.name for f in fields(Row)} - {"kind"}  # the kind: its recorded source's
    row = Row(**{k: v for k, v in d.items() if k in known})
    if row.force_curve is not None:
        try:
            check_curve(row.force_curve)
        except (ValueError, TypeError) as exc:
            at = where or f"row {one_line(row.label)[:60]}"
            said = " ".join(str(exc).split())[:160]
            print(
                f"tissuebench leaderboard: {at}: its force curve dropped ({said})",
                file=sys.stderr,
            )
            row.force_curve = None
    return row


def row_fields(row: Row) -> dict:
    """Every field of a Row but its kind, which its source says (row_of)."""
    d = asdict(row)
    d.pop("kind", None)
    return d


def row_record(row: Row) -> dict:
    """A Row as the record holds it: every field (series_hash only where it has one: a user's
    row, model only where its user stated one, folder only on a user's row, and contact and
    force only on a contact case's row, force_curve only where it has one, so that a record of
    our rows reads as before; its
    kind is not kept: its source says it, row_of)."""
    d = row_fields(row)
    if d.get("series_hash") is None:
        d.pop("series_hash", None)
    if not d.get("contact"):
        d.pop("contact", None)
    if d.get("force") is None:
        d.pop("force", None)
    if d.get("force_curve") is None:
        d.pop("force_curve", None)
    if d.get("model") is None:
        d.pop("model", None)
    if d.get("folder") is None:
        d.pop("folder", None)
    return d


def record_of(boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]]) -> dict:
    """leaderboard.json: every case's Board (what renders it: description, truth, its band and
    note, sizes, session, machine), its notes (the run's; the users' refusals are not kept: they
    are read again) and every Row with all its fields (errors in m^gdim or relative, wall times
    in s, truth columns, Pareto flags, error budget, a contact case's row's force curve:
    force_curve.py, so that a render anywhere draws and grades it with no force file)."""
    return {
        "schema": RECORD_SCHEMA,
        "version": RECORD_VERSION,
        "cases": [
            {
                "board": asdict(b),
                "notes": list(notes.get(b.name, [])),
                "rows": [row_record(r) for r in rows[b.name]],
            }
            for b in boards
        ],
    }


def record_text(record: dict) -> str:
    """leaderboard.json's text: the record (record_of) indented by one, but each row's force
    curve's lists of numbers on one line each (one number a line would double its size)."""
    nonce = secrets.token_hex(8)
    held: list[str] = []

    def hold(value) -> str:
        held.append(json.dumps(value, separators=(",", ":")))
        return f"{nonce}:{len(held) - 1}"

    cases = []
    for case in record.get("cases", []):
        rows = []
        for r in case.get("rows", []):
            curve = r.get("force_curve")
            if isinstance(curve, dict):
                held_curve = {k: hold(v) if k != "unit" else v for k, v in curve.items()}
                r = {**r, "force_curve": held_curve}
            rows.append(r)
        cases.append({**case, "rows": rows})
    text = json.dumps({**record, "cases": cases}, indent=1)
    return re.sub(f'"{nonce}:(\\d+)"', lambda m: held[int(m[1])], text) + "\n"


def clone_results() -> Path | None:
    """The results/ folder of the clone tissuebench runs from (an editable install, `make
    setup` or `pip install -e .`: the package's source tree is the repository, whose
    results/ holds the committed leaderboard.json), found from the package's own path; None
    when it holds no record (an installed copy of the package)."""
    from tissuebench.workflows.leaderboard.committed import clone_root

    found = clone_root() / "results"
    return found if (found / RECORD).is_file() else None


def record_folder(out: Path, results: Path | None = None) -> Path:
    """The folder whose leaderboard.json the leaderboard renders from: `results` when given
    (--results; LeaderboardError, one line, when it holds no record), else OUT when it holds
    one, else the clone's results/ (clone_results), else OUT (which has none: the caller says
    so). Wherever the user stands, `--out results` in a folder of their own renders the
    committed record with their rows, written to OUT; the record's folder is only read."""
    if results is not None:
        if not (results / RECORD).is_file():
            raise LeaderboardError(
                f"--results {results}: no leaderboard record ({RECORD}) there; name a folder "
                "that holds one (a clone's results/), or leave --results out"
            )
        return results
    if (out / RECORD).is_file():
        return out
    clone = clone_results()
    return clone if clone is not None else out


Record = tuple[list[Board], dict[str, list[Row]], dict[str, list[str]]]


def read_record(out: Path) -> Record | None:
    """The record OUT/leaderboard.json as (boards, {case: rows}, {case: notes}); None when there
    is none. Every case and row is checked for type and range (check_board, check_row) before
    anything is made of it: LeaderboardError, one line naming the first field that fails, when
    it cannot be read (nested too deep, too large, not JSON). Rank 0."""
    path = out / RECORD
    if not path.is_file():
        return None
    redo = f"`tissuebench leaderboard --out {out} --rerun` writes a new one"
    try:
        if path.stat().st_size > MAX_RECORD:
            raise ValueError(f"larger than {MAX_RECORD // 2**20} MB")
        text = path.read_text()
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        said = " ".join(str(exc).split())[:200]
        raise LeaderboardError(
            f"{path}: cannot be read ({type(exc).__name__}: {said}); {redo}"
        ) from None
    return parse_record(text, str(path), redo)


COMMITTED_RECORD = f"results/{RECORD}"  # the record as the clone's git holds it


def committed_record(root: Path | None = None) -> tuple[Record | None, str]:
    """(the record results/leaderboard.json as committed at git's HEAD of the clone `root`
    (default: the one tissuebench runs from), checked as any record (parse_record), "") or
    (None, why there is none, one line: no git, not a clone, none committed, not readable)."""
    from tissuebench.workflows.leaderboard.committed import clone_root, head_text

    root = clone_root() if root is None else root
    text, why = head_text(COMMITTED_RECORD, root)
    if text is None:
        return None, why
    try:
        return parse_record(text, f"{root / COMMITTED_RECORD} (as committed)", "commit one"), ""
    except LeaderboardError as exc:
        return None, str(exc)


def parse_record(text: str, path: str, redo: str) -> Record:
    """The record in `text` (read from `path`, named in errors; `redo`: how to write a new
    one) as read_record returns it."""
    where = ""
    try:
        if len(text) > MAX_RECORD:
            raise ValueError(f"larger than {MAX_RECORD // 2**20} MB")
        doc = json.loads(text)
        if not isinstance(doc, dict):
            raise ValueError("not an object")
        if doc.get("schema") != RECORD_SCHEMA or doc.get("version") != RECORD_VERSION:
            raise ValueError(f"not a {RECORD_SCHEMA} record of version {RECORD_VERSION}")
        if not isinstance(doc.get("cases"), list):
            raise ValueError("no list of cases")
        boards: list[Board] = []
        rows: dict[str, list[Row]] = {}
        notes: dict[str, list[str]] = {}
        for i, case in enumerate(doc["cases"]):
            where = f"case {i + 1}"
            if not isinstance(case, dict) or not isinstance(case.get("rows"), list):
                raise ValueError("not an object with a list of rows")
            board = board_of(case.get("board"))
            where = f"case {one_line(board.name)[:60]}"
            if board.name in rows:
                raise ValueError("recorded twice")
            boards.append(board)
            rows[board.name] = []
            for j, r in enumerate(case["rows"]):
                where = f"case {one_line(board.name)[:60]}, row {j + 1}"
                if isinstance(r, dict) and isinstance(r.get("label"), str):
                    where += f" ({one_line(r['label'])[:60]})"
                rows[board.name].append(row_of(r, where))
            where = f"case {one_line(board.name)[:60]}"
            found = case.get("notes", [])
            if not isinstance(found, list) or not all(isinstance(n, str) for n in found):
                raise ValueError("its notes are not a list of texts")
            notes[board.name] = list(found)
    except RecursionError:
        raise LeaderboardError(f"{path}: cannot be read (nested too deep); {redo}") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
        said = " ".join(str(exc).split())[:200]
        at = f"{where}: " if where else ""
        raise LeaderboardError(
            f"{path}: cannot be read ({at}{type(exc).__name__}: {said}); {redo}"
        ) from None
    return boards, rows, notes


# a row's fields that a render sets anew over all the rows of its case (users' included)
REMARKED = ("pareto", "truth_pareto")


def _as_graded(board: Board, rows: list[Row], notes: list[str]) -> str:
    """A case's board, notes and rows that are not a user's or the frontier's (which a render
    grades or reads again), but for the flags a render marks anew (REMARKED), as one text."""
    kept = [
        {k: v for k, v in row_record(r).items() if k not in REMARKED}
        for r in rows
        if r.kind in (Kind.OURS, Kind.SIMULATOR)
    ]
    return json.dumps([asdict(board), notes, kept], sort_keys=True)


def with_committed_rows(
    record: Record, committed: Record | None, why: str, say
) -> tuple[Record, list[str]]:
    """`record` (read from OUT or --results) with the board, notes and rows of ours and the
    simulators of each case taken from `committed` (the record as the clone's git holds it:
    committed_record), so that no grade, force or time of ours or a simulator's comes from a
    file anyone can write (issue 60); a user's rows stay (a render grades them again from their
    series) and the frontier's are read again anyway. A case whose rows were not as committed
    is said in one line to `say`; so is a case `committed` lacks (not committed yet: its rows
    as read), and a record read with no committed one to hold it against (`why`). Returns the
    record and the cases whose rows were not as committed."""
    if committed is None:
        say(
            f"the record's rows of ours and the simulators are shown as read, not held against "
            f"a committed record ({why})"
        )
        return record, []
    boards, rows, notes = record
    held_boards, held_rows, held_notes = committed
    held = {b.name: b for b in held_boards}
    out_boards, out_rows, out_notes, changed = [], {}, {}, []
    for board in boards:
        name = board.name
        if name not in held:
            say(f"{name}: not in the committed record; its rows of ours are shown as read")
            out_boards.append(board)
            out_rows[name], out_notes[name] = rows[name], notes[name]
            continue
        if _as_graded(board, rows[name], notes[name]) != _as_graded(
            held[name], held_rows[name], held_notes[name]
        ):
            changed.append(name)
            say(
                f"{name}: the record's rows of ours and the simulators are not as committed; "
                f"shown as committed (git HEAD's {COMMITTED_RECORD}: commit a rerun's record "
                "for its rows to be shown)"
            )
        users = [r for r in rows[name] if r.kind is Kind.USER]
        theirs = [r for r in held_rows[name] if r.kind in (Kind.OURS, Kind.SIMULATOR)]
        out_boards.append(held[name])
        out_rows[name], out_notes[name] = theirs + users, list(held_notes[name])
    return (out_boards, out_rows, out_notes), changed
