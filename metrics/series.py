"""Displacement time series (Series) as the metrics take them, and their checks; the files they are
read from (workflows/io/series.py) are described here since their rules are the Series'.

Formats: XDMF with HDF5 (or inline XML) data, as DOLFINx's XDMFFile.write_function and
meshio's TimeSeriesWriter write it, ParaView .pvd collections of .vtu files, and CalculiX's
ASCII .frd and .dat (with its deck, the .inp beside it; workflows/io/calculix.py). The mesh is
first order, of one cell type: triangles or quadrilaterals (2D; a zero third coordinate, as
meshio and ParaView store 2D data, is dropped), tetrahedra or hexahedra (3D); the
displacement is P1 on simplices and Q1 on the others (SPEC section 9). Cells are returned in
VTK node order, as the files hold them. Every step must hold the first step's mesh: the same
nodes in the same order (a step whose nodes move or are numbered otherwise is refused, not
matched by coordinates) and the same cells. Values must be real numbers (a complex field is
refused); a non-finite value in any component, the third of 2D data included, is kept as
non-finite, so that the step counts as diverged (metrics/compare.py). Anything else raises
InputError with one line naming the file and the problem.

The field: a name, taken as it is; or none, and then the first of io.series.DEFAULT_FIELDS
that the file holds (`displacement` as we write it, `U` and `DISP` as CalculiX names it, ...).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from tissuebench.core.errors import UserError
from tissuebench.metrics.cells import DIM, FACETS, NAMES

# file cell names (XDMF topology types lower-cased, meshio's names) -> (our cell type, nodes
# per cell)
CELLS = {
    "triangle": ("triangle", 3),
    "quadrilateral": ("quadrilateral", 4),
    "quad": ("quadrilateral", 4),
    "tetrahedron": ("tetrahedron", 4),
    "tetra": ("tetrahedron", 4),
    "hexahedron": ("hexahedron", 8),
}


class InputError(UserError):
    """Input files that cannot be compared: the message is one line naming file and problem."""


# Coordinates (in any unit) within +-COORDINATE_RANGE, spanning more than 1/COORDINATE_RANGE:
# the metrics' sums, areas and volumes of such a mesh, displaced by up to 100 times its extent
# (beyond that a series has diverged, SPEC section 3), cannot overflow or underflow.
COORDINATE_RANGE = 1e50
SAME_NODE = 1e-6  # a later step's node is the first step's within this fraction of the extent


@dataclass
class Series:
    """A displacement time series on one mesh: points (n, d), cells (VTK node order),
    cell_type ("triangle", "quadrilateral", "tetrahedron" or "hexahedron"), times (steps,)
    and displacements, a list of
    (n, d) arrays, one per time; `field` is the name it was read from."""

    path: Path
    points: np.ndarray
    cells: np.ndarray
    cell_type: str
    times: np.ndarray
    displacements: list
    field: str = "displacement"

    @property
    def dim(self) -> int:
        return self.points.shape[1]


def series_of(
    path: Path,
    field: str,
    points: ArrayLike,
    cells: ArrayLike,
    cell_type: str,
    times: ArrayLike,
    values: np.ndarray | list[Any],
) -> Series:
    """The Series read from `path` (named in errors): its arrays as a file holds them (cell type
    by the file's name, 2D data possibly with a zero third coordinate), checked, reduced to d
    columns; InputError (one line) for anything that cannot be graded. A list of `values` is
    consumed step by step (each entry set to None once converted; float64 steps are kept as
    they are, not copied), so that the peak memory stays near one copy of the series."""
    if cell_type not in CELLS:
        raise InputError(
            f"{path}: cells of type {cell_type!r}; only first-order triangles, quadrilaterals, "
            "tetrahedra and hexahedra are supported"
        )
    cell_type, per_cell = CELLS[cell_type]
    points = real(path, points, "point coordinates")
    cells = np.asarray(cells, dtype=np.int64)
    n = len(points)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or n == 0:
        raise InputError(
            f"{path}: point coordinates of shape {points.shape}, expected (n, 2) or (n, 3)"
        )
    if cells.ndim != 2 or cells.shape[1] != per_cell or len(cells) == 0:
        raise InputError(
            f"{path}: {cell_type} cells of shape {cells.shape}, expected (cells, {per_cell})"
        )
    if cells.min() < 0 or cells.max() >= n:
        raise InputError(f"{path}: cells refer to points outside 0..{n - 1}")
    if not np.isfinite(points).all():
        raise InputError(f"{path}: point coordinates are not finite")
    largest, extent = float(np.abs(points).max()), float(np.ptp(points, axis=0).max())
    if largest > COORDINATE_RANGE or extent <= 1 / COORDINATE_RANGE:
        raise InputError(
            f"{path}: point coordinates reach {largest:.3g} and span {extent:.3g}; only "
            f"coordinates within +-{COORDINATE_RANGE:g} that span more than "
            f"{1 / COORDINATE_RANGE:g} can be graded (in any unit)"
        )
    dim = DIM[cell_type]
    if points.shape[1] < dim:
        raise InputError(f"{path}: {NAMES[cell_type]} with 2D points")
    if points.shape[1] > dim and np.any(points[:, dim:] != 0):
        raise InputError(
            f"{path}: {NAMES[cell_type]} with a non-zero third coordinate (a surface in 3D is "
            "not supported)"
        )
    points = np.ascontiguousarray(points[:, :dim])
    check_cells(path, points, cells, cell_type)
    check_boundary(path, points, cells, cell_type)
    times = np.asarray(times, dtype=np.float64)
    if len(times) == 0:
        raise InputError(f"{path}: no time steps")
    if not np.isfinite(times).all():
        raise InputError(f"{path}: time stamps are not finite")
    if np.any(np.diff(times) <= 0):
        raise InputError(f"{path}: time stamps are not increasing")
    if len(values) != len(times):
        raise InputError(f"{path}: {len(values)} steps of field {field!r}, {len(times)} times")
    displacements = []
    for k, t in enumerate(times):
        u = real(path, values[k], f"field {field!r} at time {t:g}")
        if isinstance(values, list):
            values[k] = None  # the step as read is released once converted: one copy at most
        if u.ndim != 2 or u.shape[0] != n or u.shape[1] < dim or u.shape[1] > 3:
            raise InputError(
                f"{path}: field {field!r} at time {t:g} has shape {u.shape}, expected ({n}, {dim})"
            )
        displacements.append(planar(path, u, dim, f"field {field!r} at time {t:g}"))
    return Series(path, points, cells, cell_type, times, displacements, field)


def real(path: Path | str, data: ArrayLike, what: str) -> np.ndarray:
    """`data` as float64, refusing (InputError) complex and non-numeric values: a complex field
    is not graded on its real part. Values beyond float64's range become +-inf. float64 data
    is returned as it is (no copy)."""
    data = np.asarray(data)
    if data.dtype.kind == "c":
        raise InputError(
            f"{path}: {what} is complex-valued ({data.dtype}); only real values can be graded"
        )
    if data.dtype.kind not in "iuf":
        raise InputError(f"{path}: {what} is not numbers (data type {data.dtype})")
    with np.errstate(over="ignore"):
        return data.astype(np.float64, copy=False)


def planar(path: Path, u: np.ndarray, dim: int, what: str) -> np.ndarray:
    """The first `dim` columns of nodal values u (n, 2 or 3) of a mesh of dimension `dim`. A
    third column of 2D data must be zero where it is finite (InputError otherwise); a node
    whose third component is NaN or +-inf gets NaN in its kept ones, so that the step stays
    non-finite (a divergence)."""
    if u.shape[1] == dim:
        return np.ascontiguousarray(u)
    extra = u[:, dim:]
    finite = np.isfinite(extra)
    if np.any(finite & (extra != 0)):
        raise InputError(f"{path}: 2D mesh but {what} has a non-zero third component")
    kept = np.array(u[:, :dim])
    kept[~finite.all(axis=1)] = np.nan
    return kept


def check_same_mesh(
    where: str, first: tuple[ArrayLike, ArrayLike | None], step: tuple[ArrayLike, ArrayLike | None]
) -> None:
    """Refuse (InputError, `where` naming the file and step) a step whose points (n, 2 or 3)
    or cells differ from the first step's: the nodes must be the same, in the same order,
    within SAME_NODE of the first step's extent, and the cells the same. Node values are read
    in the first step's order, so a renumbered or moved mesh would be graded wrongly."""
    (points, cells), (step_points, step_cells) = first, step
    points, step_points = np.asarray(points), np.asarray(step_points)
    if step_points.shape != points.shape:
        raise InputError(
            f"{where}: points of shape {step_points.shape}, the first step's {points.shape} "
            "(every step must keep the first step's mesh)"
        )
    points, step_points = real(where, points, "points"), real(where, step_points, "points")
    tol = SAME_NODE * float(np.ptp(points, axis=0).max(initial=0.0))
    moved = np.flatnonzero(~(np.abs(step_points - points).max(axis=1) <= tol))
    if len(moved):
        i = moved[0]
        at = ", ".join(f"{x:.9g}" for x in step_points[i])
        raise InputError(
            f"{where}: node {i} is at ({at}), in the first step at "
            f"({', '.join(f'{x:.9g}' for x in points[i])}): {len(moved)} node(s) moved or "
            "numbered otherwise; every step must keep the first step's nodes, in their order, "
            "at their undeformed coordinates"
        )
    if not np.array_equal(np.asarray(step_cells), np.asarray(cells)):
        raise InputError(
            f"{where}: the cells differ from the first step's; every step must keep the first "
            "step's mesh"
        )


# --- mesh checks ----------------------------------------------------------------------------

# Faces of a VTK hexahedron, each a cycle of its four corners; edges of a VTK quadrilateral.
HEX_FACES = np.array(
    [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
)
QUAD_EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])
# A VTK hexahedron as six tetrahedra (0, 6, a, b) around its diagonal 0-6, (a, b) going round
# the cycle 1-2-3-7-4-5 of the corners that are neither 0 nor 6.
HEX_RING = np.array([1, 2, 3, 7, 4, 5])
DEGENERATE = 1e-12  # a cell whose |area| or |volume| is at most this times extent^d is degenerate


