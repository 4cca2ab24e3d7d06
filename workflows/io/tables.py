"""Every CSV file of tissuebench, written and read here: metrics.csv (one row per run and
step: the time in s, every metric of METRICS, the step's status), tip.csv (the probe point's
displacement in m), and any table of rows: a study's (frontier.csv, mesh-sensitivity.csv;
write_rows, append_row), truth.csv and leaderboard.csv (write_table), read back by read_rows.
`CSVError` is the error of a file that is not CSV.

A text cell that a spreadsheet would take for a formula (it begins with = + - @, a tab or a
carriage return, after any apostrophes: a label `=HYPERLINK(...)` or `-2+3+cmd|...`) is written
with a leading apostrophe, which read_rows takes off again (so the file reads back as the text
it was given); numbers, and text that is a number (`-0.25`, `-inf`), are written as they are.
Every file is written under a staging name beside it and renamed into place when complete
(append_row too), so that a full disk or a kill leaves the old file whole, or none."""

from __future__ import annotations

import csv
import io
import os
import re
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import ArrayLike

from tissuebench.metrics.compare import columns
from tissuebench.metrics.table import METRICS

CSVError = csv.Error  # a file that the csv module cannot read as CSV
FORMULA = ("=", "+", "-", "@", "\t", "\r")  # what a spreadsheet reads as the start of a formula
NUMBER = re.compile(
    r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:inf|nan)", re.IGNORECASE
)


def guarded(x: object) -> object:
    """A cell as written: text whose first character after any apostrophes is one of FORMULA
    gets one more apostrophe in front (no spreadsheet evaluates it); numbers and text that is
    a number (NUMBER) are as they are; None stays None (an empty cell)."""
    if x is None or isinstance(x, (int, float, np.number)):
        return x
    text = str(x)
    if text.lstrip("'")[:1] in FORMULA and not NUMBER.fullmatch(text):
        return "'" + text
    return text


def unguarded(cell: str | None) -> str | None:
    """The text a cell was given, from the cell as `guarded` wrote it: one leading apostrophe
    off where guarded put it (the cell's first character after its apostrophes is one of
    FORMULA), the cell itself otherwise."""
    if cell is not None and cell[:1] == "'" and cell.lstrip("'")[:1] in FORMULA:
        return cell[1:]
    return cell


def _writer(f: IO[str]):
    """A csv.writer whose rows are guarded cell by cell."""
    writer = csv.writer(f)

    class Guarded:
        def writerow(self, row: Iterable[object]) -> None:
            writer.writerow([guarded(x) for x in row])

        def writerows(self, rows: Iterable[Iterable[object]]) -> None:
            for row in rows:
                self.writerow(row)

    return Guarded()


@contextmanager
def _staged(path: Path, keep: bool = False) -> Iterator[IO[str]]:
    """A text file open for writing under a staging name beside `path` (with the old file's
    content first if `keep`), renamed to `path` when the block ends without an error; on an
    error (a full disk, a signal) the staging file is removed and `path` is as it was."""
    path = Path(path)
    tmp = path.with_name(f".tissuebench-{path.name}.{os.getpid()}.staged")
    try:
        with open(tmp, "w", newline="") as f:
            if keep and path.is_file():
                with open(path, newline="") as old:
                    f.write(old.read())
            yield f
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_metrics_csv(
    path: Path,
    times: np.ndarray,
    curves: dict[str, dict[str, np.ndarray]],
    status: dict[str, list[str]],
    extra: dict[str, dict[str, np.ndarray]] | None = None,
) -> None:
    """metrics.csv: for each run label, one row per step; `status` says ok, diverged,
    reference diverged or missing. `extra` {label: {column: values per step}}: columns after
    the status (a contact reference's interpenetration and force, SPEC 12; the same columns
    for every label), none when it is None."""
    names = list(next(iter(extra.values()))) if extra else []
    with _staged(path) as f:
        writer = _writer(f)
        writer.writerow([*columns(), *names])
        for label, curve in curves.items():
            more = (extra or {}).get(label, {})
            for i, t in enumerate(times):
                writer.writerow(
                    [
                        label,
                        i,
                        repr(float(t)),
                        *(repr(float(curve[n][i])) for n in METRICS),
                        status[label][i],
                        *(repr(float(more[n][i])) for n in names),
                    ]
                )


