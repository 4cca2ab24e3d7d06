"""The penalty contact's nodal force (SPEC 12, 13) evaluated in numpy, facet by facet, beside the
explicit schemes' compiled element loop (solvers/compiled_forces.py): the contact surface has
about N^(d-1) facets against the N^d cells of the element loop, so its cost is small beside it.
The UFL forms of solvers/contact.py give the same force (tests/test_contact_runs.py in 2D,
tests/test_cylinder.py in 3D)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import basix
import dolfinx.la
import numpy as np
from dolfinx import fem

from tissuebench.solvers.contact import QUADRATURE_DEGREE, penalty_stiffness

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


class EdgePenalty:
    """The penalty's nodal force on first-order (P1/Q1) cells, evaluated facet by facet in
    numpy beside the explicit schemes' compiled element loop: each contact facet is a straight
    segment between its two nodes, integrated by the Gauss points of edge_measure; the force
    is the UFL residual's to round-off (tests/test_contact_runs.py). Units: u in m, forces in N
    (N/m in 2D, per unit thickness)."""

    def __init__(self, system: System):
        contact = system.benchmark.contact
        if contact is None or system.gdim != 2:
            raise ValueError("EdgePenalty needs a 2D system with contact (3D: FacetPenalty)")
        mesh, V = system.mesh, system.V
        self.system, self.contact, self.k = system, contact, penalty_stiffness(system)
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim - 1, 0)
        mesh.topology.create_connectivity(tdim, 0)
        f2c = mesh.topology.connectivity(tdim - 1, tdim)
        f2v = mesh.topology.connectivity(tdim - 1, 0)
        c2v = mesh.topology.connectivity(tdim, 0)
        owned_cells = mesh.topology.index_map(tdim).size_local
        # each facet once over the ranks: on the rank that owns its (one) cell, as DOLFINx
        # assembles exterior facet integrals
        facets = [int(f) for f in contact.facets if f2c.links(f)[0] < owned_cells]
        dof_of = {}
        for f in facets:
            cell = int(f2c.links(f)[0])
            for vertex, dof in zip(c2v.links(cell), V.dofmap.cell_dofs(cell), strict=True):
                dof_of[int(vertex)] = int(dof)
        self.nodes = np.array(
            [[dof_of[int(v)] for v in f2v.links(f)] for f in facets], dtype=np.int64
        ).reshape(-1, 2)
        self.X = V.tabulate_dof_coordinates()[:, :2]
        points, weights = basix.make_quadrature(basix.CellType.interval, QUADRATURE_DEGREE)
        self.s = np.asarray(points)[:, 0]
        self.w = np.asarray(weights)
        self.u = fem.Function(V)
        self.f = fem.Function(V)

    def __call__(self, u: np.ndarray, t: float) -> np.ndarray:
        """The contact's share of f_int at the owned dof values u (m) at time t (s): the
        owned dofs' nodal forces (N), -int p n . N_a dS, p = k <-g_n>. Collective."""
        n_owned = len(u)
        self.u.x.array[:n_owned] = u
        self.u.x.scatter_forward()
        values = self.u.x.array.reshape(-1, 2)
        a, b = self.nodes[:, 0], self.nodes[:, 1]
        xa, xb = self.X[a] + values[a], self.X[b] + values[b]
        length = np.linalg.norm(self.X[b] - self.X[a], axis=1)  # the undeformed dS
        s = self.s[None, :, None]
        x = ((1 - s) * xa[:, None] + s * xb[:, None]).reshape(-1, 2)
        c = np.asarray(self.contact.centre(t), dtype=float)
        tool = self.contact.tool
        g = tool.signed_distance(x, c)
        traction = (self.k * np.maximum(-g, 0.0))[:, None] * tool.outward_normal(x, c)
        traction = traction.reshape(len(a), len(self.s), 2) * (self.w[None, :, None])
        traction *= length[:, None, None]
        force = self.f.x.array.reshape(-1, 2)
        force[:] = 0.0
        np.add.at(force, a, -np.einsum("q,fqd->fd", 1 - self.s, traction))
        np.add.at(force, b, -np.einsum("q,fqd->fd", self.s, traction))
        self.f.x.scatter_reverse(dolfinx.la.InsertMode.add)
        return self.f.x.array[:n_owned].copy()

    def add_to(self, out: np.ndarray, u: np.ndarray, t: float) -> None:
        """out += the contact's share of f_int at u (m) at time t (s), N. Collective."""
        out += self(u, t)


