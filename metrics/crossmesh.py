"""Grading a candidate on its own mesh M′ against a reference on M (SPEC section 9).

- Same body: every node of either mesh lies within τ = 1e-6 · (the reference's extent) of
  the other mesh's undeformed domain, and |Ω′_0| agrees with |Ω_0| within 1e-6 relative
  (`check_same_body`, on rank 0, before anything is distributed).
- Π u′: the candidate's displacement u′_h evaluated at the reference's nodes X_n, found in
  the undeformed M′ (`Locator`); a reference node within τ of a candidate node (in every
  coordinate, the rule by which compare matches the nodes of one mesh) takes that node's
  value. E_n = ‖Π u′ − u‖ / ‖u‖ and the nodal E_i use Π u′ as section 6 uses u′.
- E_i = |Ω_0|^(−1/d) Σ_cells Σ_q w_q |det J_q| ‖u′_h(x_q) − u_h(x_q)‖, with the reference's
  cells and the quadrature rule that InteriorMetric's form uses, u′_h located at every x_q.
- E_s: Ω′_t is bounded by the candidate's own deformed boundary facets.

The candidate mesh is whole on every rank; each rank locates its own reference nodes and
quadrature points in it, so that a point's value does not depend on the partition.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import cast

from mpi4py import MPI

import basix
import numpy as np
from dolfinx import fem

from tissuebench.metrics.cells import (
    NAMES,
    Locator,
    Surface,
    boundary_facets,
    match_points,
    measures,
    shape_functions,
)
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.surface import domain, surface_error
from tissuebench.metrics.table import METRICS, Metrics

BODY_TOLERANCE = 1e-6  # τ: node distances, as a fraction of the reference's extent
VOLUME_RTOL = 1e-6  # |Ω′_0| within this fraction of |Ω_0|
INSIDE = 1e-9  # a point at most this far outside a cell, in reference units, is inside it


@dataclass
class Mesh:
    """A first-order mesh: points (N, d), cells (VTK order) and their cell_type."""

    points: np.ndarray
    cells: np.ndarray
    cell_type: str

    @classmethod
    def of(cls, series: Series) -> Mesh:
        return cls(series.points, series.cells, series.cell_type)

    def key(self) -> str:
        """A hash of the mesh, node for node and cell for cell (its cell type, points as
        float64 and cells as int64, with their shapes): two series with the same key are on
        the same mesh in the same order, so that whatever is built of one mesh (point
        locations, a run on it) serves the other."""
        h = hashlib.sha256(self.cell_type.encode())
        for a in (np.asarray(self.points, np.float64), np.asarray(self.cells, np.int64)):
            a = np.ascontiguousarray(a)
            h.update(repr(a.shape).encode())
            h.update(a.tobytes())
        return h.hexdigest()


# --- same body ------------------------------------------------------------------------------


def distances_to_domain(x: np.ndarray, mesh: Mesh, tol: float) -> np.ndarray:
    """Distance (units of the coordinates) from each point x (n, d) to the mesh's undeformed
    domain: 0 inside a cell (within INSIDE reference units), else the exact distance to its
    boundary where that is at most tol, else the exact distance found by `Surface.farthest`
    for the farthest such point only, and inf for the others (which are nearer)."""
    cell, _, how_far = Locator(mesh.points, mesh.cells, mesh.cell_type, tol).locate(x)
    distance = np.zeros(len(x))
    out = np.flatnonzero(how_far > INSIDE)
    if len(out) == 0:
        return distance
    surface = Surface(mesh.points, boundary_facets(mesh.points, mesh.cells, mesh.cell_type))
    distance[out] = surface.within(x[out], tol)
    far = out[np.isinf(distance[out])]
    if len(far):
        k, d = surface.farthest(x[far])
        distance[far] = np.inf
        distance[far[k]] = d
    return distance


def farthest_node(distance: np.ndarray) -> int:
    """The node of largest distance; among infinite ones (nearer than the finite farthest one
    of them, see distances_to_domain), that finite one."""
    finite = np.where(np.isinf(distance), -1.0, distance)
    return int(np.argmax(finite))


def _at(points: np.ndarray, i: int) -> str:
    return f"({', '.join(f'{x:.9g}' for x in points[i])})"


def curved_allowance(series: Series, body: dict | None) -> float:
    """How far (m) a faceted mesh of a body with a curved side may lie from the true side
    (SPEC 13: "a faceted candidate's side lies within its facets' sagitta"): for a body of
    revolution about z (its entry's body states its "radius" R: the cylinder), the largest
    R (1 - cos(theta / 2)) over the mesh's boundary facets whose nodes all lie on r = R
    (within 1e-6 R), theta the largest angle its nodes span about the axis; 0 for any other
    body."""
    if not body or "radius" not in body or series.points.shape[1] != 3:
        return 0.0  # a box (no radius: no curved side)
    R = float(body["radius"])
    points = np.asarray(series.points, dtype=float)
    r = np.hypot(points[:, 0], points[:, 1])
    facets = boundary_facets(points, series.cells, series.cell_type)
    side = facets[(np.abs(r[facets] - R) <= 1e-6 * R).all(axis=1)]
    if len(side) == 0:
        return 0.0
    angle = np.arctan2(points[:, 1], points[:, 0])[side]  # (facets, nodes)
    spread = np.abs(angle[:, :, None] - angle[:, None, :])
    spread = np.minimum(spread, 2 * np.pi - spread).max(axis=(1, 2))
    return float(R * (1 - np.cos(spread.max() / 2)))


def boundary_area(series: Series) -> float:
    """The area (units of the coordinates squared) of a 3D mesh's boundary, its facets split
    into triangles from their first node; the length of a 2D mesh's boundary."""
    points = np.asarray(series.points, dtype=float)
    facets = boundary_facets(points, series.cells, series.cell_type)
    if points.shape[1] == 2:
        return float(np.linalg.norm(points[facets[:, 1]] - points[facets[:, 0]], axis=1).sum())
    total = 0.0
    for k in range(1, facets.shape[1] - 1):
        a, b, c = (points[facets[:, i]] for i in (0, k, k + 1))
        total += float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum() / 2)
    return total


