"""Grading a candidate against the truth (SPEC section 10, "Grading against the truth"): as
SPEC section 9, with the truth as the reference mesh M and its own element's interpolation
u_h(X), sampled in a TruthSamples (solvers/truth/samples.py).

- E_n = ‖Π u′ − u‖ / ‖u‖ at the truth's vertices, Π u′ the candidate's u′_h there (found in
  the undeformed candidate mesh; a vertex within τ of a candidate node takes its value);
  NaN where ‖u‖ = 0.
- E_i = |Ω_0|^(−1/d) Σ_q w_q ‖u′_h(X_q) − u_h(X_q)‖ over the truth's quadrature points
  (3 Gauss points per direction in each truth cell, u_h the truth's second-order field there),
  |Ω_0| = Σ_q w_q; the nodal form |Ω_0|^(−1/d) Σ_n w_n ‖(Π u′)_n − u_n‖ with w_n = ∫ φ_n dX,
  φ_n the Q1 basis of the truth's (first-order) cells.
- E_s = |Ω_t ⊕ Ω′_t| / |Ω_t|, Ω_t bounded by the truth's deformed boundary through its
  vertices, Ω′_t by the candidate's own deformed boundary (metrics/surface.py).

The candidate is located once: at the truth's vertices and at its quadrature points, each
point keeps its candidate cell's nodes and shape-function weights, and every step is applied
with numpy fancy indexing (crossmesh.PointValues): a sparse interpolation matrix in all but
name.

Checks as compare's (metrics/compare.py): same body (SPEC 9: every node of either mesh within
τ = 1e-6 of the truth's extent of the other's undeformed domain, volumes within 1e-6), time
stamps t_i = i h within 1e-5 max(t, h) (a candidate may stop early: "missing"; one at other
times is refused), divergence (NaN from the step a series diverges, status column). A
candidate that starts at t = h starts from the zero initial state.

Rank 0 computes, every rank gets the same TruthGrading (the work is serial: numpy and
shapely/manifold3d on one process); the other ranks wait asleep (core/waiting.py).

Its speed is timed by workflows/bench/truth_grading.py (issue 25, item 6).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core.waiting import wait_for_rank0
from tissuebench.metrics.cells import (
    DIM,
    NAMES,
    Locator,
    boundary_facets,
    shape_functions,
    shape_gradients,
)
from tissuebench.metrics.compare import (
    Grading,
    describe,
    divergence,
    smallest_step,
    starts_at_h,
    statuses,
    time_tolerance,
    with_initial_state,
)
from tissuebench.metrics.crossmesh import (
    BODY_TOLERANCE,
    Mesh,
    PointValues,
    check_same_body,
    check_same_revolved_body,
    curved_allowance,
)
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.surface import domain, surface_error
from tissuebench.metrics.table import METRICS, SURFACE
from tissuebench.solvers.truth.revolve import ANGLES, revolve
from tissuebench.solvers.truth.samples import TruthSamples

GAUSS = 3  # points per direction for the truth's Q1 nodal weights (exact: 2 would do)


def truth_name(truth: TruthSamples) -> str:
    """How the truth is named in messages and titles: "truth:CASE"."""
    return f"truth:{truth.case}"


def truth_series(truth: TruthSamples) -> Series:
    """The truth's vertex values as a Series (for the checks that compare makes)."""
    return Series(
        Path(truth_name(truth)),
        np.asarray(truth.vertices, dtype=np.float64),
        np.asarray(truth.cells),
        truth.cell_type,
        np.asarray(truth.times, dtype=np.float64),
        list(truth.u_vertices),  # a revolved truth's computed step by step (revolve.Revolved)
    )


def own_error(truth: TruthSamples) -> float:
    """The truth's own E_i estimate (max over steps, m^gdim), NaN if it carries none."""
    value = truth.own_error.get("interior_error_max")
    return np.nan if value is None else float(value)