def write_tip_csv(path: Path, times: np.ndarray, tips: dict[str, np.ndarray]) -> None:
    """tip.csv: for each run label, the probe point's displacement (m) at every step it has."""
    with _staged(path) as f:
        writer = _writer(f)
        d = next(iter(tips.values())).shape[1]
        writer.writerow(["algorithm", "step", "time", *("u_" + "xyz"[k] for k in range(d))])
        for label, tip in tips.items():
            for i, t in enumerate(times[: len(tip)]):
                writer.writerow([label, i, repr(float(t)), *(repr(float(x)) for x in tip[i])])


def write_contact_csv(path: Path, times: np.ndarray, contacts: dict[str, np.ndarray]) -> None:
    """contact.csv (SPEC 12, 13): for each run label, the force on the tool (per unit thickness
    in 2D, N/m, x and y; in N in 3D, x, y and z) and the interpenetration (m) at every step it
    has (each run's rows: its steps, gdim + 1)."""
    width = next((np.shape(rows)[-1] for rows in contacts.values() if np.ndim(rows) == 2), 3)
    forces = [f"force_{c}" for c in "xyz"[: width - 1]]
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["algorithm", "step", "time", *forces, "interpenetration"])
        for label, rows in contacts.items():
            for i, t in enumerate(times[: len(rows)]):
                writer.writerow([label, i, repr(float(t)), *(repr(float(x)) for x in rows[i])])


FORCE_COLUMNS = ("time", "force_x", "force_y")  # a candidate's needle force (SPEC 12)
FORCE_Z = "force_z"  # and its third component, for a 3D tool (SPEC 13)


def write_force_csv(path: Path, times: np.ndarray, force: np.ndarray) -> None:
    """A tool's force series as a candidate hands it to compare (`--needle-force`, SPEC 12,
    13): columns time (s), force_x, force_y (and force_z for a 3D tool): the force that the
    tissue exerts on the tool, N/m per unit thickness in 2D and N in 3D, one row per step;
    times (steps,), force (steps, 2) or (steps, 3)."""
    force = np.asarray(force, dtype=float)
    width = 3 if force.ndim == 2 and force.shape[1] == 3 else 2
    force = force.reshape(len(times), width)
    with _staged(path) as f:
        writer = _writer(f)
        writer.writerow(FORCE_COLUMNS + ((FORCE_Z,) if width == 3 else ()))
        for t, row in zip(times, force, strict=True):
            writer.writerow([repr(float(t)), *(repr(float(x)) for x in row)])