def _farthest(checks: list, tol: float) -> tuple[float, str, str]:
    """Of checks (who, points located, the other side's Mesh, the points as shown): the largest
    distance of a node to the other side's undeformed domain (distances_to_domain within tol),
    the node as a phrase, and the other side's name."""
    worst = []
    for who, points, other, shown in checks:
        distance = distances_to_domain(points, other, tol)
        node = farthest_node(distance)
        other_name = "candidate" if who == "reference" else "reference"
        worst.append(
            (float(distance[node]), f"{who} node {node} at {_at(shown, node)}", other_name)
        )
    return max(worst, key=lambda w: w[0])


def _within(pairs: list, tol: float, where: str, said: str) -> tuple[float, str, str]:
    """_farthest of `pairs`, refused in one line (InputError, `where` first) beyond `tol` (m),
    `said` saying how tol is made."""
    distance, phrase, other_name = _farthest(pairs, tol)
    if distance > tol:
        raise InputError(
            f"{where}: {phrase} is {distance:.3g} from the {other_name}'s undeformed domain, "
            f"beyond {tol:.3g} ({said})"
        )
    return distance, phrase, other_name


def check_same_body(ref: Series, cand: Series, body: dict | None = None) -> tuple[str, float]:
    """Refuse (InputError, one line naming the farthest node and its distance) a candidate mesh
    that is not a mesh of the reference's body (see the module docstring). A body with a
    curved side (`body`, its entry's: the cylinder) allows the larger of the two meshes' facet
    sagittas beside tau (curved_allowance), and their volumes to differ by that allowance times
    the reference's boundary area. Returns the farthest node (a phrase) and its distance
    (units of the coordinates)."""
    extent = float(np.ptp(ref.points, axis=0).max())
    allowance = max(curved_allowance(ref, body), curved_allowance(cand, body))
    tol = BODY_TOLERANCE * extent + allowance
    said = f"1e-6 of the reference's extent {extent:.6g}"
    if allowance:
        said += f", plus the curved side's facet sagitta {allowance:.3g}"
    where = f"{cand.path}: not a mesh of the body of {ref.path}"
    distance, phrase, other_name = _within(
        [("reference", ref.points, Mesh.of(cand), ref.points),
         ("candidate", cand.points, Mesh.of(ref), cand.points)], tol, where, said
    )  # fmt: skip
    v_ref = float(measures(ref.points, ref.cells, ref.cell_type).sum())
    v_cand = float(measures(cand.points, cand.cells, cand.cell_type).sum())
    bound = VOLUME_RTOL * v_ref + (allowance * boundary_area(ref) if allowance else 0.0)
    if abs(v_cand - v_ref) > bound:
        what = "area" if ref.dim == 2 else "volume"
        beyond = f"{bound / v_ref:.3g}" if allowance else "1e-6"
        raise InputError(
            f"{where}: its {what} {v_cand:.9g} differs from the reference's {v_ref:.9g} by "
            f"{abs(v_cand - v_ref) / v_ref:.3g} relative, beyond {beyond} (the farthest node, "
            f"{phrase}, is {distance:.3g} from the {other_name}'s undeformed domain)"
        )
    return phrase, distance


