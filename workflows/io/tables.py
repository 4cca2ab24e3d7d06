"""Every CSV file of tissuebench, written and read here: metrics.csv (one row per run and
step: the time in s, every metric of METRICS, the step's status), tip.csv (the probe point's
displacement in m), and any table of rows: a study's (frontier.csv, mesh-sensitivity.csv;
write_rows, append_row), truth.csv and leaderboard.csv (write_table), read back by read_rows.
`CSVError` is the error of a file that is not CSV."""

from __future__ import annotations

import csv
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from tissuebench.metrics.compare import columns
from tissuebench.metrics.table import METRICS

CSVError = csv.Error  # a file that the csv module cannot read as CSV


def write_metrics_csv(
    path: Path,
    times: np.ndarray,
    curves: dict[str, dict[str, np.ndarray]],
    status: dict[str, list[str]],
) -> None:
    """metrics.csv: for each run label, one row per step; `status` says ok, diverged,
    reference diverged or missing."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns())
        for label, curve in curves.items():
            for i, t in enumerate(times):
                writer.writerow(
                    [
                        label,
                        i,
                        repr(float(t)),
                        *(repr(float(curve[n][i])) for n in METRICS),
                        status[label][i],
                    ]
                )


def write_tip_csv(path: Path, times: np.ndarray, tips: dict[str, np.ndarray]) -> None:
    """tip.csv: for each run label, the probe point's displacement (m) at every step it has."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        d = next(iter(tips.values())).shape[1]
        writer.writerow(["algorithm", "step", "time", *("u_" + "xyz"[k] for k in range(d))])
        for label, tip in tips.items():
            for i, t in enumerate(times[: len(tip)]):
                writer.writerow([label, i, repr(float(t)), *(repr(float(x)) for x in tip[i])])


def write_contact_csv(path: Path, times: np.ndarray, contacts: dict[str, np.ndarray]) -> None:
    """contact.csv (SPEC 12): for each run label, the needle's force per unit thickness (N/m,
    x and y) and the interpenetration (m) at every step it has."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["algorithm", "step", "time", "force_x", "force_y", "interpenetration"])
        for label, rows in contacts.items():
            for i, t in enumerate(times[: len(rows)]):
                writer.writerow([label, i, repr(float(t)), *(repr(float(x)) for x in rows[i])])


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
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: _cell(row[k]) if empty_nan else row[k] for k in columns})


def write_table(path: Path, columns: Sequence[str], rows: Iterable[Sequence[object]]) -> None:
    """A CSV file of a header, `columns`, and one line for each row of cells (each cell as
    str() writes it, None as an empty cell)."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        writer.writerows(rows)


def append_row(path: Path, row: dict, columns: tuple[str, ...]) -> None:
    """Add one row to a CSV file of `columns`, its header first if the file is new (a study
    that keeps each result as it ends)."""
    new = not Path(path).is_file()
    with open(path, "a", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        if new:
            writer.writeheader()
        writer.writerow({k: _cell(row[k]) for k in columns})


def read_rows(path: Path, errors: str = "strict") -> list[dict[str, str]]:
    """A CSV file's rows as {column: text}, keyed by its header; `errors` as open() takes it
    ("replace": undecodable bytes become U+FFFD). OSError, CSVError or UnicodeDecodeError for
    a file that cannot be read."""
    with open(path, newline="", errors=errors) as f:
        return list(csv.DictReader(f))


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
