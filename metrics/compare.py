"""`grade`: the metrics of SPEC section 6 for two displacement time series read from files
(how a user grades any simulator against our reference). The files that
`tissuebench compare` writes are written by workflows/compare/grading.py.

Rank 0 reads and checks both series; the reference mesh is then distributed over `comm`
and every step is measured in parallel. A candidate on the reference's mesh, node for node
and cell for cell, is graded node by node (section 6); a candidate on another mesh of the
same body is graded as SPEC section 9 says (metrics/crossmesh.py), and a note says so.

A series has diverged at step k, as SPEC section 3 says of a run, when its displacement at
step k has a non-finite value (NaN or inf, in any component) or its largest nodal
displacement magnitude exceeds 100 times its domain's largest extent: the metrics are not
evaluated from step k on (NaN), metrics.csv's `status` column says so ("diverged" for the
candidate, "reference diverged" for the reference, as in a run's metrics.csv; "missing" for
the steps after a shorter candidate's last one), and Grading gives the reason. Within that
bound no metric of a graded step can overflow (series.py bounds the coordinates).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import overload

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.io.utils import cell_perm_vtk
from numpy.typing import ArrayLike

from tissuebench.metrics.cells import NAMES, match_points
from tissuebench.metrics.crossmesh import (
    BODY_TOLERANCE,
    CrossMetrics,
    Mesh,
    check_same_body,
    curved_allowance,
    note,
)
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.table import METRICS, Metrics


def columns() -> tuple[str, ...]:
    """The columns of a metrics.csv: one per metric of METRICS, then the step's status."""
    return ("algorithm", "step", "time", *METRICS, "status")


COLUMNS = columns()  # with the SPEC's metrics
POINT_TOLERANCE = 1e-6  # node coordinates match within this fraction of the mesh's extent
# Time stamps match within TIME_RTOL max(|t_ref|, h), h the reference's smallest step, and
# never beyond h/4, so that no step can pass for its neighbour. Six significant digits, as
# CalculiX prints times in its .frd (E12.5: 3.33333E-02), are within 5e-6 |t| of the exact
# time: TIME_RTOL accepts them with a factor 2 to spare, up to 25 000 steps of h (beyond
# that six digits cannot tell neighbouring steps apart, and h/4 decides).
TIME_RTOL = 1e-5
DIVERGENCE = 100.0  # SPEC 3: a nodal displacement beyond this times the largest extent diverges


def unit(name: str, dim: int | None) -> str | None:
    """The unit of metric `name` (a key of METRICS) on a body of dimension `dim`: E_n and E_s
    are "dimensionless", E_i and its nodal form are "m^d" (|Omega_0|^(-1/d) times the
    integral of a displacement in m over the body, SPEC 6; m^2 in 2D, m^3 in 3D; None when
    `dim` is not known)."""
    if (METRICS[name].variant_of or name) != "interior_error":
        return "dimensionless"
    return None if dim is None else f"m^{dim}"


def metric_units(dim: int | None) -> dict[str, dict[str, str | None]]:
    """{metric: {"symbol": "E_n", "unit": ...}} for every metric of METRICS (see unit)."""
    return {name: {"symbol": m.symbol, "unit": unit(name, dim)} for name, m in METRICS.items()}


def summarize(curve: ArrayLike) -> tuple[float, float]:
    """(max, time-mean) of a metric curve over steps 1..N, ignoring NaN; NaN if none (the
    curve's own units: the metrics are dimensionless)."""
    values = np.asarray(curve, dtype=np.float64)[1:]
    values = values[~np.isnan(values)]
    if len(values) == 0:
        return np.nan, np.nan
    return float(values.max()), float(values.mean())


# --- checks ---------------------------------------------------------------------------------


