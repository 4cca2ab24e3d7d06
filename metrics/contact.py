"""What SPEC 12 and 13 grade of a candidate besides its displacement: its interpenetration with
the rigid tool (from its own series, whatever mesh it is on) and the error of the tool's force
it reports.

The interpenetration at a step is the largest -g_n (m, 0 where nothing passes into the needle)
over the candidate's right edge: its nodes whose reference X lies at the domain's right end
(within 1e-9 of its size), deformed (x = X + u, the in-plane x and y), and SAMPLES points along
each straight deformed segment between consecutive edge nodes sorted by Y, as our own runs
measure it (solvers/contact.py Measures). A 3D slab one element thick (a simulator that has no
plane strain) has its edge nodes on several z layers: each layer is one chain, taken in x, y.
g_n is the tool's signed distance (meshes/tools/) at its centre c(t_i).

In 3D (SPEC 13) the contact surface is the candidate's own: the faces of its cells whose nodes
all lie on it (`on_surface`, the benchmark's predicate), each deformed face (a triangle, or a
bilinear quadrilateral) sampled at SAMPLES_3D points an edge with its nodes.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from tissuebench.meshes.tools import Tool
from tissuebench.solvers.contact import facet_samples

SAMPLES = 9  # points a deformed edge segment (both ends included), as solvers/contact.py
SAMPLES_3D = 7  # points along each edge of a deformed face (SPEC 13: at least 6)
# each cell's faces by its local nodes, VTK order (a quadrilateral in tensor order: 0, 1, 3, 2
# around it, as solvers/contact.py's facet_samples takes it)
FACES = {
    "tetrahedron": ((0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)),
    "hexahedron": (
        (0, 1, 3, 2),
        (4, 5, 7, 6),
        (0, 1, 4, 5),
        (3, 2, 7, 6),
        (0, 3, 4, 7),
        (1, 2, 5, 6),
    ),
}
EDGE_TOLERANCE = 1e-9  # of the domain's size: a node with X this close to its right end is on it


def edge_chains(points: np.ndarray, right: float, size: float) -> list[np.ndarray]:
    """The candidate's right edge as chains of node indices: nodes with |X - right| <=
    EDGE_TOLERANCE * size (m), grouped by their z (3D; rounded to the same tolerance) and
    sorted by Y within each group. [] when no node is on it."""
    points = np.asarray(points, dtype=float)
    tol = EDGE_TOLERANCE * size
    on = np.flatnonzero(np.abs(points[:, 0] - right) <= tol)
    if len(on) == 0:
        return []
    if points.shape[1] < 3:
        layers = [on]
    else:
        z = np.round(points[on, 2] / max(tol, 1e-300)).astype(np.int64)
        layers = [on[z == v] for v in np.unique(z)]
    return [layer[np.argsort(points[layer, 1], kind="stable")] for layer in layers]


def edge_interpenetration(deformed: Sequence[np.ndarray], centre: np.ndarray, tool: Tool) -> float:
    """The largest -g_n (m, >= 0) over the deformed chains (each (k, 2), m, in edge order),
    sampled at SAMPLES points a segment, against `tool` centred at `centre` (m). NaN when a
    point is not finite."""
    s = np.linspace(0.0, 1.0, SAMPLES)[:, None, None]
    worst = 0.0
    for chain in deformed:
        chain = np.asarray(chain, dtype=float)
        if not np.isfinite(chain).all():
            return float("nan")
        if len(chain) == 1:
            sampled = chain
        else:
            sampled = ((1 - s) * chain[None, :-1] + s * chain[None, 1:]).reshape(-1, 2)
        g = tool.signed_distance(sampled, centre)
        worst = max(worst, float(-g.min()))
    return worst


def interpenetration_curve(
    points: np.ndarray,
    displacements: Sequence[np.ndarray],
    times: np.ndarray,
    tool: Tool,
    right: float = 1.0,
    size: float = 1.0,
) -> np.ndarray:
    """The interpenetration (m) at each step of a series: points (n, d) m, displacements one
    (n, d) array (m) per time of `times` (s), `tool` the rigid tool (its centre c(t)); `right`
    (m) the reference X of the contact edge and `size` (m) the domain's. NaN at a step with a
    non-finite displacement on the edge. ValueError when no node lies on the edge."""
    chains = edge_chains(points, right, size)
    if not chains:
        raise ValueError(
            f"no node of the candidate lies on the contact edge x = {right:g} m (within "
            f"{EDGE_TOLERANCE:g} of the domain's size): its interpenetration cannot be measured"
        )
    points = np.asarray(points, dtype=float)
    curve = np.full(len(times), np.nan)
    for i, (t, u) in enumerate(zip(times, displacements, strict=False)):
        u = np.asarray(u, dtype=float)
        x = points[:, :2] + u[:, :2]
        curve[i] = edge_interpenetration([x[c] for c in chains], tool.centre(float(t)), tool)
    return curve


def surface_faces(cells: np.ndarray, cell_type: str, on_surface: np.ndarray) -> np.ndarray:
    """The faces (k, 3 or 4 node indices, a quadrilateral in tensor order) of a 3D mesh's cells
    (VTK order) whose nodes all lie on the surface (`on_surface`, a mask over the nodes), each
    once. ValueError for a cell type without faces here."""
    if cell_type not in FACES:
        raise ValueError(f"the contact surface of {cell_type} cells is not measured here")
    cells = np.asarray(cells, dtype=np.int64)
    faces = np.concatenate([cells[:, list(face)] for face in FACES[cell_type]])
    faces = faces[on_surface[faces].all(axis=1)]
    _, first = np.unique(np.sort(faces, axis=1), axis=0, return_index=True)
    return faces[np.sort(first)]


def surface_interpenetration_curve(
    points: np.ndarray,
    cells: np.ndarray,
    cell_type: str,
    displacements: Sequence[np.ndarray],
    times: np.ndarray,
    tool: Tool,
    on_surface: np.ndarray,
) -> np.ndarray:
    """The interpenetration (m) at each step of a 3D series: the largest -g_n (0 where nothing
    passes into the tool) over its deformed contact faces (surface_faces), each sampled at
    SAMPLES_3D points an edge; points (n, 3) m, cells in VTK order, displacements one (n, 3)
    array (m) per time of `times` (s). NaN at a step with a non-finite displacement there.
    ValueError when no face lies on the surface."""
    faces = surface_faces(cells, cell_type, np.asarray(on_surface, dtype=bool))
    if len(faces) == 0:
        raise ValueError(
            "no face of the candidate's cells lies on the contact surface: its "
            "interpenetration cannot be measured"
        )
    N = facet_samples(faces.shape[1], SAMPLES_3D)
    points = np.asarray(points, dtype=float)
    curve = np.full(len(times), np.nan)
    for i, (t, u) in enumerate(zip(times, displacements, strict=False)):
        x = (points + np.asarray(u, dtype=float))[faces]  # (faces, nodes, 3)
        if not np.isfinite(x).all():
            continue
        g = tool.signed_distance(np.einsum("pv,fvd->fpd", N, x).reshape(-1, 3), tool.centre(t))
        curve[i] = max(0.0, float(-g.min()))
    return curve


def force_error(force: np.ndarray, reference: np.ndarray) -> float:
    """SPEC 12's force error: the largest |F - F_ref| over the steps both have, over the largest
    |F_ref| (dimensionless); force and reference (steps, 2) N/m, or (steps, 3) N in 3D (SPEC
    13 grades the axial component: hand it the z column alone). NaN when they share no step
    or a compared force is not finite."""
    force, reference = np.asarray(force, dtype=float), np.asarray(reference, dtype=float)
    n = min(len(force), len(reference))
    if n == 0:
        return float("nan")
    scale = np.linalg.norm(reference, axis=1).max()
    return float(np.linalg.norm(force[:n] - reference[:n], axis=1).max() / scale)