class FacetPenalty:
    """The penalty's nodal force in 3D on first-order cells (P1 tetrahedra: triangular facets;
    Q1 hexahedra: bilinear quadrilateral facets), facet by facet in numpy beside the compiled
    element loop, integrated by the facet's Gauss rule of degree 2 QUADRATURE_DEGREE (the
    UFL form's, solvers/contact.py) with the undeformed area element. Units: u in m, forces in
    N."""

    def __init__(self, system: System):
        from tissuebench.solvers.contact import facet_nodes

        contact = system.benchmark.contact
        if contact is None or system.gdim != 3:
            raise ValueError("FacetPenalty needs a 3D system with contact")
        mesh, V = system.mesh, system.V
        self.contact, self.k = contact, penalty_stiffness(system)
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        f2c = mesh.topology.connectivity(tdim - 1, tdim)
        owned_cells = mesh.topology.index_map(tdim).size_local
        # each facet once over the ranks: on the rank that owns its (one) cell
        facets = np.array(
            [f for f in contact.facets if f2c.links(f)[0] < owned_cells], dtype=np.int32
        )
        self.nodes = facet_nodes(system, facets)  # (facets, vertices)
        shape = (
            basix.CellType.quadrilateral if self.nodes.shape[1] == 4 else basix.CellType.triangle
        )
        points, weights = basix.make_quadrature(shape, QUADRATURE_DEGREE)
        element = basix.create_element(basix.ElementFamily.P, shape, 1)
        tab = np.asarray(element.tabulate(1, np.asarray(points)))  # (derivative, q, vertex, 1)
        self.N = tab[0, :, :, 0]  # (q, v)
        X = V.tabulate_dof_coordinates()[:, :3][self.nodes]  # (f, v, 3)
        J = np.einsum("kqv,fvd->fqkd", tab[1:3, :, :, 0], X)  # (f, q, 2, 3)
        area = np.linalg.norm(np.cross(J[:, :, 0], J[:, :, 1]), axis=2)  # (f, q)
        self.dA = area * np.asarray(weights)[None, :]  # m^2 at each Gauss point (f, q)
        self.X = X
        self.u = fem.Function(V)
        self.f = fem.Function(V)
        # one rank: the surface's own nodes only, no scatter of whole vectors (its nodes are
        # all owned); each facet corner's place among them, for bincount
        self.serial = mesh.comm.size == 1
        self.surface, self.corner = np.unique(self.nodes, return_inverse=True)
        self.corner = self.corner.reshape(self.nodes.shape)

    def nodal(self, x: np.ndarray, t: float) -> np.ndarray:
        """-int p n . N_a dS (N) at each facet's corners (f, v, 3) for the deformed corners x
        (f, v, 3), m, at time t (s). Only the facets that may touch the tool are integrated:
        the signed distance is 1-Lipschitz and a facet lies in its corners' convex hull, so a
        facet whose first corner is farther from the tool than from its other corners has no
        point inside it (its force is exactly zero). The interpolation and the test
        functions' sums are one matrix product each over those facets (corner by corner)."""
        f, v, _ = x.shape
        c = np.asarray(self.contact.centre(t), dtype=float)
        tool = self.contact.tool
        reach = np.linalg.norm(x[:, 1:] - x[:, :1], axis=2).max(axis=1)
        near = np.flatnonzero(tool.signed_distance(x[:, 0], c) <= reach)
        nodal = np.zeros((f, v, 3))
        if len(near) == 0:
            return nodal
        corners = np.ascontiguousarray(x[near].transpose(1, 0, 2)).reshape(v, -1)
        points = (self.N @ corners).reshape(-1, 3)  # (q x near, 3): point q of every facet
        dA = self.dA[near].T.ravel()  # m^2, in the same order
        p = self.k * np.maximum(-tool.signed_distance(points, c), 0.0) * dA
        traction = p[:, None] * tool.outward_normal(points, c)  # (q x near, 3), N
        summed = (self.N.T @ traction.reshape(len(self.N), -1)).reshape(v, len(near), 3)
        nodal[near] = -summed.transpose(1, 0, 2)
        return nodal  # (f, v, 3)

    def __call__(self, u: np.ndarray, t: float) -> np.ndarray:
        """The contact's share of f_int at the owned dof values u (m) at time t (s): the
        owned dofs' nodal forces (N), -int p n . N_a dS, p = k <-g_n>. Collective."""
        out = np.zeros_like(u)
        self.add_to(out, u, t)
        return out

    def add_to(self, out: np.ndarray, u: np.ndarray, t: float) -> None:
        """out += the contact's share of f_int at the owned dof values u (m) at time t (s), N.
        One rank: over the surface's nodes alone; several: through the ghosts. Collective."""
        if self.serial:
            nodal = self.nodal(self.X + u.reshape(-1, 3)[self.nodes], t)
            corner, count = self.corner.ravel(), len(self.surface)
            summed = [np.bincount(corner, nodal[..., d].ravel(), count) for d in range(3)]
            out.reshape(-1, 3)[self.surface] += np.stack(summed, axis=1)
            return
        n_owned = len(u)
        self.u.x.array[:n_owned] = u
        self.u.x.scatter_forward()
        nodal = self.nodal(self.X + self.u.x.array.reshape(-1, 3)[self.nodes], t)
        force = self.f.x.array.reshape(-1, 3)
        force[:] = 0.0
        np.add.at(force, self.nodes.ravel(), nodal.reshape(-1, 3))
        self.f.x.scatter_reverse(dolfinx.la.InsertMode.add)
        out += self.f.x.array[:n_owned]