def check_meshes(ref: Series, cand: Series) -> np.ndarray | None:
    """For each reference node, the index of the candidate node at its coordinates (within
    POINT_TOLERANCE of the reference's extent), when the candidate's mesh is the reference's,
    node for node and cell for cell; None when the meshes differ (the candidate is then graded
    on its own mesh, SPEC section 9). Raises InputError for meshes of different dimensions."""
    if ref.dim != cand.dim:
        raise InputError(
            f"{cand.path}: {cand.dim}D {NAMES[cand.cell_type]} cannot be graded against the "
            f"{ref.dim}D {NAMES[ref.cell_type]} of {ref.path}"
        )
    if ref.cell_type != cand.cell_type:
        return None
    if len(ref.points) != len(cand.points) or len(ref.cells) != len(cand.cells):
        return None
    extent = np.ptp(ref.points, axis=0).max()
    tol = POINT_TOLERANCE * extent
    for bound in (np.min, np.max):
        if np.abs(bound(ref.points, axis=0) - bound(cand.points, axis=0)).max() > tol:
            return None
    match = match_points(ref.points, cand.points, tol)
    if np.any(match < 0) or len(np.unique(match)) != len(match):
        return None
    in_ref = np.empty_like(match)
    in_ref[match] = np.arange(len(match))

    def canonical(cells):
        cells = np.sort(cells, axis=1)
        return cells[np.lexsort(cells.T[::-1])]

    if not np.array_equal(canonical(ref.cells), canonical(in_ref[cand.cells])):
        return None
    return match


def smallest_step(times: ArrayLike) -> float:
    """The smallest time step of a series (s); for a single time, that time's magnitude (or 1
    s at t = 0), so that tolerances stay relative."""
    times = np.asarray(times, dtype=np.float64)
    if len(times) > 1:
        return float(np.diff(times).min())
    return float(abs(times[0])) or 1.0


@overload
def time_tolerance(t_ref: float, h: float) -> float: ...
@overload
def time_tolerance(t_ref: np.ndarray, h: float) -> np.ndarray: ...
def time_tolerance(t_ref: float | np.ndarray, h: float) -> float | np.ndarray:
    """How far a time stamp may be from the reference's t_ref (s) with step h: TIME_RTOL
    max(|t_ref|, h), at most h/4 (see TIME_RTOL)."""
    return np.minimum(TIME_RTOL * np.maximum(np.abs(t_ref), h), 0.25 * h)


def check_times(ref: Series, cand: Series) -> None:
    """The candidate's times are the reference's, or a prefix of them (a run that stopped),
    within time_tolerance."""
    if len(cand.times) > len(ref.times):
        raise InputError(
            f"{cand.path}: {len(cand.times)} time steps, more than the {len(ref.times)} of "
            f"{ref.path}"
        )
    t_ref = ref.times[: len(cand.times)]
    tolerance = time_tolerance(t_ref, smallest_step(ref.times))
    bad = np.flatnonzero(~(np.abs(cand.times - t_ref) <= tolerance))
    if len(bad):
        k = bad[0]
        raise InputError(
            f"{cand.path}: time stamps do not match {ref.path}: step {k} is at "
            f"t = {cand.times[k]:.9g} s, the reference's at t = {t_ref[k]:.9g} s "
            f"(tolerance {tolerance[k]:.3g} s); write every step t_i = i h of the reference "
            f"(h = {smallest_step(ref.times):.6g} s), from t = 0 or t = h"
        )


def starts_at_h(series: Series, other: Series) -> bool:
    """True if the series' first time is one step h after t = 0 (within h/4: a time stamp
    farther from its step is refused later by check_times), h the other series' first step
    when that one starts at t = 0, else the series' own. Such a series (CalculiX writes none
    at t = 0) starts from the SPEC's initial state, u = 0 at t = 0."""
    t, o = series.times, other.times
    if t[0] <= 0:
        return False
    if len(o) > 1 and o[0] == 0:
        h = float(o[1] - o[0])
    elif len(t) > 1:
        h = float(t[1] - t[0])
    else:
        return False
    return h > 0 and abs(t[0] - h) <= 0.25 * h


def with_initial_state(series: Series) -> Series:
    """The series with the zero state prepended at t = 0."""
    zero = np.zeros_like(series.displacements[0])
    return replace(
        series,
        times=np.r_[0.0, series.times],
        displacements=[zero, *series.displacements],
    )


def initial_states(ref: Series, cand: Series) -> tuple[Series, Series, list[str]]:
    """Both series, each from t = 0: one that starts at t = h gets the zero initial state
    (SPEC section 3) as its step 0. Returns them and one line for each so completed."""
    notes, done = [], []
    for who, series, other in (("reference", ref, cand), ("candidate", cand, ref)):
        if not starts_at_h(series, other):
            done.append(series)
            continue
        done.append(with_initial_state(series))
        notes.append(
            f"{who} {series.path.name} starts at t = {series.times[0]:.6g} s = h: taken to start "
            "from the SPEC's zero initial state (u = 0 at t = 0, step 0)"
        )
    return done[0], done[1], notes