def check_same_revolved_body(
    meridian: Series, revolved: Series, cand: Series, allowance: float
) -> tuple[str, float]:
    """check_same_body for a truth computed on a meridian (SPEC 13) and revolved: the
    candidate's nodes, taken to (r, z), within tau plus `allowance` (m, the faceted side's
    sagitta) of the meridian's domain (the exact body of revolution: the revolved mesh's cells
    on the axis are wedges that cannot locate a point), the revolved truth's vertices within
    as much of the candidate's domain, and the candidate's volume within the allowance times
    the revolved body's boundary area of the revolved truth's. Returns the farthest node (a
    phrase) and its distance (m); InputError (one line) otherwise."""
    extent = float(np.ptp(revolved.points, axis=0).max())
    tol = BODY_TOLERANCE * extent + allowance
    said = f"1e-6 of the reference's extent {extent:.6g}, plus the curved side's facet sagitta "
    said += f"{allowance:.3g}"
    rz = np.column_stack([np.hypot(cand.points[:, 0], cand.points[:, 1]), cand.points[:, 2]])
    where = f"{cand.path}: not a mesh of the body of {revolved.path}"
    distance, phrase, other_name = _within(
        [("candidate", rz, Mesh.of(meridian), cand.points),
         ("reference", revolved.points, Mesh.of(cand), revolved.points)], tol, where, said
    )  # fmt: skip
    r, z = meridian.points[:, 0], meridian.points[:, 1]
    radius, height = float(r.max()), float(np.ptp(z))
    v_ref = np.pi * radius**2 * height  # the body of revolution: the meridian's box revolved
    v_cand = float(measures(cand.points, cand.cells, cand.cell_type).sum())
    bound = VOLUME_RTOL * v_ref + allowance * 2 * np.pi * radius * (radius + height)
    if abs(v_cand - v_ref) > bound:
        raise InputError(
            f"{where}: its volume {v_cand:.9g} differs from the revolved body's {v_ref:.9g} by "
            f"{abs(v_cand - v_ref) / v_ref:.3g} relative, beyond {bound / v_ref:.3g} (the "
            f"farthest node, {phrase}, is {distance:.3g} from the {other_name}'s undeformed "
            "domain)"
        )
    return phrase, distance


def quadrature_points(cell_type: str, points: int = 3) -> int:
    """The number of quadrature points per cell of InteriorMetric with `points` Gauss points per
    direction (the rule of degree 2 points − 1)."""
    weights = cast(np.ndarray, basix.make_quadrature(basix.CellType[cell_type], 2 * points - 1)[1])
    return len(weights)


def note(ref: Series, cand: Series, points: int = 3) -> str:
    """One line saying that the candidate is graded on its own mesh, and where u′ is
    evaluated."""
    q = len(ref.cells) * quadrature_points(ref.cell_type, points)
    return (
        f"candidate on its own mesh: {len(cand.points):,} nodes, {NAMES[cand.cell_type]} "
        f"(reference: {len(ref.points):,} nodes, {NAMES[ref.cell_type]}); interpolated at the "
        f"reference's {len(ref.points):,} nodes and {q:,} quadrature points"
    )


# --- evaluation -----------------------------------------------------------------------------


