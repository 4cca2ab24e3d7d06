"""compare against a contact reference (SPEC 12): what the reference's needle is and its force,
and the candidate's two contact readings, the interpenetration (from its own series:
metrics/contact.py) and, when it hands its needle force (`--needle-force FILE.csv`, io/tables.py
read_force_csv), the force error against the reference's force.

The reference's force: a truth's (study.truth_force: impulse-averaged, with its own error); our
run folder's (its contact.csv, the run of the reference file's name); an export's
(reference.contact.force of STEM.json beside STEM.reference.xdmf, or of benchmark.json beside
the reference.xdmf that the external runner writes).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tissuebench.core.errors import UserError
from tissuebench.meshes import get_entry, in_contact
from tissuebench.meshes.tools import Tool
from tissuebench.metrics.contact import (
    force_error,
    interpenetration_curve,
    surface_interpenetration_curve,
)

TIME_TOLERANCE = 1e-5  # of max(|t|, h): compare's time stamps match to six printed digits
NOT_GIVEN = (
    "force error: not given (no --needle-force FILE.csv: the candidate's needle force, columns "
    "time, force_x, force_y in s and N/m; a 3D tool's with force_z, in N)"
)
# summary.json's `metrics` entries of a contact reference
CONTACT_METRICS = {
    "force_error": {
        "symbol": "e_F",
        "unit": "1",
        "meaning": "max over the steps of |F - F_ref| / max |F_ref|, F the needle force per "
        "unit thickness (N/m) that the candidate hands (--needle-force); for a 3D tool its "
        "axial component (N); null when not given",
    },
    "interpenetration_max": {
        "symbol": "d_max",
        "unit": "m",
        "meaning": "the largest -g_n over the candidate's deformed right edge (its nodes and "
        "9 points a segment between them), or for a 3D tool over its deformed faces on the "
        "contact surface (7 points an edge), and the steps",
    },
}


class ContactGradingError(UserError):
    """A needle force that compare cannot take (one line, exit status 2)."""


@dataclass
class ContactReference:
    """A contact reference: its needle's load scale s (c(t) = c0 + s g(t)), its force (steps,
    2) N/m at t_i = i h (None: it states none), where that force comes from (a few words), its
    own relative error (a truth's; None for a run of ours) and its benchmark."""

    load_scale: float
    force: np.ndarray | None
    source: str
    own_error: float | None = None
    benchmark: str = ""  # the benchmark it poses (its entry's tool: meshes/tools/)

    @functools.cached_property
    def tool(self) -> Tool:
        """The benchmark's tool at the reference's load scale (meshes/tools/), built once."""
        make = get_entry(self.benchmark).tool
        assert make is not None  # a contact benchmark
        return make(load_scale=self.load_scale)

    def centre(self, t: float) -> np.ndarray:
        """The needle's centre c(t) (m) at t (s)."""
        return self.tool.centre(t)


@dataclass
class ContactGrades:
    """A candidate's contact readings: interpenetration (m) at each step of the grading's
    times (NaN where not measured), its force (steps, 2) N/m on those times (None: not
    given), the force error (NaN: not given or not comparable), the largest interpenetration
    (m; NaN when no step was measured), what the force was graded against, and that force's
    own relative error (a truth's; None for a run of ours)."""

    interpenetration: np.ndarray
    force: np.ndarray | None
    force_error: float
    interpenetration_max: float
    force_source: str
    own_error: float | None = None  # the reference force's own relative error (a truth's)
    force_file: str | None = None  # the candidate's force file, absolute (None: not given)
    force_unit: str = "N/m"  # the tool's (meshes/tools/): N/m in 2D, N in 3D

    def summaries(self) -> dict[str, str]:
        """One line each: the interpenetration, and the force error or why it is not given."""
        d = self.interpenetration_max
        lines = {"interpenetration": f"interpenetration interpenetration_max: {d:.6g} m"}
        if self.force is None:
            lines["force error"] = NOT_GIVEN
        else:
            n, every = len(self.force), len(self.interpenetration)
            part = f"steps 0..{n - 1} of 0..{every - 1}, " if n < every else ""
            lines["force error"] = (
                f"force error force_error: {self.force_error:.6g} ({part}against "
                f"{self.force_source})"
            )
        return lines

    def entry(self) -> dict:
        """Its summary.json entries (None for NaN)."""

        def value(x: float) -> float | None:
            return None if not math.isfinite(x) else float(x)

        return {
            "force_error": value(self.force_error),
            "interpenetration_max": value(self.interpenetration_max),
        }

    def summary(self) -> dict:
        """summary.json's `contact` block (compare: workflows/compare/grading.py's summary_of)."""
        return {
            **self.entry(),
            "force_given": self.force is not None,
            "force_file": self.force_file,
            "force_reference": self.force_source,
            "reference_force_own_error": self.own_error,
            "units": {
                "force_error": "1",
                "interpenetration_max": "m",
                "force": self.force_unit,
            },
        }


def truth_reference(truth) -> ContactReference:
    """The contact reference of a contact truth (TruthSamples): its force and own error."""
    from tissuebench.solvers.truth.cases import CASES
    from tissuebench.workflows.contact.study import truth_force

    scale = float(CASES[truth.case][3])
    force = truth_force(truth)
    return ContactReference(
        scale,
        force.force,
        f"the truth {truth.case}'s force",
        float(force.own_error),
        benchmark=CASES[truth.case][0],
    )


def file_reference(path: Path, fingerprint: dict) -> ContactReference:
    """The contact reference of a run folder or export of ours (its fingerprint as
    grading.folder_fingerprint reads it): its load scale and its force."""
    from tissuebench.workflows.io.tables import read_rows

    options = fingerprint.get("options") or {}
    scale = load_scale_of(options, str(path))
    path = Path(path)
    force, source = None, "our reference's force"
    if fingerprint.get("source") == "run folder":
        table = path.parent / "contact.csv"
        if table.is_file():
            rows = [r for r in read_rows(table) if r["algorithm"] == path.stem]
            if rows:
                force = np.array([[float(r["force_x"]), float(r["force_y"])] for r in rows])
                source = f"our {path.stem}'s force (contact.csv)"
    elif fingerprint.get("source") == "export":
        stem = path.name.split(".")[0]
        force = export_force(path.parent / f"{stem}.json")
        source = f"our {fingerprint.get('case')} export's reference force"
    return ContactReference(scale, force, source, benchmark=str(fingerprint.get("benchmark") or ""))


def export_force(json_path: Path) -> np.ndarray | None:
    """reference.contact.force (steps, 2) N/m of an exported JSON (None when it has none)."""
    import json

    try:
        data = json.loads(Path(json_path).read_text())
        force, dim = data["reference"]["contact"]["force"], data["dimension"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return force_array(force, f"{json_path}: reference.contact.force", dim)


def force_array(value: object, where: str, dim: object) -> np.ndarray:
    """A force table (steps, dim) of finite numbers from a JSON value, dim the export's
    dimension (2 or 3); ContactGradingError, one line, naming `where`, for anything else (an
    edited export)."""
    try:
        force = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        force = np.zeros((0, 0))
    if force.ndim != 2 or force.shape[1] != dim or not np.isfinite(force).all():
        raise ContactGradingError(
            f"{where} is not a table of finite forces, one row of {dim} numbers a step"
        )
    return force


def load_scale_of(options: dict, where: str) -> float:
    """The load scale s (a finite number > 0) of an export's options; ContactGradingError."""
    value = options.get("load_scale", 1.0)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < np.inf:
        raise ContactGradingError(f"{where}: options.load_scale is {value!r}, not a number > 0")
    return float(value)


def exported_reference(data) -> ContactReference | None:
    """The contact reference of an Exported (io/exported.py) whose `reference` our run filled:
    its load scale and force; None for an export without contact."""
    if getattr(data, "contact", None) is None:
        return None
    reference = data.reference or {}
    force = (reference.get("contact") or {}).get("force")
    return ContactReference(
        load_scale_of(data.options, "the export"),
        None
        if force is None
        else force_array(force, "the export's reference.contact.force", data.dim),
        "our reference's force (the export's reference.contact.force)",
        benchmark=data.benchmark,
    )


def read_needle_force(path: Path, times: np.ndarray) -> np.ndarray:
    """A candidate's needle force file (io/tables.py read_force_csv) on the grading's times
    (s): (k, 2) N/m for the first k steps it covers; a file that starts at t = h starts from
    zero force at t = 0 (the needle touches without force at rest). ContactGradingError, one
    line, for an unreadable file or time stamps that are not the grading's t_i."""
    from tissuebench.workflows.io.tables import read_force_csv

    try:
        t, force = read_force_csv(path)
    except (OSError, ValueError) as err:
        raise ContactGradingError(f"--needle-force: {err}") from None
    h = float(times[1] - times[0]) if len(times) > 1 else 1.0
    if len(t) and len(times) > 1 and abs(t[0] - times[1]) <= TIME_TOLERANCE * max(abs(t[0]), h):
        t, force = np.concatenate([[0.0], t]), np.vstack([np.zeros(force.shape[1]), force])
    n = min(len(t), len(times))
    wrong = np.abs(t[:n] - times[:n]) > TIME_TOLERANCE * np.maximum(np.abs(times[:n]), h)
    if len(t) > len(times) or wrong.any():
        at = int(np.argmax(wrong)) if wrong.any() else len(times)
        raise ContactGradingError(
            f"--needle-force {path}: its time stamps are not the graded steps t_i = i h "
            f"(h = {h:.6g} s, {len(times)} steps from t = 0): row {at + 1} is at t = "
            f"{t[min(at, len(t) - 1)]:.6g} s; write one row per step t_i"
        )
    return force


def grade_contact(
    series, times: np.ndarray, reference: ContactReference, needle_force: Path | None = None
) -> ContactGrades:
    """A candidate series' contact readings on the grading's `times` (s): its interpenetration
    at every step it has (metrics/contact.py) and, when it hands its force file, the force
    error against the reference's force. ContactGradingError for a force file that cannot be
    read or a candidate with no node on the contact edge."""
    tool = reference.tool
    try:
        if tool.dim == 3:  # SPEC 13: the candidate's own faces on the contact surface
            own = surface_interpenetration_curve(
                series.points,
                series.cells,
                series.cell_type,
                series.displacements,
                series.times,
                tool,
                surface_mask(reference, series.points),
            )
        else:
            box = get_entry(reference.benchmark).box
            own = interpenetration_curve(
                series.points,
                series.displacements,
                series.times,
                tool,
                right=box[0],
                size=box[0],
            )
    except ValueError as err:
        raise ContactGradingError(str(err)) from None
    curve = np.full(len(times), np.nan)
    for t, d in zip(series.times, own, strict=True):  # the candidate's steps on the grading's
        i = int(np.argmin(np.abs(times - t)))
        h = float(times[1] - times[0]) if len(times) > 1 else 1.0
        if abs(times[i] - t) <= TIME_TOLERANCE * max(abs(t), h):
            curve[i] = d
    if len(times) and not np.isfinite(curve[0]) and abs(times[0]) == 0.0:
        curve[0] = 0.0  # a series completed with the zero initial state: nothing inside at rest
    force = None if needle_force is None else read_needle_force(Path(needle_force), times)
    error = float("nan")
    if force is not None and reference.force is not None:
        if force.shape[1] != reference.force.shape[1]:
            raise ContactGradingError(
                f"--needle-force {needle_force}: {force.shape[1]} force components, the "
                f"reference's tool has {reference.force.shape[1]} ({tool.force_unit})"
            )
        # SPEC 13: in 3D the axial component is graded (the others are a symmetry error)
        axis = [tool.axis] if tool.dim == 3 else slice(None)
        error = force_error(force[:, axis], reference.force[:, axis])
    source = reference.source if reference.force is not None else "no force of the reference"
    finite = curve[np.isfinite(curve)]
    peak = float(finite.max()) if len(finite) else float("nan")
    given = None if needle_force is None else str(Path(needle_force).resolve())
    return ContactGrades(
        curve, force, error, peak, source, reference.own_error, given, tool.force_unit
    )


def surface_mask(reference: ContactReference, points: np.ndarray) -> np.ndarray:
    """Which of a candidate's nodes (n, d), m, lie on the reference benchmark's contact surface
    (its posing's predicate, within SPEC 9's tau of its extent)."""
    from tissuebench.meshes.posed import posing
    from tissuebench.meshes.regions import SAME_BODY

    _, posed = posing(reference.benchmark, load_scale=reference.load_scale)
    assert posed.tool is not None  # a contact benchmark
    return posed.tool.mask(np.asarray(points, dtype=float), SAME_BODY * posed.extent)


def force_columns(grades: ContactGrades, steps: int) -> dict[str, np.ndarray]:
    """metrics.csv's extra columns of a contact reference: interpenetration (m) and, when the
    candidate's force is given, force_x and force_y (N/m; NaN past its last row)."""
    columns = {"interpenetration": grades.interpenetration}
    if grades.force is not None:
        width = grades.force.shape[1]
        padded = np.full((steps, width), np.nan)
        padded[: len(grades.force)] = grades.force[:steps]
        columns |= {f"force_{c}": padded[:, i] for i, c in enumerate("xyz"[:width])}
    return columns


# --- compare's side (workflows/compare/grading.py calls these) -----------------------------


def reference_benchmark(reference: str | Path, case: str | None) -> str | None:
    """The benchmark the reference poses, as far as it can be told before reading its series:
    the truth case's, or its folder's (folder_fingerprint); None when unknown."""
    from tissuebench.workflows.compare.fingerprint import folder_fingerprint

    if case is not None:
        from tissuebench.solvers.truth.cases import CASES

        return CASES[case][0] if case in CASES else None
    try:
        return folder_fingerprint(Path(reference)).get("benchmark")
    except Exception:  # anything a file can hold: the folder says nothing
        return None


def is_contact_reference(
    reference: str | Path, case: str | None, contact: ContactReference | None, comm
) -> bool:
    """Whether compare's reference poses contact (SPEC 12): `contact` given (the external
    runner gives its export's, on rank 0), or a truth, run folder or export of the benchmark
    "contact"; rank 0's answer on every rank. Collective."""
    return comm.bcast(
        (contact is not None or in_contact(reference_benchmark(reference, case)))
        if comm.rank == 0
        else None,
        root=0,
    )


def contact_grades(
    g,
    reference: str | Path,
    truth,
    contact: ContactReference | None,
    needle_force: str | Path | None,
) -> ContactGrades:
    """The candidate's contact readings (rank 0: its Grading keeps the candidate's series)
    against the contact reference: `contact` when given, else the truth's (`truth`, rank 0's
    TruthSamples), else the reference folder's."""
    if contact is None:
        if truth is not None:
            contact = truth_reference(truth)
        else:
            contact = file_reference(Path(reference), getattr(g, "reference_fingerprint", {}))
    grades = grade_contact(
        getattr(g, "candidate_series"),
        g.times,
        contact,
        None if needle_force is None else Path(needle_force),
    )
    delattr(g, "candidate_series")  # read once, graded: not kept with the summary
    return grades