def largest_magnitude(u: np.ndarray) -> float:
    """The largest Euclidean norm of a row of the finite nodal values u (n, d), in u's units,
    computed without overflow for values up to float64's largest (inf beyond)."""
    scale = float(np.abs(u).max(initial=0.0))
    if scale == 0:
        return 0.0
    with np.errstate(over="ignore"):
        return scale * float(np.sqrt(np.sum((u / scale) ** 2, axis=1)).max())


def divergence(series: Series) -> tuple[int, str] | None:
    """The first step at which the series has diverged (SPEC section 3: a non-finite
    displacement, or a largest nodal displacement magnitude beyond DIVERGENCE times the
    domain's largest extent) with the reason in a few words; None if it never does."""
    extent = float(np.ptp(series.points, axis=0).max())
    what = (
        "displacement"
        if series.field == "displacement"
        else f"displacement (field {series.field!r})"
    )
    for i, u in enumerate(series.displacements):
        if not np.isfinite(u).all():
            return i, f"non-finite {what}"
        largest = largest_magnitude(u)
        if largest > DIVERGENCE * extent:
            shown = f"{largest:.3g}" if np.isfinite(largest) else "beyond 1.8e+308"
            return i, (
                f"largest nodal {what} {shown} exceeds {DIVERGENCE:g} x the domain's largest "
                f"extent ({extent:.3g})"
            )
    return None


def statuses(
    steps: int, cand_steps: int, ref_diverged: int | None, cand_diverged: int | None
) -> list[str]:
    """The status of each of `steps` steps: "ok", or from the reference's divergence step on
    "reference diverged", from the candidate's last step on "missing", from the candidate's
    divergence step on "diverged" (the later of these rules overrides the earlier)."""
    status = ["ok"] * steps
    for start, name in (
        (ref_diverged, "reference diverged"),
        (cand_steps, "missing"),
        (cand_diverged, "diverged"),
    ):
        if start is not None:
            status[start:] = [name] * (steps - min(start, steps))
    return status


# --- parallel evaluation --------------------------------------------------------------------


def function_space(comm: MPI.Comm, series: Series | None) -> tuple[fem.FunctionSpace, np.ndarray]:
    """The vector Q1 space on the series' mesh, read on rank 0 and distributed over comm, and
    for each owned node of the space the index of its point in the series."""
    cell_type, dim, per_cell = comm.bcast(
        (series.cell_type, series.dim, series.cells.shape[1])
        if comm.rank == 0 and series is not None
        else None,
        root=0,
    )
    if comm.rank == 0:
        assert series is not None  # rank 0's
        cells = series.cells[:, cell_perm_vtk(dolfinx.mesh.CellType[cell_type], per_cell)]
        x = series.points
    else:
        cells, x = np.empty((0, per_cell), dtype=np.int64), np.empty((0, dim))
    element = basix.ufl.element("Lagrange", cell_type, 1, shape=(dim,))
    mesh = dolfinx.mesh.create_mesh(comm, cells, ufl.Mesh(element), x)
    V = fem.functionspace(mesh, ("Lagrange", 1, (dim,)))
    # Cell by cell the P1 dofs sit at the geometry nodes, which know their input index.
    index_map = V.dofmap.index_map
    point = np.empty(index_map.size_local + index_map.num_ghosts, dtype=np.int64)
    point[V.dofmap.list.ravel()] = mesh.geometry.input_global_indices[
        mesh.geometry.dofmaps[0].ravel()
    ]
    return V, point[: index_map.size_local]