class PointValues:
    """u′_h at fixed points of the candidate mesh: (Σ_k φ_k(ξ_p) u′_{c_p,k})_p for nodal values
    u′ (N′, d), from the points' cells and reference coordinates. `missing`: the points
    farther than the locator's padding from every cell."""

    def __init__(self, locator: Locator, x: np.ndarray, snap: float | None = None):
        mesh_points, cells, cell_type = locator.points, locator.cells, locator.cell_type
        cell, xi, _ = locator.locate(x)
        self.missing = np.flatnonzero(cell < 0)
        found = np.where(cell < 0, 0, cell)
        self.nodes = cells[found]  # (n, nodes per cell)
        self.weights = shape_functions(cell_type, np.nan_to_num(xi))
        if snap is not None and len(x):
            same = match_points(x, mesh_points, snap)  # a node of M′ here: its own value
            hit = np.flatnonzero(same >= 0)
            self.nodes[hit] = same[hit, None]
            self.weights[hit] = 0.0
            self.weights[hit, 0] = 1.0
            self.missing = np.setdiff1d(self.missing, hit)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        """u′_h at the points, (n, d)."""
        components = np.ascontiguousarray(np.asarray(u).T)  # gathers of rows are the fastest
        return np.stack([np.einsum("pk,pk->p", self.weights, c[self.nodes]) for c in components], 1)

    def steps(self, u: np.ndarray) -> np.ndarray:
        """u′_h at the points for several steps at once: u (steps, N′, d) -> (steps, n, d)."""
        return np.einsum("pk,spkd->spd", self.weights, u[:, self.nodes, :])


class CrossInterior:
    """E_i of a candidate on its own mesh by quadrature on V's cells (the rule of
    InteriorMetric), and the nodal form from Π u′. `candidate` holds the candidate's nodal
    displacement (N′, d) being graded (set by CrossMetrics.evaluate)."""

    def __init__(self, V: fem.FunctionSpace, reference, locator: Locator, points: int = 3):
        mesh = V.mesh
        self.reference = reference  # the InteriorMetric of V: weights, volume, scale
        self.comm, self.dim = mesh.comm, mesh.geometry.dim
        self.owned = reference.owned
        d, tdim = self.dim, mesh.topology.dim
        cells = mesh.topology.index_map(tdim).size_local
        cell = basix.CellType[mesh.topology.cell_name()]
        # basix annotates its arrays as ArrayLike
        xi, w = cast(tuple[np.ndarray, np.ndarray], basix.make_quadrature(cell, 2 * points - 1))
        element = basix.create_element(basix.ElementFamily.P, cell, 1)
        table = cast(np.ndarray, element.tabulate(1, xi))[..., 0]
        self.phi = table[0]  # (q, nodes): V's and the geometry's P1/Q1 basis at ξ_q
        X = mesh.geometry.x[mesh.geometry.dofmaps[0][:cells], :d]  # (cells, nodes, d)
        x_q = np.einsum("qk,cki->cqi", self.phi, X)
        J = np.einsum("jqk,cki->cqij", table[1:], X)
        self.dx = w * np.abs(np.linalg.det(J))  # w_q |det J_q|, (cells, q)
        self.dofs = V.dofmap.list[:cells]  # nodes of V, in the basis' order
        self.points = x_q.reshape(-1, d)
        self.at_points = PointValues(locator, self.points)
        self.shape = x_q.shape
        self.e = fem.Function(V)
        self.candidate: np.ndarray | None = None

    def quadrature(self, u_ref: np.ndarray, at_nodes: np.ndarray) -> float:
        """E_i = |Ω_0|^(−1/d) Σ_c Σ_q w_q |det J_q| ‖u′_h(x_q) − u_h(x_q)‖ (`at_nodes` unused:
        u′_h comes from the candidate's own nodes)."""
        self.e.x.array[: self.owned] = u_ref
        self.e.x.scatter_forward()
        u = self.e.x.array.reshape(-1, self.dim)[self.dofs]  # (cells, nodes, d)
        u_h = np.matmul(self.phi, u)  # (cells, q, d): Σ_k φ_k(ξ_q) u_k
        assert self.candidate is not None  # set by CrossMetrics.evaluate
        u_cand = self.at_points(self.candidate).reshape(self.shape)
        local = float(np.sum(self.dx * np.linalg.norm(u_cand - u_h, axis=2)))
        return self.reference.scale * self.comm.allreduce(local, op=MPI.SUM)

    def nodal(self, u_ref: np.ndarray, at_nodes: np.ndarray) -> float:
        """The nodal form |Ω_0|^(−1/d) Σ_n w_n ‖(Π u′)_n − u_n‖."""
        return self.reference.nodal(u_ref, at_nodes)


