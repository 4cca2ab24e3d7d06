"""First-order cells in VTK node order (triangles, quadrilaterals, tetrahedra, hexahedra):
their reference vertices, shape functions, measures and facets, and the location of points
in a mesh of them (SPEC section 9).

A displacement inside a cell is the linear (P1, simplices) or multilinear (Q1) interpolation
of its nodes' values: u_h(X) = Σ_k φ_k(ξ) u_k, with ξ the reference coordinates of X, found by
pulling X back through the cell's own (P1 or Q1) geometry map X(ξ) = Σ_k φ_k(ξ) X_k.
Reference cells are the unit simplex and the unit square or cube, as in basix.
"""

from __future__ import annotations

import itertools

import numpy as np

# Reference coordinates of each VTK node.
REFERENCE = {
    "triangle": np.array([[0, 0], [1, 0], [0, 1]], dtype=np.float64),
    "quadrilateral": np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=np.float64),
    "tetrahedron": np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64),
    "hexahedron": np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        dtype=np.float64,
    ),
}
SIMPLICES = ("triangle", "tetrahedron")
DIM = {"triangle": 2, "quadrilateral": 2, "tetrahedron": 3, "hexahedron": 3}
NAMES = {  # for notes and messages
    "triangle": "triangles",
    "quadrilateral": "quadrilaterals",
    "tetrahedron": "tetrahedra",
    "hexahedron": "hexahedra",
}
# Facets of each cell as cycles of its local nodes: edges in 2D, faces in 3D.
FACETS = {
    "triangle": np.array([[0, 1], [1, 2], [2, 0]]),
    "quadrilateral": np.array([[0, 1], [1, 2], [2, 3], [3, 0]]),
    "tetrahedron": np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]),
    "hexahedron": np.array(
        [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
    ),
}
NEWTON_STEPS = 30  # at most, for the pull-back through a Q1 map
NEWTON_CONVERGED = 1e-8  # |Δξ| (reference units) after which one more step reaches round-off


def _factors(cell_type: str, xi: np.ndarray):
    """Q1: f[0] = 1 − ξ, f[1] = ξ, (2, n, d), and each node's choice R (nodes, d)."""
    return np.stack([1 - xi, xi]), REFERENCE[cell_type].astype(np.int64)


def shape_functions(cell_type: str, xi: np.ndarray) -> np.ndarray:
    """φ_k(ξ) at reference points xi (n, d): an (n, nodes) array (dimensionless)."""
    xi = np.asarray(xi, dtype=np.float64)
    if cell_type in SIMPLICES:
        return np.concatenate([1 - xi.sum(axis=1, keepdims=True), xi], axis=1)
    f, R = _factors(cell_type, xi)  # φ_k = Π_j (ξ_j if R_kj = 1 else 1 − ξ_j)
    phi = f[R[:, 0], :, 0]
    for j in range(1, xi.shape[1]):
        phi = phi * f[R[:, j], :, j]
    return phi.T


def shape_gradients(cell_type: str, xi: np.ndarray) -> np.ndarray:
    """∂φ_k/∂ξ_j at reference points xi (n, d): an (n, nodes, d) array."""
    xi = np.asarray(xi, dtype=np.float64)
    n, d = xi.shape
    if cell_type in SIMPLICES:
        grad = np.concatenate([-np.ones((1, d)), np.eye(d)])
        return np.broadcast_to(grad, (n, d + 1, d)).copy()
    f, R = _factors(cell_type, xi)
    slope = np.array([-1.0, 1.0])  # ∂/∂ξ_j of 1 − ξ_j and of ξ_j
    grad = np.empty((n, len(R), d))
    for j in range(d):
        g = np.repeat(slope[R[:, j]][:, None], n, axis=1)
        for m in range(d):
            if m != j:
                g = g * f[R[:, m], :, m]
        grad[:, :, j] = g.T
    return grad