def _curves(
    comm: MPI.Comm,
    V: fem.FunctionSpace,
    points: np.ndarray,
    ref: Series | None,
    cand: Series | None,
    steps: int,
    graded: int,
    match: np.ndarray | None,
    cross: CrossMetrics | None = None,
    skip: tuple[str, ...] = (),
) -> dict[str, np.ndarray]:
    """The metric curves (dimensionless, one value per step, keyed as METRICS), evaluated on the
    first `graded` steps only and NaN on the others. Collective; the series are rank 0's. The
    candidate is node-matched through `match`, or else on its own mesh, graded by `cross`."""
    if cross is not None:
        curves = {name: np.full(steps, np.nan) for name in METRICS}
        for i in range(graded):
            u_ref, u_cand = comm.bcast(
                (ref.displacements[i], cand.displacements[i])
                if comm.rank == 0 and ref is not None and cand is not None
                else None,
                root=0,
            )
            for name, value in cross.evaluate(u_ref[points].ravel(), u_cand).items():
                curves[name][i] = value
        return curves
    metrics = Metrics(V)
    curves = {name: np.full(steps, np.nan) for name in METRICS}
    for i in range(graded):
        u_ref, u_cand = comm.bcast(
            (ref.displacements[i], cand.displacements[i][match])
            if comm.rank == 0 and ref is not None and cand is not None
            else None,
            root=0,
        )
        pair = u_ref[points].ravel(), u_cand[points].ravel()
        values = metrics.evaluate(*pair, skip=skip) if skip else metrics.evaluate(*pair)
        for name, value in values.items():
            curves[name][i] = value
    return curves


# --- output ---------------------------------------------------------------------------------


def _divergence(who: str, step: int, time: float, reason: str | None) -> str:
    """One line: `who` ("candidate" or "reference") diverged at `step` (time in s), and why."""
    return f"{who} diverged at step {step} (t = {time:.6g} s): {reason}"


@dataclass
class Grading:
    """A candidate series graded against a reference: `times` (s), the metric `curves` keyed as
    METRICS (NaN where a step was not graded), each step's `status` (ok, diverged, reference
    diverged, missing), the one-line `summaries` (where a series diverged or ends, then one per
    metric: max and time-mean over the graded steps), the candidate's `label`, a `title`,
    the `notes` on how the series were read (one line each: a series completed with the zero
    initial state, a candidate graded on its own mesh), the field read from each side (`fields`:
    reference, candidate), the divergence steps, the number of candidate steps, and why each
    side diverged (`reference_reason`, `candidate_reason`: a few words, as a run's summary.json
    `reason`; None for a side that did not)."""

    label: str
    title: str
    times: np.ndarray
    curves: dict[str, np.ndarray]
    status: list[str]
    summaries: dict[str, str]
    notes: list[str] = field(default_factory=list)
    fields: tuple[str, str] = ("displacement", "displacement")
    reference_diverged: int | None = None
    candidate_diverged: int | None = None
    candidate_steps: int = 0
    reference_reason: str | None = None
    candidate_reason: str | None = None


def describe(
    label: str,
    against: str,
    times: np.ndarray,
    curves: dict[str, np.ndarray],
    graded: int,
    cand_steps: int,
    reference: tuple[int | None, str | None],
    candidate: tuple[int | None, str | None],
    suffix: Callable[[str], str] = lambda name: "",
    dim: int | None = None,
) -> tuple[str, dict[str, str]]:
    """The title and one-line summaries of a grading: where a series diverged or the
    candidate ended, and each metric's maximum and time-mean over the steps graded, named by
    its symbol and key with its unit on a body of dimension `dim` ("E_i interior_error: max
    0.0012 m^3, ..."; see unit), with `suffix(metric name)` after its line. `reference` and
    `candidate` are (divergence step or None, reason)."""
    steps = len(times)
    summaries = {}
    for side, (step, reason) in (("reference", reference), ("candidate", candidate)):
        if step is not None:
            summaries[side] = _divergence(side, step, times[step], reason)
    if candidate[0] is None and cand_steps < steps:
        summaries["candidate"] = (
            f"candidate ends at step {cand_steps - 1} (t = {times[cand_steps - 1]:.6g} s): "
            f"steps {cand_steps}..{steps - 1} missing"
        )
    title = f"{label} against {against}"
    if summaries:
        title += f" (graded up to t = {times[graded - 1]:.4g} s)" if graded else " (no step graded)"
    scope = (
        f"steps 1..{steps - 1}" if graded == steps else f"steps 1..{graded - 1} of 1..{steps - 1}"
    )
    if graded <= 1:
        scope = f"no step of 1..{steps - 1} graded"
    # E_i first (SPEC 10's headline: it does not blow up where |u| is small), E_n's maximum
    # with its step (over the early steps, where |u| is tiny, it is large and says little)
    first = [n for n in METRICS if n == HEADLINE]
    for name in first + [n for n in METRICS if n != HEADLINE]:
        peak, mean = summarize(curves[name])
        u = unit(name, dim)
        if u == "dimensionless":
            at = ""
            curve = np.asarray(curves[name], dtype=float)[1:graded]
            if name == "relative_error" and np.isfinite(curve).any():
                at = f" at step {int(np.nanargmax(curve)) + 1}"
            values = f"max {peak:.4g}, time-mean {mean:.4g}"
            where = f"(dimensionless; {scope}{at.replace(' at', ', the max at')}"
        else:
            m = "" if u is None else f" {u}"
            values, where = f"max {peak:.4g}{m}, time-mean {mean:.4g}{m}", f"({scope}"
        line = f"{METRICS[name].symbol} {name}: {values} {where}, {label})"
        summaries[name] = line + suffix(name)
    return title, summaries


