"""A contact case's two columns (SPEC 12) on the leaderboard: each row's force error and
interpenetration (m).

When a case runs (runs.py), ours take theirs from their run (the interpenetration our
Measures recorded; the force from contact.csv, kept as a force file per row in
leaderboard/CASE/forces/) and the simulators' from compare (the interpenetration from their
series; the force error when the simulator hands its force, ExternalRun.force), both against our
implicit reference's force. Each row carries its force as a curve (Row.force_curve,
force_curve.py), which the record keeps: the file is read once, where its run of this session
made it, and never again. Where the case's truth is graded (grading.py), every row's force
curve is graded again against the truth's force (impulse-averaged: workflows/contact/study.py).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from tissuebench.metrics.contact import force_error
from tissuebench.workflows.io.tables import read_rows, write_force_csv
from tissuebench.workflows.leaderboard.force_curve import curve_of, read_curve, row_force
from tissuebench.workflows.leaderboard.rows import Row

NOT_GIVEN = "not given: the run hands no needle force"
NOT_RECORDED = "its force is not recorded (its force file could not be read where it ran)"


def graded_components(components: int) -> list[int] | slice:
    """The force components graded (SPEC 12, 13): both of a 2D tool's (N/m); of a 3D tool's
    (N) the axial one, z (the capsule's axis): F_x and F_y are zero for the exact axisymmetric
    answer, a candidate's a symmetry error, reported, not graded."""
    return [2] if components == 3 else slice(None)


def unfinished(row: Row) -> bool:
    """A row whose run did not finish: its force error over the steps it has would flatter
    it, so it has none (its status says why)."""
    if row.status == "ok":
        return False
    row.contact["force_error"] = None
    row.contact["force_error_how"] = f"none: the run did not finish ({row.status})"
    return True


def number(x) -> float | None:
    """A finite float, else None."""
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None


def slug(label: str) -> str:
    """A file name for a row's label ("implicit+neo-hookean" -> "implicit+neo-hookean",
    "calculix:C3D8" -> "calculix-C3D8")."""
    return "".join(c if c.isalnum() or c in "+-_." else "-" for c in label)


def our_forces(folder: Path, rows: list[Row], forces: Path) -> None:
    """Ours: each row's needle force from its case folder's contact.csv, written as a force
    file in `forces` (row.force), carried as its curve (row.force_curve, as the record keeps
    it) and graded, as that curve, against the reference row's; its
    interpenetration (m) as our run recorded it (summary.json's contact readings are in
    row.contact already, or contact.csv's largest)."""
    table = read_rows(folder / "contact.csv") if (folder / "contact.csv").is_file() else []
    forces.mkdir(parents=True, exist_ok=True)
    mine: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
    curves: dict[str, dict] = {}  # each label's force as the record keeps it (rounded)
    for label in dict.fromkeys(r["algorithm"] for r in table):
        got = [r for r in table if r["algorithm"] == label]
        columns = ("force_x", "force_y") + (("force_z",) if got and got[0].get("force_z") else ())
        times = np.array([float(r["time"]) for r in got])
        force = np.array([[float(r[c]) for c in columns] for r in got])
        mine[label] = (times, force, np.array([float(r["interpenetration"]) for r in got]))
        curves[label] = curve_of(times, force)
    reference = next((r.label for r in rows if r.reference), None)
    for row in rows:
        if row.label not in mine:
            row.contact = {
                "force_error": None,
                "interpenetration_max": None,
                "force_error_how": "not measured: its run wrote no contact readings",
            }
            continue
        times, force, depth = mine[row.label]
        path = forces / f"{slug(row.label)}.csv"
        write_force_csv(path, times, force)
        row.force, row.force_curve = str(path), curves[row.label]
        against = curves.get(reference or "")
        graded = graded_components(force.shape[1])
        error = None
        if against is not None:  # graded as the record keeps both: the same numbers later
            ours, theirs = np.asarray(curves[row.label]["force"]), np.asarray(against["force"])
            error = number(force_error(ours[:, graded], theirs[:, graded]))
        row.contact = {
            "force_error": 0.0 if row.reference else error,
            "interpenetration_max": number(depth.max()) if len(depth) else None,
            "force_error_how": f"against our {reference}'s force (contact.csv)",
        }
        unfinished(row)


def external_contact(row: Row, run: Mapping[str, Any], force: str | None) -> None:
    """A simulator's row: compare's readings of its variant (`run`, its external summary's
    entry) and its force file (None: it handed none), read here, as its run of this session
    wrote it, into the row's force curve (none where it cannot be read)."""
    row.force = force
    try:
        row.force_curve = read_curve(force) if force else None
    except ValueError:
        row.force_curve = None
    row.contact = {
        "force_error": number(run.get("force_error")),
        "interpenetration_max": number(run.get("interpenetration_max")),
        "force_error_how": "against our implicit reference's force" if force else NOT_GIVEN,
    }
    unfinished(row)


def grade_forces(rows: list[Row], truth_force: np.ndarray, case: str, own: float) -> None:
    """Every row with a force graded against the truth's force (steps, 2) N/m, from the curve
    it carries (row_force: never a file); a row that handed a force file but carries no curve
    keeps its force error against our reference, and says why."""
    for row in rows:
        if not row.contact:
            continue
        if not (row.force or row.force_curve) or unfinished(row):
            continue
        found = row_force(row)
        if found is None:
            row.contact["force_error_how"] = (
                f"{row.contact.get('force_error_how')}; not graded against the truth: "
                f"{NOT_RECORDED}"
            )
            continue
        _, force = found
        graded = graded_components(force.shape[1])
        row.contact["force_error"] = number(force_error(force[:, graded], truth_force[:, graded]))
        row.contact["force_error_how"] = (
            f"against the truth {case}'s force (impulse-averaged; its own error {own:.3g})"
        )


_FORCES: dict = {}  # truth case -> its TruthForce, once computed in this process


def truth_force(case: str, truth=None):
    """The needle force of a contact truth (workflows/contact/study.py TruthForce: averaged,
    with its own error), from `truth` (TruthSamples) or the cache (None when not computed
    here). Rank 0."""
    if case not in _FORCES:
        if truth is None:
            from mpi4py import MPI

            from tissuebench.solvers.truth.store import load_cached

            truth = load_cached(case, comm=MPI.COMM_SELF)
            if truth is None:
                return None
        from tissuebench.workflows.contact.study import truth_force as of_truth

        _FORCES[case] = of_truth(truth)
    return _FORCES[case]


def user_contact(board, rows: list[Row], row: Row, series, truth=None) -> None:
    """A user's row on a contact case, from what the leaderboard reads itself: its
    interpenetration from its series (metrics/contact.py), and its force error from the force
    its compare graded (rows.user_force, checked against its hash; carried as its curve,
    row.force_curve, from when its folder was read) against the truth's
    force where the truth is in the cache and converged (`truth`: its TruthSamples, where
    loaded already), else against our reference row's."""
    from tissuebench.meshes import get_entry
    from tissuebench.metrics.contact import interpenetration_curve

    scale = float(board.options.get("load_scale", 1.0))
    make = get_entry(board.benchmark).tool
    assert make is not None  # a contact board's benchmark
    try:
        curve = interpenetration_curve(
            series.points, series.displacements, series.times, make(load_scale=scale)
        )
        finite = curve[np.isfinite(curve)]
        depth = number(finite.max()) if len(finite) else None
    except ValueError:  # no node on the contact edge
        depth = None
    row.contact = {"force_error": None, "interpenetration_max": depth}
    if not (row.force or row.force_curve):
        row.contact["force_error_how"] = NOT_GIVEN + " (compare --needle-force FILE.csv)"
        return
    if unfinished(row):
        return
    found = row_force(row)
    if found is None:
        row.contact["force_error_how"] = f"not graded: {NOT_RECORDED}"
        return
    _, force = found
    yardstick = truth_force(board.truth, truth) if board.truth else None
    if yardstick is not None and math.isfinite(yardstick.own_error):
        row.contact["force_error"] = number(force_error(force, yardstick.force))
        row.contact["force_error_how"] = (
            f"against the truth {board.truth}'s force (impulse-averaged; its own error "
            f"{yardstick.own_error:.3g})"
        )
        return
    reference = next((r for r in rows if r.reference and row_force(r) is not None), None)
    recorded = row_force(reference) if reference is not None else None
    if reference is None or recorded is None:
        row.contact["force_error_how"] = "not graded: no force of our reference is recorded"
        return
    theirs = recorded[1]
    row.contact["force_error"] = number(force_error(force, theirs))
    row.contact["force_error_how"] = f"against our {reference.label}'s force"