def solve_small(J: np.ndarray, b: np.ndarray) -> np.ndarray:
    """J⁻¹ b for stacks of 2 x 2 or 3 x 3 matrices J (n, d, d) and vectors b (n, d), by
    Cramer's rule (NaN or inf where J is singular)."""
    if J.shape[1] == 2:
        det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
        x0 = b[:, 0] * J[:, 1, 1] - J[:, 0, 1] * b[:, 1]
        x1 = J[:, 0, 0] * b[:, 1] - b[:, 0] * J[:, 1, 0]
        return np.stack([x0, x1], axis=1) / det[:, None]
    c0, c1, c2 = J[:, :, 0], J[:, :, 1], J[:, :, 2]
    c12 = np.cross(c1, c2)
    det = np.einsum("ni,ni->n", c0, c12)
    x = np.stack(
        [
            np.einsum("ni,ni->n", b, c12),
            np.einsum("ni,ni->n", c0, np.cross(b, c2)),
            np.einsum("ni,ni->n", c0, np.cross(c1, b)),
        ],
        axis=1,
    )
    return x / det[:, None]


def outside(cell_type: str, xi: np.ndarray) -> np.ndarray:
    """How far reference points xi (n, d) lie outside the reference cell, in reference units
    (0 inside or on it): the largest violated inequality ξ_j ≥ 0, ξ_j ≤ 1 (Q1) or Σ ξ_j ≤ 1
    (simplices)."""
    low = np.max(-xi, axis=1)
    high = xi.sum(axis=1) - 1 if cell_type in SIMPLICES else np.max(xi - 1, axis=1)
    return np.maximum(np.maximum(low, high), 0.0)