def _node(points: np.ndarray, i: int) -> str:
    return f"node {i} at ({', '.join(f'{x:.9g}' for x in points[i])})"


def cell_measures(
    points: np.ndarray, cells: np.ndarray, cell_type: str | None = None
) -> np.ndarray:
    """Signed area (2D; units of the coordinates squared) or volume (3D; units cubed) of each
    cell, positive for VTK's orientation: triangles and tetrahedra exactly; quadrilaterals by
    the shoelace of the 4 nodes in VTK order; hexahedra estimated by the sum of the six
    tetrahedra around the diagonal from node 0 to node 6. Without `cell_type`, 4 nodes are a
    quadrilateral and 8 a hexahedron."""
    x = points[cells]
    if cell_type in ("triangle", "tetrahedron"):
        edges = x[:, 1:] - x[:, :1]
        if cell_type == "triangle":
            return 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
        return np.einsum("cj,cj->c", np.cross(edges[:, 0], edges[:, 1]), edges[:, 2]) / 6
    if cells.shape[1] == 4:
        following = np.roll(x, -1, axis=1)
        return 0.5 * np.sum(x[..., 0] * following[..., 1] - following[..., 0] * x[..., 1], axis=1)
    a, b = x[:, HEX_RING] - x[:, [0]], x[:, np.roll(HEX_RING, -1)] - x[:, [0]]
    return np.einsum("ckj,cj->c", np.cross(a, b), x[:, 6] - x[:, 0]) / 6