def nodal_weights(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """w_n = ∫ φ_n dX for the Q1 (or P1) basis of a first-order mesh (units of the coordinates
    to the power d), by GAUSS points per direction on each cell (exact for first-order cells).
    """
    d = DIM[cell_type]
    g, gw = np.polynomial.legendre.leggauss(GAUSS)
    g, gw = 0.5 * (g + 1), 0.5 * gw
    xi = np.stack(np.meshgrid(*[g] * d, indexing="ij"), axis=-1).reshape(-1, d)
    w = np.prod(np.stack(np.meshgrid(*[gw] * d, indexing="ij"), axis=-1).reshape(-1, d), axis=1)
    if cell_type in ("triangle", "tetrahedron"):  # a simplex: w_n = |cell| / (d + 1)
        X = points[cells]
        volume = np.abs(np.linalg.det(X[:, 1:] - X[:, :1])) / (2.0 if d == 2 else 6.0)
        contribution = np.repeat(volume[:, None] / (d + 1), d + 1, axis=1)
    else:
        phi = shape_functions(cell_type, xi)  # (q, k)
        J = np.einsum("cki,qkj->cqij", points[cells], shape_gradients(cell_type, xi))
        contribution = np.einsum("q,cq,qk->ck", w, np.abs(np.linalg.det(J)), phi)
    weights = np.zeros(len(points))
    np.add.at(weights, cells, contribution)
    return weights


def _boundary(points: np.ndarray, cells: np.ndarray, cell_type: str):
    """(boundary nodes, their undeformed coordinates, the Polygon or Solid they bound)."""
    facets = boundary_facets(points, cells, cell_type)
    nodes = np.unique(facets)
    return nodes, points[nodes], domain(points[nodes], np.searchsorted(nodes, facets))


class TruthMetrics:
    """The metrics of METRICS for a candidate mesh against a truth, located once.
    `evaluate(i, u_cand)` grades the candidate's nodal displacement u_cand (N′, d), m, against
    the truth's step i. Raises InputError if a truth vertex or quadrature point lies farther
    than tol (m) outside the candidate's mesh (`where` starts the message)."""

    def __init__(self, truth: TruthSamples, mesh: Mesh, tol: float, where: str):
        self.truth = truth
        self.dim = truth.gdim
        locator = Locator(mesh.points, mesh.cells, mesh.cell_type, tol)
        vertices = np.asarray(truth.vertices, dtype=np.float64)
        points = np.asarray(truth.points, dtype=np.float64)
        self.at_vertices = PointValues(locator, vertices, snap=tol)
        self.at_points = PointValues(locator, points)
        lost_v, lost_q = self.at_vertices.missing, self.at_points.missing
        if len(lost_v) + len(lost_q):
            x = vertices[lost_v[0]] if len(lost_v) else points[lost_q[0]]
            what = "vertex" if len(lost_v) else "quadrature point"
            raise InputError(
                f"{where}: {len(lost_v)} truth vertices and {len(lost_q)} quadrature points lie "
                f"farther than {tol:.3g} outside the candidate's mesh, e.g. the {what} at "
                f"({', '.join(f'{c:.9g}' for c in x)})"
            )
        self.weights = np.asarray(truth.weights, dtype=np.float64)
        self.volume = float(self.weights.sum())
        self.scale = self.volume ** (-1 / self.dim)
        self.nodal = nodal_weights(vertices, np.asarray(truth.cells), truth.cell_type)
        self.truth_nodes, self.truth_X, self.truth_shape = _boundary(
            vertices, np.asarray(truth.cells), truth.cell_type
        )
        self.cand_nodes, self.cand_X, self.cand_shape = _boundary(
            mesh.points, mesh.cells, mesh.cell_type
        )
        self.surface = True  # False: E_s is not computed (NaN), the costly boolean skipped

    def evaluate(self, i: int, u_cand: np.ndarray) -> dict[str, float]:
        """The metrics (dimensionless E_n and E_s; E_i in m^d, as SPEC 6 scales it) of u_cand
        (N′, d), m, against the truth's step i, keyed as METRICS (NaN for a metric this
        module does not know)."""
        u_cand = np.asarray(u_cand, dtype=np.float64)
        u_v = np.asarray(self.truth.u_vertices[i], dtype=np.float64)
        u_q = np.asarray(self.truth.u_points[i], dtype=np.float64)
        at_v = self.at_vertices(u_cand)
        reference = float(np.linalg.norm(u_v))
        gap = np.linalg.norm(at_v - u_v, axis=1)
        values = {
            "relative_error": float(np.sqrt(gap @ gap)) / reference if reference > 0 else np.nan,
            "interior_error": self.scale
            * float(self.weights @ np.linalg.norm(self.at_points(u_cand) - u_q, axis=1)),
            "interior_error_nodal": self.scale * float(self.nodal @ gap),
        }
        if self.surface:
            values["surface_error"] = self.surface_at(i, u_cand)
        return {name: float(values.get(name, np.nan)) for name in METRICS}

    def surface_at(self, i: int, u_cand: np.ndarray) -> float:
        """E_s (dimensionless) of u_cand (N′, d), m, against the truth's step i: the boolean of
        the two deformed domains, each bounded by its own mesh's boundary."""
        u_v = np.asarray(self.truth.u_vertices[i], dtype=np.float64)
        return surface_error(
            self.truth_shape,
            self.truth_X + u_v[self.truth_nodes],
            self.cand_X + np.asarray(u_cand, dtype=np.float64)[self.cand_nodes],
            self.cand_shape,
        )

    def evaluate_steps(self, displacements, steps: int, chunk: int = 16) -> dict[str, np.ndarray]:
        """`evaluate` of steps 0..steps-1 of a candidate's nodal displacements (a sequence of
        (N′, d) arrays, m) without E_s (NaN), `chunk` steps at a time: the same numbers to
        round-off, many times faster than step by step. E_i's interpolation at the truth's
        points and its differences with the truth's values there, most of a step's cost, are
        one compiled loop (metrics/kernels.py)."""
        from tissuebench.metrics.kernels import interior_norms

        out = {name: np.full(steps, np.nan) for name in METRICS}
        for start in range(0, steps, chunk):
            stop = min(steps, start + chunk)
            u = np.stack([np.asarray(displacements[i], np.float64) for i in range(start, stop)])
            u_v = np.asarray(self.truth.u_vertices[start:stop], dtype=np.float64)
            gap = np.linalg.norm(self.at_vertices.steps(u) - u_v, axis=2)  # (steps, vertices)
            reference = np.linalg.norm(u_v.reshape(len(u_v), -1), axis=1)
            # a dot product a step, as `evaluate`'s: the same numbers whatever the chunk holds
            # (a matrix product's sums depend on how many rows it has, in the last bit)
            with np.errstate(invalid="ignore", divide="ignore"):
                relative = np.sqrt([g @ g for g in gap]) / reference
            out["relative_error"][start:stop] = np.where(reference > 0, relative, np.nan)
            points = self.at_points
            u_q = self.truth.u_points[start:stop]
            away = interior_norms(points.nodes, points.weights, u, u_q, self.weights)
            out["interior_error"][start:stop] = self.scale * away
            if "interior_error_nodal" in out:
                out["interior_error_nodal"][start:stop] = [
                    self.scale * (self.nodal @ g) for g in gap
                ]
        return out


# --- checks ---------------------------------------------------------------------------------


def check_truth_times(truth: Series, cand: Series, h: float) -> None:
    """The candidate's times are the truth's t_i = i h (within compare's time_tolerance), or a
    prefix of them (a run that stopped); else InputError, one line."""
    steps = len(truth.times) - 1
    need = (
        f"grading against the truth needs the candidate at every t_i = i h, h = {h:.6g} s, "
        f"i = 0..{steps} (t_N = {truth.times[-1]:.6g} s; t = 0 may be left out)"
    )
    if len(cand.times) > len(truth.times):
        raise InputError(
            f"{cand.path}: {len(cand.times) - 1} steps after t = 0, more than the truth's "
            f"{steps}: {need}"
        )
    t_ref = truth.times[: len(cand.times)]
    tolerance = time_tolerance(t_ref, h)
    bad = np.flatnonzero(~(np.abs(cand.times - t_ref) <= tolerance))
    if len(bad):
        k = bad[0]
        raise InputError(
            f"{cand.path}: step {k} is at t = {cand.times[k]:.9g} s, not at t_{k} = "
            f"{t_ref[k]:.9g} s (tolerance {tolerance[k]:.3g} s): {need}"
        )


# --- grading --------------------------------------------------------------------------------


@dataclass
class TruthGrading(Grading):
    """A Grading against the truth: also the truth's `case`, its `own_error` (as stored) and
    the seconds the grading took (`seconds`: locating, and the steps)."""

    case: str = ""
    own_error: dict = field(default_factory=dict)
    seconds: dict = field(default_factory=dict)

    def summary(self) -> dict:
        """The entry "truth" of compare's summary.json: the case, its own error, timings."""
        return {"case": self.case, "own_error": self.own_error, "seconds": self.seconds}


# the last meridian truth revolved (SPEC 13), kept while its meridian is graded against:
# (the meridian's TruthSamples, its revolved TruthSamples)
_REVOLVED: list[tuple[TruthSamples, TruthSamples]] = []


def for_candidate(truth: TruthSamples, dim: int) -> TruthSamples:
    """The truth a `dim`-dimensional candidate is graded against: a meridian truth (SPEC 13:
    computed on (r, z), its inputs say "axisymmetric") revolved about z on ANGLES azimuths for
    a 3D candidate (solvers/truth/revolve.py; the same revolved samples while the same
    meridian is asked for again); any other truth as it is."""
    if not ("axisymmetric" in truth.inputs and truth.gdim == 2 and dim == 3):
        return truth
    if not (_REVOLVED and _REVOLVED[0][0] is truth):
        _REVOLVED[:] = [(truth, revolve(truth, ANGLES))]
    return _REVOLVED[0][1]


def revolved_from(truth: TruthSamples) -> TruthSamples | None:
    """The meridian truth that `truth` was revolved from by for_candidate (None: another)."""
    return next((m for m, r in _REVOLVED if r is truth), None)


def body_of_truth(truth: TruthSamples) -> dict | None:
    """The body a revolved truth was revolved from (SPEC 13's cylinder): {"radius": R_B, m},
    the largest r of its vertices, so that the same-body check allows a faceted side's
    sagitta (crossmesh.curved_allowance); None for any other truth."""
    if "revolved" not in truth.hierarchy:
        return None
    return {"radius": float(np.hypot(truth.vertices[:, 0], truth.vertices[:, 1]).max())}


def located_on(
    truth: TruthSamples, ref: Series, cand: Series, located: dict | None
) -> TruthMetrics:
    """The TruthMetrics of the candidate's mesh: the same body checked (check_same_body) and the
    truth's vertices and quadrature points located in it; taken from `located` ({mesh key:
    TruthMetrics}, kept by the caller) when a series on the same mesh (crossmesh.Mesh.key)
    was graded against this truth before, and kept there. A refusal is not kept: its message
    names the candidate's file."""
    mesh = Mesh.of(cand)
    key = mesh.key() if located is not None else None
    grader = located.get(key) if located is not None else None
    if grader is not None and grader.truth is truth:
        return grader
    body = body_of_truth(truth)
    extent = float(np.ptp(ref.points, axis=0).max())
    # a faceted side: the truth's points on its own facets lie up to the larger sagitta out
    allowance = max(curved_allowance(ref, body), curved_allowance(cand, body))
    meridian = revolved_from(truth)
    if meridian is None:
        check_same_body(ref, cand, body)
    else:
        check_same_revolved_body(truth_series(meridian), ref, cand, allowance)
    where = f"{cand.path}: not a mesh of the body of {truth_name(truth)}"
    grader = TruthMetrics(truth, mesh, BODY_TOLERANCE * extent + allowance, where)
    if located is not None:
        located[key] = grader
    return grader


def _grade(
    truth: TruthSamples,
    cand: Series,
    label: str | None,
    log,
    surface: bool = True,
    located: dict | None = None,
) -> TruthGrading:
    """grade_truth on one process."""
    start = time.perf_counter()
    truth = for_candidate(truth, cand.dim)
    ref = truth_series(truth)
    name = truth_name(truth)
    if cand.dim != truth.gdim:
        raise InputError(
            f"{cand.path}: {cand.dim}D {NAMES[cand.cell_type]} cannot be graded against the "
            f"{truth.gdim}D truth of {truth.case}"
        )
    notes = []
    h = smallest_step(ref.times)
    if starts_at_h(cand, ref):
        cand = with_initial_state(cand)
        notes.append(
            f"candidate {cand.path.name} starts at t = {cand.times[1]:.6g} s = h: taken to start "
            "from the SPEC's zero initial state (u = 0 at t = 0, step 0)"
        )
    check_truth_times(ref, cand, h)
    grader = located_on(truth, ref, cand, located)
    grader.surface = surface
    located = time.perf_counter() - start
    revolved = truth.hierarchy.get("revolved")
    if revolved:
        notes.append(
            f"the truth {truth.case} is axisymmetric, computed on its meridian (r, z): revolved "
            f"about z on {revolved['angles']} azimuths (SPEC 13; the trapezoidal rule in theta)"
        )
    notes.append(
        f"graded against the truth {truth.case} ({len(truth.vertices):,} vertices, "
        f"{NAMES[truth.cell_type]}, second-order field): candidate on its own mesh, "
        f"{len(cand.points):,} nodes, {NAMES[cand.cell_type]}, interpolated at the truth's "
        f"{len(truth.vertices):,} vertices and {len(truth.points):,} quadrature points"
    )

    steps = len(ref.times)
    ref_divergence, cand_divergence = divergence(ref), divergence(cand)
    ref_diverged, ref_reason = ref_divergence or (None, None)
    cand_diverged, cand_reason = cand_divergence or (None, None)
    status = statuses(steps, len(cand.times), ref_diverged, cand_diverged)
    graded = status.count("ok")
    curves = {n: np.full(steps, np.nan) for n in METRICS}
    # E_n and E_i of the steps in chunks (the same numbers as step by step, to round-off, and
    # many times faster), then E_s, a boolean a step, where it is asked for
    for n, values in grader.evaluate_steps(cand.displacements, graded).items():
        curves[n][:graded] = values
    if surface:
        for i in range(graded):
            curves[SURFACE][i] = grader.surface_at(i, cand.displacements[i])
    seconds = {"locate": located, "steps": time.perf_counter() - start - located}

    label = label or cand.path.stem
    own = own_error(truth)
    title, summaries = describe(
        label, name, ref.times, curves, graded, len(cand.times),
        (ref_diverged, ref_reason), (cand_diverged, cand_reason),
        suffix=lambda n: f" (the truth's own error: {own:.2g})" if n.startswith("interior") else "",
        dim=cand.dim,
    )  # fmt: skip
    times = ref.times
    if log is not None:
        log(
            f"graded {graded - 1} steps against {name} in "
            f"{seconds['locate'] + seconds['steps']:.1f} s"
        )
    return TruthGrading(
        label,
        title,
        np.asarray(times),
        curves,
        status,
        summaries,
        notes,
        ("displacement", cand.field),
        ref_diverged,
        cand_diverged,
        len(cand.times),
        ref_reason,
        cand_reason,
        case=truth.case,
        own_error=dict(truth.own_error),
        seconds=seconds,
    )


def grade_truth(
    truth: TruthSamples | None,
    cand: Series | None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    label: str | None = None,
    log: Callable[[str], None] | None = None,
    surface: bool = True,
    located: dict | None = None,
) -> TruthGrading:
    """Grade the candidate series (rank 0's; None may be passed elsewhere) against the truth
    (rank 0's) as the module docstring says. Collective: rank 0 computes, every rank gets the
    same TruthGrading; InputError on every rank for a candidate of another dimension or body,
    other time stamps, or points outside its mesh. `label` names the candidate (default: its
    file name without suffix); `log` (rank 0) is given one line with the time taken; without
    `surface`, E_s is left NaN (its boolean of two deformed bodies is most of the cost).
    `located`: a dict the caller keeps across gradings against this truth (rank 0's), in which
    each candidate mesh is checked and located once (located_on): candidates on one mesh share
    it."""
    result: TruthGrading | None = None
    error: Exception | None = None
    if comm.rank == 0:
        try:
            assert truth is not None and cand is not None  # rank 0's
            result = _grade(truth, cand, label, log, surface, located)
        except InputError as exc:
            error = InputError(str(exc))
        except Exception as exc:  # never leave the other ranks waiting
            error = exc
    wait_for_rank0(comm)  # the other ranks asleep meanwhile, not polling in the broadcast
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


# --- compare truth:CASE ----------------------------------------------------------------------

PREFIX = "truth:"


def truth_case(reference: str | Path, reference_field: str | None = None) -> str | None:
    """The SPEC 10 case of a reference given as `truth:CASE`; None for a reference file.
    InputError (one line) for a case without a truth: a point-needle block case (w = 0), the
    large block (a neo-Hookean one, block-MP1-nh-s2-w0.2 as it was), or a name not in SPEC 10's
    table; and for a --reference-field, which a truth has no use for."""
    text = str(reference)
    if not text.startswith(PREFIX):
        return None
    from tissuebench.solvers.truth.cases import CASES

    case = text[len(PREFIX) :]
    if reference_field is not None:
        raise InputError(
            f"{text}: --reference-field does not apply to the truth (its field is the displacement)"
        )
    if case in CASES:
        return case
    from tissuebench.meshes import BENCHMARKS

    for benchmark, entry in BENCHMARKS.items():
        own = ", ".join(c for c in CASES if CASES[c][0] == benchmark)
        hint = entry.truth_hint(case, own)
        if hint is not None:
            raise InputError(f"{text}: {hint}")
    raise InputError(f"{text}: no such truth case; the cases (SPEC 10) are {', '.join(CASES)}")
