"""The surface error E_s = |Ω_t ⊕ Ω'_t| / |Ω_t| (SPEC 6.2), on rank 0, from the deformed
boundary nodes x = X + u of a `Boundary`.

2D: the deformed domain is the polygon through the deformed boundary nodes, made valid by
shapely (a boundary that crosses itself is split at its crossings, never dropped).
3D: each deformed quadrilateral face is split into four triangles through its centre
(triangular faces, of tetrahedra, are taken as they are), and the closed triangle surface
becomes a manifold3d solid (double precision, Mesh64);
|A ⊕ B| = |A| + |B| - 2 |A ∩ B|. That difference of volumes carries round-off of a few
machine epsilons relative to |A| (identical shapes gave -4.4e-16 and +4.4e-16): 3D values
below ROUND_OFF are reported as 0, so E_s is never negative (a volume cannot be) and
identical shapes give exactly 0.

The two domains may be bounded by different boundaries (a candidate on its own mesh, SPEC
section 9): `surface_error(shape, x_ref, x_cand, cand_shape)`.
"""

from __future__ import annotations

import manifold3d
import numpy as np
import shapely

# 3D: |A| + |B| - 2 |A ∩ B| subtracts volumes of about 2 |A|; below this (relative to |A|)
# the result is round-off of that subtraction, not a volume.
ROUND_OFF = 16 * np.finfo(np.float64).eps


def signed_area(points: np.ndarray) -> float:
    """Shoelace area of a closed polygon, positive when counter-clockwise."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def loops(edges: np.ndarray) -> list[np.ndarray]:
    """The closed loops (arrays of node positions) traced by oriented edges (a, b)."""
    following = dict(zip(edges[:, 0].tolist(), edges[:, 1].tolist(), strict=True))
    if len(following) != len(edges):
        raise ValueError("the boundary touches itself at a node: its loops are ambiguous")
    result = []
    while following:
        start = min(following)
        loop = [start]
        while (node := following.pop(loop[-1])) != start:
            loop.append(node)
        result.append(np.array(loop))
    return result


class Polygon:
    """The 2D deformed domain, bounded by the loops of oriented boundary edges.

    Loops are counter-clockwise (shells) or clockwise (holes) on the undeformed mesh, since
    the domain lies on the left of every edge; each hole belongs to the smallest shell
    around it.
    """

    def __init__(self, X, edges):
        all_loops = loops(edges)
        shells = [loop for loop in all_loops if signed_area(X[loop]) > 0]
        holes = [loop for loop in all_loops if signed_area(X[loop]) < 0]
        areas = [signed_area(X[shell]) for shell in shells]
        self.parts = [(shell, []) for shell in shells]
        for hole in holes:
            around = [
                i
                for i, shell in enumerate(shells)
                if shapely.Polygon(X[shell]).contains(shapely.Point(X[hole[0]]))
            ]
            self.parts[min(around, key=areas.__getitem__)][1].append(hole)

    def region(self, x: np.ndarray) -> shapely.Geometry:
        """The valid (multi)polygon bounded by the deformed loops through x."""
        pieces = []
        for shell, holes in self.parts:
            valid = shapely.make_valid(shapely.Polygon(x[shell], [x[hole] for hole in holes]))
            pieces += [
                p for p in shapely.get_parts(valid) if p.geom_type in ("Polygon", "MultiPolygon")
            ]
        return shapely.union_all(pieces)

    def error(self, ref: shapely.Geometry, cand: shapely.Geometry) -> np.float64:
        """|A ⊕ B| / |A| for two of its regions, A (ref) and B (cand); NaN if |A| = 0."""
        if not ref.area > 0:
            return np.float64(np.nan)
        return np.float64(shapely.symmetric_difference(ref, cand).area) / ref.area


class Solid:
    """The 3D deformed domain, bounded by outward faces: quadrilaterals (a, b, c, d), each split
    into the triangles (a, b, m), (b, c, m), (c, d, m), (d, a, m) through its centre m, or
    triangles (a, b, c), taken as they are."""

    def __init__(self, X, faces):
        if faces.shape[1] == 3:
            self.quads = None
            self.triangles = np.ascontiguousarray(faces, dtype=np.uint64)
            return
        self.quads = quads = faces
        a, b, c, d = quads.T
        m = len(X) + np.arange(len(quads))
        triangles = [np.stack(t, axis=1) for t in ((a, b, m), (b, c, m), (c, d, m), (d, a, m))]
        self.triangles = np.ascontiguousarray(np.concatenate(triangles), dtype=np.uint64)

    def region(self, x: np.ndarray) -> manifold3d.Manifold:
        """The manifold3d solid bounded by the (split) faces through x."""
        if self.quads is None:
            vertices = x
        else:
            vertices = np.vstack([x, x[self.quads].mean(axis=1)])
        solid = manifold3d.Manifold(
            manifold3d.Mesh64(
                vert_properties=np.ascontiguousarray(vertices, dtype=np.float64),
                tri_verts=self.triangles,
            )
        )
        if solid.status() != manifold3d.Error.NoError:
            raise RuntimeError(
                f"the deformed boundary is not a closed oriented surface: {solid.status()}"
            )
        return solid

    def error(self, ref: manifold3d.Manifold, cand: manifold3d.Manifold) -> np.float64:
        """|A ⊕ B| / |A| for two of its solids, A (ref) and B (cand), from
        |A| + |B| - 2 |A ∩ B|; NaN if |A| = 0. That difference has round-off of a few eps
        relative to |A| and can come out negative (-4.4e-16 for identical shapes): a value
        below ROUND_OFF (16 eps, 3.6e-15), negative ones included, is clipped to 0, since a
        volume cannot be negative; identical shapes thus give exactly 0."""
        if not ref.volume() > 0:
            return np.float64(np.nan)
        common = (ref ^ cand).volume()  # manifold3d: ^ is the intersection
        value = np.float64(ref.volume() + cand.volume() - 2 * common) / ref.volume()
        return np.float64(0.0) if value < ROUND_OFF else value


def domain(X: np.ndarray, facets: np.ndarray) -> Polygon | Solid:
    """Polygon (2D edges) or Solid (3D quadrilateral or triangular faces) for the undeformed
    boundary."""
    return Polygon(X, facets) if facets.shape[1] == 2 else Solid(X, facets)


def surface_error(
    shape: Polygon | Solid,
    x_ref: np.ndarray,
    x_cand: np.ndarray,
    cand_shape: Polygon | Solid | None = None,
    ref_region: shapely.Geometry | manifold3d.Manifold | None = None,
) -> float:
    """E_s of a Polygon or Solid for deformed boundary nodes x_ref, x_cand; NaN if either is
    not finite or the reference domain is empty or of zero area (2D) or volume (3D). The
    candidate's domain is bounded by `cand_shape` through x_cand when given (its own
    boundary), else by `shape`. `ref_region`: shape.region(x_ref), where the caller built it
    (one reference step against several candidates: metrics/table.py)."""
    if not (np.isfinite(x_ref).all() and np.isfinite(x_cand).all()):
        return np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        ref = shape.region(x_ref) if ref_region is None else ref_region
        if cand_shape is None and np.array_equal(x_ref, x_cand):
            # one shape against itself (the reference's own row): |A ⊕ A| = 0, what the
            # boolean gives (its round-off clipped in 3D), without its cost (5 ms on the rod)
            size = ref.area if isinstance(shape, Polygon) else ref.volume()
            return 0.0 if size > 0 else np.nan
        cand = (shape if cand_shape is None else cand_shape).region(x_cand)
        return float(shape.error(ref, cand))