def pull_back(cell_type: str, X: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Reference coordinates ξ (n, d) of the points x (n, d) in the cells whose nodes are
    X (n, nodes, d), from X(ξ) = x: one linear solve on simplices, Newton's method on Q1 cells
    (from the cell's centre, until one step after a step below NEWTON_CONVERGED; NaN or inf
    where the map is singular). A point outside its cell gets the ξ of the cell's map
    extended beyond it."""
    x = np.asarray(x, dtype=np.float64)
    with np.errstate(all="ignore"):
        if cell_type in SIMPLICES:
            J = (X[:, 1:] - X[:, :1]).transpose(0, 2, 1)  # J_ij = ∂x_i/∂ξ_j
            return solve_small(J, x - X[:, 0])
        n, d = x.shape
        xi = np.full((n, d), 0.5)
        active = np.arange(n)
        last = np.zeros(n, dtype=bool)  # converged: one more step, then done
        for _ in range(NEWTON_STEPS):
            if len(active) == 0:
                break
            Xa, xa = X[active], xi[active]
            residual = np.einsum("pk,pki->pi", shape_functions(cell_type, xa), Xa) - x[active]
            J = np.einsum("pki,pkj->pij", Xa, shape_gradients(cell_type, xa))
            step = solve_small(J, residual)
            xi[active] = xa - step
            size = np.abs(step).max(axis=1)
            done = last[active] | ~np.isfinite(size)
            last[active] = size < NEWTON_CONVERGED
            active = active[~done]
    return xi


def measures(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """|Ω_c| of each cell, ∫ |det J| dξ (area in 2D, volume in 3D; units of the coordinates
    squared or cubed): exact, by 2 Gauss points per direction on Q1 cells."""
    X = points[cells]
    if cell_type in SIMPLICES:
        J = X[:, 1:] - X[:, :1]
        factorial = 2.0 if cell_type == "triangle" else 6.0
        return np.abs(np.linalg.det(J)) / factorial
    d = DIM[cell_type]
    g = np.array([0.5 - 0.5 / np.sqrt(3), 0.5 + 0.5 / np.sqrt(3)])
    xi = np.stack(np.meshgrid(*[g] * d, indexing="ij"), axis=-1).reshape(-1, d)
    grad = shape_gradients(cell_type, xi)  # (q, nodes, d)
    J = np.einsum("cki,qkj->cqij", X, grad)
    return np.abs(np.linalg.det(J)).sum(axis=1) / len(xi)


def boundary_facets(points: np.ndarray, cells: np.ndarray, cell_type: str) -> np.ndarray:
    """The facets that belong to one cell only, as cycles of node indices oriented outward:
    edges (a, b) with the domain on their left (2D), faces whose right-handed normal points
    out of the domain (3D; triangles or quadrilaterals)."""
    local = FACETS[cell_type]
    facets = cells[:, local].reshape(-1, local.shape[1])
    owner = np.repeat(np.arange(len(cells)), len(local))
    key = np.sort(facets, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    single = counts[inverse.ravel()] == 1
    facets, owner = facets[single], owner[single]
    inside = points[cells[owner]].mean(axis=1)
    p = points[facets]
    if p.shape[2] == 2:
        edge, to_inside = p[:, 1] - p[:, 0], inside - p[:, 0]
        keep = edge[:, 0] * to_inside[:, 1] - edge[:, 1] * to_inside[:, 0] > 0
    else:
        if facets.shape[1] == 3:
            normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        else:
            normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
        keep = np.einsum("ij,ij->i", normal, p.mean(axis=1) - inside) > 0
    return np.where(keep[:, None], facets, facets[:, ::-1])


# --- location -------------------------------------------------------------------------------


def match_points(a: np.ndarray, b: np.ndarray, tol: float) -> np.ndarray:
    """match[i] = the index of the point of b within tol of a[i] (in every coordinate); -1
    where there is none. Points are hashed on a grid of spacing tol, so a match lies in the
    same or a neighbouring grid cell."""
    low = np.minimum(a.min(axis=0), b.min(axis=0))
    ka = np.floor((a - low) / tol).astype(np.int64) + 1
    kb = np.floor((b - low) / tol).astype(np.int64) + 1
    span = int(max(ka.max(), kb.max())) + 2

    def encode(k):
        return sum(k[:, j] * span**j for j in range(k.shape[1]))

    keys_b = encode(kb)
    order = np.argsort(keys_b, kind="stable")
    sorted_b = keys_b[order]
    match = np.full(len(a), -1, dtype=np.int64)
    offsets = sorted(
        itertools.product((-1, 0, 1), repeat=a.shape[1]), key=lambda o: np.abs(o).sum()
    )
    for offset in offsets:
        todo = np.flatnonzero(match < 0)
        if len(todo) == 0:
            break
        keys = encode(ka[todo] + np.array(offset))
        pos = np.minimum(np.searchsorted(sorted_b, keys), len(sorted_b) - 1)
        found = order[pos]
        ok = (sorted_b[pos] == keys) & (np.abs(a[todo] - b[found]).max(axis=1) <= tol)
        match[todo[ok]] = found[ok]
    return match


class BoxGrid:
    """Axis-aligned boxes [lo, hi] (n, d) hashed on a uniform grid whose spacing is the median
    box size: `candidates(x)` gives the pairs (point, box) whose box may hold the point."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray):
        self.lo, self.hi = lo, hi
        d = lo.shape[1]
        sides = (hi - lo).max(axis=1)
        self.origin = lo.min(axis=0)
        span = np.maximum(hi.max(axis=0) - self.origin, 0)
        # at most about 8 grid cells per box, however small the median box
        floor = (np.prod(span + sides.max()) / (8 * len(lo))) ** (1 / d)
        self.h = max(0.5 * float(np.median(sides)), float(floor)) or 1.0
        first = self._index(lo)
        last = self._index(hi)
        self.shape = last.max(axis=0) + 1
        counts = last - first + 1
        per_box = counts.prod(axis=1)
        box = np.repeat(np.arange(len(lo)), per_box)
        rest = np.arange(len(box)) - np.repeat(np.cumsum(per_box) - per_box, per_box)
        cell = np.zeros(len(box), dtype=np.int64)
        for j in reversed(range(d)):  # mixed radix: the offset within each box's range
            c = counts[box, j]
            cell = cell * self.shape[j] + first[box, j] + rest % c
            rest //= c
        order = np.argsort(cell, kind="stable")
        self.boxes = box[order]
        self.starts = np.searchsorted(cell[order], np.arange(self.shape.prod() + 1))

    def _index(self, x):
        return np.floor((x - self.origin) / self.h).astype(np.int64)

    def _flat(self, k):
        flat = np.zeros(len(k), dtype=np.int64)
        for j in reversed(range(k.shape[1])):
            flat = flat * self.shape[j] + k[:, j]
        return flat

    def candidates(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(point, box) index pairs with the point inside the box (bounds included)."""
        k = self._index(x)
        valid = np.all((k >= 0) & (k < self.shape), axis=1)
        points = np.flatnonzero(valid)
        flat = self._flat(k[points])
        start, stop = self.starts[flat], self.starts[flat + 1]
        count = stop - start
        point = np.repeat(points, count)
        offset = np.arange(len(point)) - np.repeat(np.cumsum(count) - count, count)
        box = self.boxes[np.repeat(start, count) + offset]
        inside = np.all((x[point] >= self.lo[box]) & (x[point] <= self.hi[box]), axis=1)
        return point[inside], box[inside]


class Locator:
    """Point location in a mesh (points (N, d), cells (VTK order), cell_type): for each query
    point the cell that holds it, or, for a point outside every cell but within `padding`
    (units of the coordinates) of one, the cell it is least outside of (in reference units)."""

    CHUNK = 20_000  # query points per batch (bounds the memory of the cell pairs)

    def __init__(self, points: np.ndarray, cells: np.ndarray, cell_type: str, padding: float):
        self.points, self.cells, self.cell_type = points, cells, cell_type
        X = points[cells]
        self.grid = BoxGrid(X.min(axis=1) - padding, X.max(axis=1) + padding)

    def locate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(cell, ξ, outside) for the points x (n, d): the chosen cell (-1 if no cell is within
        the padding), the reference coordinates in it, and how far outside it the point is
        (reference units, 0 inside; inf without a cell). Among the cells that hold a point,
        the one least outside, then the lowest index, is chosen: the choice depends on the
        point alone, never on the other points asked with it."""
        n, d = x.shape
        cell = np.full(n, -1, dtype=np.int64)
        xi = np.full((n, d), np.nan)
        far = np.full(n, np.inf)
        for start in range(0, n, self.CHUNK):
            part = slice(start, min(start + self.CHUNK, n))
            point, box = self.grid.candidates(x[part])
            ref = pull_back(self.cell_type, self.points[self.cells[box]], x[part][point])
            how_far = outside(self.cell_type, ref)
            how_far[~np.isfinite(how_far)] = np.inf
            order = np.lexsort((box, how_far, point))
            first = order[np.r_[True, point[order][1:] != point[order][:-1]]]
            chosen = start + point[first]
            cell[chosen], xi[chosen], far[chosen] = box[first], ref[first], how_far[first]
        return cell, xi, far


# --- distances to a boundary ----------------------------------------------------------------


def _segment_distance(x, a, b):
    """|x − closest point of the segments ab| (broadcast arrays of points)."""
    ab = b - a
    t = np.einsum("...i,...i->...", x - a, ab) / np.maximum(
        np.einsum("...i,...i->...", ab, ab), 1e-300
    )
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(x - (a + t[..., None] * ab), axis=-1)


def _triangle_distance(x, a, b, c):
    """|x − closest point of the triangles abc| (3D, broadcast arrays of points)."""
    normal = np.cross(b - a, c - a)
    area2 = np.einsum("...i,...i->...", normal, normal)
    # barycentric coordinates of x's projection onto the plane
    w_c = np.einsum("...i,...i->...", np.cross(b - a, x - a), normal) / np.maximum(area2, 1e-300)
    w_b = np.einsum("...i,...i->...", np.cross(x - a, c - a), normal) / np.maximum(area2, 1e-300)
    w_a = 1 - w_b - w_c
    above = np.abs(np.einsum("...i,...i->...", x - a, normal)) / np.sqrt(np.maximum(area2, 1e-300))
    edges = np.minimum(
        np.minimum(_segment_distance(x, a, b), _segment_distance(x, b, c)),
        _segment_distance(x, c, a),
    )
    inside = (w_a >= 0) & (w_b >= 0) & (w_c >= 0) & (area2 > 0)
    return np.where(inside, np.minimum(above, edges), edges)


class Surface:
    """The boundary of a mesh's undeformed domain as segments (2D) or triangles (3D;
    quadrilateral faces split into four triangles through their centre, as SPEC 6 splits
    them), for distances from points to it."""

    def __init__(self, points: np.ndarray, facets: np.ndarray):
        if facets.shape[1] == 4:  # (a, b, m), (b, c, m), ... with m the face's centre
            m = points[facets].mean(axis=1)
            corners = points[facets]
            self.pieces = np.concatenate(
                [np.stack([corners[:, j], corners[:, (j + 1) % 4], m], axis=1) for j in range(4)]
            )
        else:
            self.pieces = points[facets]  # (pieces, 2 or 3, d)
        self.lo, self.hi = self.pieces.min(axis=1), self.pieces.max(axis=1)

    def distance_to(self, x: np.ndarray, pieces: np.ndarray) -> np.ndarray:
        """Distances from the points x (n, d) to the pieces with the given indices (n,) or
        (n, m) (then the array is (n, m))."""
        p = self.pieces[pieces]
        if pieces.ndim == 2:
            x = x[:, None, :]
        if p.shape[-2] == 2:
            return _segment_distance(x, p[..., 0, :], p[..., 1, :])
        return _triangle_distance(x, p[..., 0, :], p[..., 1, :], p[..., 2, :])

    def within(self, x: np.ndarray, tol: float) -> np.ndarray:
        """The distance from each point x (n, d) to the boundary where it is at most tol, inf
        elsewhere."""
        grid = BoxGrid(self.lo - tol, self.hi + tol)
        point, piece = grid.candidates(x)
        best = np.full(len(x), np.inf)
        if len(point):
            np.minimum.at(best, point, self.distance_to(x[point], piece))
        best[best > tol] = np.inf
        return best

    def distance(self, x: np.ndarray) -> np.ndarray:
        """Exact distances from the points x (n, d) to the boundary: for each point only the
        pieces whose bounding box is no farther than the point's nearest piece corner."""
        corners = np.unique(self.pieces.reshape(-1, self.pieces.shape[-1]), axis=0)
        best = np.empty(len(x))
        block = max(1, 1_000_000 // max(len(corners), len(self.pieces)))
        for start in range(0, len(x), block):
            y = x[start : start + block]
            near = np.sqrt(((y[:, None, :] - corners[None]) ** 2).sum(axis=2)).min(axis=1)
            gap = np.maximum(np.maximum(self.lo[None] - y[:, None], y[:, None] - self.hi[None]), 0)
            point, piece = np.nonzero(np.sqrt((gap**2).sum(axis=2)) <= near[:, None])
            found = np.full(len(y), np.inf)
            np.minimum.at(found, point, self.distance_to(y[point], piece))
            best[start : start + block] = found
        return best

    def farthest(self, x: np.ndarray) -> tuple[int, float]:
        """(index, distance) of the point of x (n, d) farthest from the boundary. Points are
        taken in decreasing order of their distance to the boundary's bounding box (a lower
        bound), stopping once no point left can be farther than the farthest so far."""
        low, high = self.lo.min(axis=0), self.hi.max(axis=0)
        bound = np.linalg.norm(np.maximum(np.maximum(low - x, x - high), 0), axis=1)
        order = np.argsort(-bound, kind="stable")
        best, where = -1.0, 0
        for start in range(0, len(order), 256):
            chunk = order[start : start + 256]
            if bound[chunk[0]] < best:
                break
            distance = self.distance(x[chunk])
            k = int(np.argmax(distance))
            if distance[k] > best:
                best, where = float(distance[k]), int(chunk[k])
        return where, best