def check_cells(
    path: Path, points: np.ndarray, cells: np.ndarray, cell_type: str | None = None
) -> None:
    """Refuse (InputError) cells that repeat a node or whose area (2D) or volume (3D) is at
    most DEGENERATE * extent^d, extent the largest side of the nodes' bounding box (in the
    units of the coordinates)."""
    ordered = np.sort(cells, axis=1)
    repeated = np.flatnonzero(np.any(ordered[:, 1:] == ordered[:, :-1], axis=1))
    if len(repeated):
        c = repeated[0]
        node = ordered[c, 1:][ordered[c, 1:] == ordered[c, :-1]][0]
        raise InputError(
            f"{path}: {len(repeated)} degenerate cell(s): cell {c} "
            f"(nodes {' '.join(map(str, cells[c]))}) "
            f"repeats node {node}"
        )
    dim = points.shape[1]
    extent = float(np.ptp(points, axis=0).max())
    measures = cell_measures(points, cells, cell_type)
    flat = np.flatnonzero(np.abs(measures) <= DEGENERATE * extent**dim)
    if len(flat):
        c = flat[0]
        what = "area" if dim == 2 else "volume"
        raise InputError(
            f"{path}: {len(flat)} degenerate cell(s): cell {c} "
            f"(nodes {' '.join(map(str, cells[c]))}) "
            f"has zero {what} ({measures[c]:.3g}; its nodes are collinear or coplanar or coincide)"
        )