HEADLINE = "interior_error"  # the metric a grading's summary says first


def grade_series(
    ref: Series | None,
    cand: Series | None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    label: str | None = None,
    surface: bool = True,
    body: dict | None = None,
) -> Grading:
    """`grade` for two series in memory, rank 0's (None on the other ranks may be passed):
    checked, completed with the zero initial state, and graded on the reference's mesh node
    for node when the candidate's mesh is the reference's, else on its own mesh (SPEC 9).
    Collective over comm; the same Grading on every rank; InputError on every rank as `grade`.
    Without `surface`, E_s is left NaN on the same mesh (its boolean is most of the cost).
    `body`: the reference benchmark's body where it is no box (its entry's; the cylinder: a
    curved side whose facets' sagitta the same-body check allows, crossmesh.curved_allowance).
    """
    match = plan = None
    error = None
    if comm.rank == 0:
        assert ref is not None and cand is not None  # rank 0's
        try:
            ref, cand, notes = initial_states(ref, cand)
            match = check_meshes(ref, cand)
            allowance = 0.0
            if match is None:
                check_same_body(ref, cand, body)
                notes.append(note(ref, cand))
                allowance = max(curved_allowance(ref, body), curved_allowance(cand, body))
                if allowance:
                    notes.append(
                        f"the curved side: each mesh within {allowance:.3g} m of the other's "
                        "domain allowed, the larger of their side facets' sagittas (SPEC 13)"
                    )
            check_times(ref, cand)
            plan = (
                match is None,
                ref.times,
                len(cand.times),
                divergence(ref),
                divergence(cand),
                notes,
                (ref.field, cand.field),
                (label or cand.path.stem, ref.path.stem),
                float(np.ptp(ref.points, axis=0).max()),
                allowance,
            )
        except InputError as exc:
            error = str(exc)
        except Exception as exc:  # never leave the other ranks waiting
            error = (
                f"{cand.path}: cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())})"
            )
    error, plan = comm.bcast((error, plan), root=0)
    if error is not None:
        raise InputError(error)

    (
        cross,
        times,
        cand_steps,
        ref_divergence,
        cand_divergence,
        notes,
        fields,
        names,
        extent,
        allow,
    ) = plan
    ref_diverged, ref_reason = ref_divergence or (None, None)
    cand_diverged, cand_reason = cand_divergence or (None, None)
    steps = len(times)
    status = statuses(steps, cand_steps, ref_diverged, cand_diverged)
    graded = status.count(
        "ok"
    )  # the steps before the first that is not "ok" (statuses only get worse)
    V, points = function_space(comm, ref)
    grader = None
    if cross:
        mesh, paths = comm.bcast(
            (Mesh.of(cand), (cand.path, ref.path))
            if comm.rank == 0 and ref is not None and cand is not None
            else None,
            root=0,
        )
        where = f"{paths[0]}: not a mesh of the body of {paths[1]}"
        grader = CrossMetrics(V, mesh, BODY_TOLERANCE * extent + allow, where)
    skip = () if surface else ("surface_error",)
    curves = _curves(comm, V, points, ref, cand, steps, graded, match, grader, skip)

    label = names[0]
    title, summaries = describe(
        label, names[1], times, curves, graded, cand_steps,
        (ref_diverged, ref_reason), (cand_diverged, cand_reason), dim=V.mesh.geometry.dim,
    )  # fmt: skip
    return Grading(
        label,
        title,
        np.asarray(times),
        curves,
        status,
        summaries,
        notes,
        fields,
        ref_diverged,
        cand_diverged,
        cand_steps,
        ref_reason,
        cand_reason,
    )