def read_force_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A tool's force series written as write_force_csv says: (times (steps,) in s, force
    (steps, 2) in N/m, or (steps, 3) in N where it has force_z). ValueError, in one line, for a
    path that is no regular file (a FIFO, a folder: never opened, so never waited on), a file
    that is not CSV (a cell beyond the csv module's limit) or without those columns, or with a
    cell that is not a finite number."""
    path = Path(path)
    if not path.is_file():
        what = "a folder" if path.is_dir() else "not a regular file" if path.exists() else "missing"
        raise ValueError(f"{path}: a needle force is a CSV file, and this is {what}")
    try:
        rows = read_rows(path)
    except (CSVError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: not a readable CSV file ({err})") from None
    if not rows or any(c not in rows[0] for c in FORCE_COLUMNS):
        raise ValueError(f"{path}: a needle force needs the columns {', '.join(FORCE_COLUMNS)}")
    columns = FORCE_COLUMNS + ((FORCE_Z,) if FORCE_Z in rows[0] else ())
    try:
        table = np.array([[float(r[c] or "nan") for c in columns] for r in rows])
    except ValueError as err:
        raise ValueError(f"{path}: a needle force cell is not a number ({err})") from None
    if not np.isfinite(table).all():
        raise ValueError(f"{path}: a needle force cell is empty or not finite")
    return table[:, 0], table[:, 1:]


def _cell(x: object) -> object:
    """A CSV cell: empty for None or NaN."""
    return "" if x is None or (isinstance(x, float) and x != x) else x


def write_rows(
    path: Path,
    rows: list[dict],
    columns: tuple[str, ...] | None = None,
    *,
    empty_nan: bool = True,
) -> None:
    """Rows as a CSV file: a header of `columns` (default: the first row's keys), then one
    line a row, None as an empty cell, and NaN too unless not `empty_nan` (then "nan")."""
    columns = tuple(columns or (rows[0] if rows else ()))
    with _staged(path) as f:
        writer = _writer(f)
        writer.writerow(columns)
        for row in rows:
            writer.writerow([_cell(row[k]) if empty_nan else row[k] for k in columns])


def write_table(path: Path, columns: Sequence[str], rows: Iterable[Sequence[object]]) -> None:
    """A CSV file of a header, `columns`, and one line for each row of cells (each cell as
    str() writes it, None as an empty cell)."""
    with _staged(path) as f:
        writer = _writer(f)
        writer.writerow(columns)
        writer.writerows(rows)


def append_row(path: Path, row: dict, columns: tuple[str, ...]) -> None:
    """Add one row to a CSV file of `columns`, its header first if the file is new (a study
    that keeps each result as it ends). The file is written again whole under a staging name
    and renamed, so that it never ends in half a row."""
    new = not Path(path).is_file()
    with _staged(path, keep=True) as f:
        writer = _writer(f)
        if new:
            writer.writerow(columns)
        writer.writerow([_cell(row[k]) for k in columns])


def read_rows(path: Path, errors: str = "strict") -> list[dict[str, str]]:
    """A CSV file's rows as {column: text}, keyed by its header; `errors` as open() takes it
    ("replace": undecodable bytes become U+FFFD). OSError, CSVError or UnicodeDecodeError for
    a file that cannot be read. Cells come back as they were given to the writers here (the
    apostrophe of a guarded cell taken off); a row cut short has None for its missing cells."""
    with open(path, newline="", errors=errors) as f:
        text = f.read()
    return rows_of(text)


def rows_of(text: str) -> list[dict[str, str]]:
    """A CSV text's rows, as read_rows reads a file's (CSVError for text that is not CSV)."""
    rows = csv.DictReader(io.StringIO(text, newline=""))
    if "'" not in text:  # no cell was guarded (the common case: numbers and names)
        return list(rows)
    return [{_unguarded_cell(k): _unguarded_cell(v) for k, v in r.items()} for r in rows]


def ends_whole(path: Path) -> bool:
    """Whether a file is empty or ends with a line's end (the writers here end every row with
    one: a file that does not was cut mid-row, by a kill or a full disk)."""
    with open(path, "rb") as f:
        if f.seek(0, os.SEEK_END) == 0:
            return True
        f.seek(-1, os.SEEK_END)
        return f.read(1) == b"\n"


def _unguarded_cell(v: Any) -> Any:
    """unguarded for a DictReader key or value: text, None, or the list of a row's extra
    cells."""
    if isinstance(v, list):
        return [unguarded(x) for x in v]
    return unguarded(v) if isinstance(v, str) else v


def read_curves(path: Path) -> tuple[np.ndarray, dict[str, dict[str, np.ndarray]]]:
    """(times in s, {label: {"time" or metric: values per step}}) from a metrics.csv; the times
    are those of its first run."""
    curves: dict[str, dict[str, list[float]]] = {}
    for r in read_rows(path):
        c = curves.setdefault(r["algorithm"], {"time": [], **{m: [] for m in METRICS}})
        c["time"].append(float(r["time"]))
        for m in METRICS:
            c[m].append(float(r[m]))
    arrays = {label: {k: np.array(v) for k, v in c.items()} for label, c in curves.items()}
    times = next(iter(arrays.values()))["time"]
    return times, arrays


def read_tips(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{label: (times in s, u_y in m)} from a tip.csv."""
    tips: dict[str, tuple[list[float], list[float]]] = {}
    for r in read_rows(path):
        t, y = tips.setdefault(r["algorithm"], ([], []))
        t.append(float(r["time"]))
        y.append(float(r["u_y"]))
    return {label: (np.array(t), np.array(y)) for label, (t, y) in tips.items()}


def spans_decades(values: ArrayLike) -> bool:
    """True if the positive finite values span a factor 10 or more (a log axis then reads
    better)."""
    values = np.asarray(values)
    positive = values[np.isfinite(values) & (values > 0)]
    return len(positive) > 1 and positive.max() >= 10 * positive.min()