def _count_rows(rows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unique rows of `rows` with their nodes sorted, the index of each row among them, and
    how often each occurs."""
    rows = np.sort(rows, axis=1)
    order = np.lexsort(rows.T[::-1])
    ordered = rows[order]
    first = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]
    inverse = np.empty(len(rows), dtype=np.int64)
    inverse[order] = np.cumsum(first) - 1
    return ordered[first], inverse, np.diff(np.r_[np.flatnonzero(first), len(rows)])


def check_boundary(
    path: Path, points: np.ndarray, cells: np.ndarray, cell_type: str | None = None
) -> None:
    """Refuse (InputError) a mesh whose boundary is not a manifold: a facet (2D edge, 3D face)
    shared by more than two cells, or a boundary that touches itself at a node or along an
    edge (as two quadrilaterals sharing only a corner do), where the boundary loops or
    surfaces that the surface error E_s is measured on would be ambiguous."""
    dim = points.shape[1]
    if cell_type is None:
        local = QUAD_EDGES if dim == 2 else HEX_FACES
    else:
        local = FACETS[cell_type]
    facets = cells[:, local].reshape(-1, local.shape[1])  # corners in cycle order
    unique, inverse, counts = _count_rows(facets)
    if np.any(counts > 2):
        f = np.flatnonzero(counts > 2)[0]
        name = "edge" if dim == 2 else "face"
        raise InputError(
            f"{path}: the {name} through nodes {' '.join(map(str, unique[f]))} is shared by "
            f"{counts[f]} cells (the mesh is not a manifold)"
        )
    boundary = facets[counts[inverse] == 1]
    touching = f"{path}: the mesh boundary touches itself at"
    why = (
        f"the boundary {'loops' if dim == 2 else 'surface'} that the surface error E_s needs "
        "would be ambiguous"
    )
    if dim == 2:
        degree = np.bincount(boundary.ravel(), minlength=len(points))
        if np.any(degree > 2):
            raise InputError(f"{touching} {_node(points, int(np.argmax(degree > 2)))} ({why})")
        return
    # 3D: each boundary edge lies on exactly two boundary faces, and around each boundary node
    # its faces form one fan, connected through the edges at that node.
    corners = boundary.shape[1]
    edges = np.stack([boundary, np.roll(boundary, -1, axis=1)], axis=2).reshape(
        -1, 2
    )  # face by face
    unique, inverse, counts = _count_rows(edges)
    if np.any(counts != 2):
        e = unique[np.flatnonzero(counts != 2)[0]]
        raise InputError(
            f"{touching} the edge from {_node(points, e[0])} to {_node(points, e[1])} ({why})"
        )
    # Half-edge (edge e seen from its end v) = 2 e + (v is the edge's larger node). At each
    # corner v of a face, the face joins the half-edges of its two edges at v.
    edge_id = inverse.reshape(-1, corners)  # edge_id[f, j]: edge from corner j to corner j + 1
    after = 2 * edge_id + (boundary > np.roll(boundary, -1, axis=1))
    before = 2 * np.roll(edge_id, 1, axis=1) + (boundary > np.roll(boundary, 1, axis=1))
    p, q = after.ravel(), before.ravel()
    label = np.arange(2 * len(unique))
    while True:  # connected components by propagating the smallest label
        smallest = np.minimum(label[p], label[q])
        new = label.copy()
        np.minimum.at(new, p, smallest)
        np.minimum.at(new, q, smallest)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    node = np.where(
        np.arange(2 * len(unique)) % 2 == 0, unique[:, 0].repeat(2), unique[:, 1].repeat(2)
    )
    fans = np.unique(node * len(label) + label) // len(label)  # one entry per (node, fan)
    several = np.flatnonzero(np.bincount(fans, minlength=len(points)) > 1)
    if len(several):
        raise InputError(f"{touching} {_node(points, int(several[0]))} ({why})")
