"""A contact case's row's needle force as the record carries it (Row.force_curve; issues 59,
60): {"times": [t_i, ...] (s), "force": [[F_x, F_y(, F_z)], ...], "unit": "N/m" (2 columns,
the needle in the plane) or "N" (3 columns, the capsule in 3D)}, each number rounded to
DIGITS significant digits. A run of this session hands its force file once, where the run made
it (contact.our_forces, contact.external_contact, checks.user_rows: read_curve); every reader
of a row's force takes it from the curve alone (row_force), never from a path, so that a
render from any folder, or a fresh clone with no force file, draws and grades every recorded
run's force, and no file put at a recorded path is taken as ours. A user's row's grades are
kept by its curve's content hash too (force_hash)."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from tissuebench.workflows.leaderboard.row import Row, one_line, real

DIGITS = 9  # significant digits kept of each time and force (301 steps x 3: ~12 kB a row)
UNITS = {2: "N/m", 3: "N"}  # the force's unit by its columns (write_force_csv)
MAX_STEPS = 1_000_000  # a curve longer than this is not ours (ours: a few hundred steps)


def rounded(x: float) -> float:
    return float(f"{float(x):.{DIGITS}g}")


def curve_of(times, force) -> dict:
    """A force series (times (steps,) s, force (steps, 2) N/m or (steps, 3) N) as the record
    carries it, rounded to DIGITS significant digits; ValueError (one line) unless it is a
    curve check_curve takes."""
    force = np.asarray(force, dtype=float)
    times = np.asarray(times, dtype=float)
    if force.ndim != 2 or force.shape[1] not in UNITS or len(times) != len(force):
        raise ValueError(f"a force of shape {force.shape} at {len(times)} times is not a curve")
    curve = {
        "times": [rounded(t) for t in times],
        "force": [[rounded(x) for x in step] for step in force],
        "unit": UNITS[force.shape[1]],
    }
    check_curve(curve)
    return curve


def read_curve(path: Path | str) -> dict:
    """The force file a run of this session wrote or handed (io/tables.py read_force_csv) as
    a curve (curve_of); ValueError, in one line, when it cannot be read."""
    from tissuebench.workflows.io.tables import read_force_csv

    times, force = read_force_csv(Path(path))
    return curve_of(times, force)


def check_curve(curve) -> None:
    """ValueError, in one line, unless `curve` is an object with times (a list of finite
    numbers), force (as many lists of 2 or 3 finite numbers, all of one length) and the unit
    of that many columns (UNITS)."""

    def numbers(values, what: str) -> None:
        if not isinstance(values, list) or not all(real(x) and math.isfinite(x) for x in values):
            raise ValueError(f"its {what} {one_line(repr(values))[:40]} are not finite numbers")

    if not isinstance(curve, dict) or set(curve) != {"times", "force", "unit"}:
        raise ValueError(f"{one_line(repr(curve))[:40]} is not an object of times, force, unit")
    times, force, unit = curve["times"], curve["force"], curve["unit"]
    numbers(times, "times")
    if not 0 < len(times) <= MAX_STEPS:
        raise ValueError(f"it has {len(times)} times, not 1 to {MAX_STEPS}")
    if not isinstance(force, list) or len(force) != len(times):
        raise ValueError(f"its force is not a list of {len(times)} steps, one a time")
    width = len(force[0]) if isinstance(force[0], list) else 0
    if width not in UNITS:
        raise ValueError(f"its force has {width} components, not 2 or 3")
    for step in force:
        numbers(step, "force's components")
        if len(step) != width:
            raise ValueError(f"its force's steps are not all of {width} components")
    if unit != UNITS[width]:
        raise ValueError(f"its unit {one_line(repr(unit))[:20]} is not {UNITS[width]}")


def row_force(row: Row) -> tuple[np.ndarray, np.ndarray] | None:
    """A row's needle force, (times (steps,) s, force (steps, 2) N/m or (steps, 3) N), from
    the curve it carries (the record's, or the one its run of this session handed); None
    when it carries none. Its force file (row.force) is never read here."""
    curve = row.force_curve
    if curve is None:
        return None
    return np.asarray(curve["times"], dtype=float), np.asarray(curve["force"], dtype=float)


def force_hash(row: Row) -> str | None:
    """The SHA-256 of a row's force curve (its canonical JSON), None when it carries none: a
    user's row's cached grades are of its series and of this force."""
    found, curve = row_force(row), row.force_curve
    if found is None or curve is None:
        return None
    times, force = found  # as floats: the same curve hashes the same, however it was written
    digest = hashlib.sha256(f"{force.shape}:{curve['unit']}:".encode())
    for values in (times, force):
        digest.update(np.ascontiguousarray(values, dtype="<f8").tobytes())
    return digest.hexdigest()