class CrossMetrics:
    """The metrics of METRICS for a candidate on its own mesh M′ (whole on every rank) against
    a reference on V. `evaluate(u_ref, u_cand)` takes V's owned dof values and the candidate's
    nodal displacement (N′, d); each metric is given Π u′ as its candidate (E_n and the nodal
    E_i as SPEC 9 defines them), while E_i and E_s take u′ from M′ itself.

    Collective. Raises InputError on every rank if some reference node or quadrature point
    lies farther than `tol` (units of the coordinates) outside M′ (`where` starts the message).
    """

    comm: MPI.Comm
    interior: CrossInterior

    def __init__(
        self, V: fem.FunctionSpace, candidate: Mesh, tol: float, where: str, points: int = 3
    ):
        self.comm, self.dim = V.mesh.comm, V.mesh.geometry.dim
        self.metrics = Metrics(V, points)
        locator = Locator(candidate.points, candidate.cells, candidate.cell_type, tol)
        owned = V.dofmap.index_map.size_local
        X = V.tabulate_dof_coordinates()[:owned, : self.dim]
        self.at_nodes = PointValues(locator, X, snap=tol)
        self.interior = CrossInterior(V, self.metrics.interior, locator, points)
        self._check_located(X, tol, where)
        self.candidate: np.ndarray | None = None
        if self.comm.rank == 0:
            facets = boundary_facets(candidate.points, candidate.cells, candidate.cell_type)
            self.boundary_nodes = np.unique(facets)
            self.X_b = candidate.points[self.boundary_nodes]  # its undeformed boundary nodes
            self.shape = domain(self.X_b, np.searchsorted(self.boundary_nodes, facets))

    def _check_located(self, X: np.ndarray, tol: float, where: str) -> None:
        """Refuse, on every rank, reference nodes or quadrature points outside M′ by more than
        tol (possible only where M′ passed check_same_body but its boundary cuts inside V's
        cells)."""
        nodes, q = self.at_nodes.missing, self.interior.at_points.missing
        first = X[nodes[0]] if len(nodes) else self.interior.points[q[0]] if len(q) else None
        what = "reference node" if len(nodes) else "quadrature point of the reference"
        everyone = self.comm.allgather((len(nodes), len(q), first, what))
        lost_nodes, lost_points = sum(e[0] for e in everyone), sum(e[1] for e in everyone)
        if lost_nodes + lost_points == 0:
            return
        _, _, point, what = next(e for e in everyone if e[2] is not None)
        raise InputError(
            f"{where}: {lost_nodes} reference node(s) and {lost_points} quadrature point(s) lie "
            f"farther than {tol:.3g} outside the candidate's mesh, e.g. the {what} at "
            f"({', '.join(f'{c:.9g}' for c in point)})"
        )

    def surface(self, u_ref: np.ndarray, at_nodes: np.ndarray) -> float:
        """E_s with Ω′_t bounded by the candidate's own deformed boundary (`at_nodes` unused)."""
        boundary = self.metrics.boundary
        x_ref = boundary.gather(u_ref)
        value = None
        if self.comm.rank == 0:
            assert self.candidate is not None and self.metrics.domain is not None  # evaluate's
            x_cand = self.X_b + self.candidate[self.boundary_nodes]
            value = surface_error(self.metrics.domain, boundary.X + x_ref, x_cand, self.shape)
        return self.comm.bcast(value, root=0)

    def evaluate(
        self, u_ref: np.ndarray, u_cand: np.ndarray, names: tuple[str, ...] | None = None
    ) -> dict[str, float]:
        """The metrics `names` (default: all of METRICS) of the candidate's nodal displacement
        u_cand (N′, d) against V's owned dof values u_ref, a dict keyed by name."""
        u_ref = self.metrics._check(u_ref)
        self.candidate = self.interior.candidate = np.asarray(u_cand, dtype=np.float64)
        at_nodes = self.at_nodes(self.candidate).ravel()
        return {
            name: float(METRICS[name].value(self, u_ref, at_nodes)) for name in names or METRICS
        }
