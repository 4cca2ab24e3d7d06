"""The boundary of a distributed first-order (Q1 or P1) mesh, known on every rank, its
displacements gathered to one rank for the surface error.

In 2D the boundary is a set of edges (a, b) oriented with the domain on their left; in 3D a
set of quadrilateral faces (a, b, c, d) (hexahedra) or triangles (a, b, c) (tetrahedra), a
cycle around the face counter-clockwise seen from outside. Nodes are numbered by their
position in `nodes`, the sorted global indices of the boundary nodes of V. Orientation is
decided once, on the undeformed mesh.
"""

from mpi4py import MPI  # noqa: F401 (loads libmpi before dolfinx)

import basix
import dolfinx.mesh
import numpy as np
from numpy.typing import ArrayLike


def _oriented_facets(V):
    """Local node indices of this rank's exterior facets, oriented outward, (facets, 2, 3 or 4)."""
    mesh = V.mesh
    topology = mesh.topology
    tdim, gdim = topology.dim, mesh.geometry.dim
    topology.create_connectivity(tdim - 1, tdim)
    topology.create_connectivity(tdim, tdim - 1)
    facets = dolfinx.mesh.exterior_facet_indices(topology)
    f2c = topology.connectivity(tdim - 1, tdim)
    c2f = topology.connectivity(tdim, tdim - 1)
    cells = f2c.array[f2c.offsets[facets]]
    facets_per_cell = c2f.offsets[1] - c2f.offsets[0]
    local_facet = np.argmax(
        c2f.array.reshape(-1, facets_per_cell)[cells] == facets[:, None], axis=1
    )

    # Lagrange degree 1: the cell's i-th dof sits at the reference cell's i-th vertex.
    reference = np.array(basix.topology(basix.CellType[topology.cell_name()])[tdim - 1])
    cell_nodes = V.dofmap.list[cells]
    nodes = np.take_along_axis(cell_nodes, reference[local_facet], axis=1)
    X = V.tabulate_dof_coordinates()[:, :gdim]
    inside = X[cell_nodes].mean(axis=1)  # a point inside each facet's cell

    if tdim == 2:
        a, b = X[nodes[:, 0]], X[nodes[:, 1]]
        edge, to_inside = b - a, inside - a
        left = edge[:, 0] * to_inside[:, 1] - edge[:, 1] * to_inside[:, 0] > 0
        return np.where(left[:, None], nodes, nodes[:, ::-1])
    if nodes.shape[1] == 3:  # triangles
        cycle = nodes
        p = X[cycle]
        normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    else:
        cycle = nodes[:, [0, 1, 3, 2]]  # reference quadrilaterals are numbered in tensor order
        p = X[cycle]
        normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    outward = np.einsum("ij,ij->i", normal, p.mean(axis=1) - inside) > 0
    return np.where(outward[:, None], cycle, cycle[:, ::-1])


class Boundary:
    """The exterior facets of V's mesh and their nodes, known on every rank.

    `gather(u, root)` (collective) returns on rank `root` the boundary node displacements (in
    `nodes` order) from the owned dof values u of V, and None elsewhere. `facets` holds the
    oriented facets as positions in `nodes` and `X` the undeformed node coordinates (m).
    """

    def __init__(self, V):
        self.comm = comm = V.mesh.comm
        self.dim = V.mesh.geometry.dim
        index_map = V.dofmap.index_map
        first, last = index_map.local_range
        local = _oriented_facets(V)
        global_facets = index_map.local_to_global(local.ravel().astype(np.int32)).reshape(
            local.shape
        )
        every = np.concatenate(comm.allgather(global_facets))
        self.nodes = nodes = np.unique(every)
        # Owned nodes have the contiguous global indices first..last-1, so the owned boundary
        # nodes of ranks 0, 1, ... concatenated are `nodes` in order.
        owned = nodes[(nodes >= first) & (nodes < last)]
        self._local = (owned - first).astype(np.int32)
        X = V.tabulate_dof_coordinates()[: last - first, : self.dim]
        self.X = np.concatenate(comm.allgather(X[self._local]))
        self.facets = np.searchsorted(nodes, every)

    def gather(self, u: ArrayLike, root: int = 0) -> np.ndarray | None:
        """Displacements of the boundary nodes (m) on rank `root`, shape (nodes, d); None
        elsewhere."""
        rows = self.comm.gather(np.asarray(u).reshape(-1, self.dim)[self._local], root=root)
        return np.concatenate(rows) if self.comm.rank == root else None
