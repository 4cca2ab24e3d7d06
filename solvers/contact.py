"""Penalty contact with the rigid needle (SPEC section 12), as UFL forms.

On the block's right edge Gamma, with x = X + u the deformed point and g_n(x) its signed
distance to the rigid tool S (meshes/tools/; m, negative inside), the penalty
energy (J/m, per unit thickness) is

    Pi_c(u) = (k/2) int_Gamma <-g_n(X + u)>^2 dS,   <z> = max(z, 0),

k in Pa/m (SPEC 12: k = kappa E / h_e). Its first variation is the contact residual, whose
traction on the tissue is p n with the pressure p = k <-g_n> (Pa) and n the outward normal of S
at the closest point; UFL differentiates it again for Newton's tangent. The needle's force
per unit thickness (N/m) is what the tissue exerts on it, F = -int_Gamma p n dS, and the
interpenetration is the largest -g_n (m).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.meshes.tools import Tool

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def deformed(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The deformed point x = X + u (m) of the displacement u (m)."""
    return ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(u)) + u


def penetration(u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, tool: Tool) -> ufl.core.expr.Expr:
    """<-g_n(X + u)> (m): how far the deformed point lies inside the tool, 0 outside."""
    g = tool.ufl_signed_distance(deformed(u), c)
    return ufl.conditional(ufl.lt(g, 0), -g, 0.0)


def energy(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    tool: Tool,
    k: ufl.core.expr.Expr | float,
    ds: ufl.Measure,
) -> ufl.Form:
    """The penalty energy (k/2) int <-g_n>^2 dS (J/m in 2D, J in 3D) over the measure ds (the
    contact surface)."""
    return 0.5 * k * penetration(u, c, tool) ** 2 * ds


def pressure(
    u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, tool: Tool, k: ufl.core.expr.Expr | float
) -> ufl.core.expr.Expr:
    """The contact pressure p = k <-g_n> (Pa)."""
    return k * penetration(u, c, tool)


def needle_force(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    tool: Tool,
    k: ufl.core.expr.Expr | float,
    ds: ufl.Measure,
) -> list[ufl.Form]:
    """The components of the force that the tissue exerts on the tool, F = -int p n dS (N/m
    per unit thickness in 2D, N in 3D), as scalar forms."""
    p = pressure(u, c, tool, k)
    n = tool.ufl_outward_normal(deformed(u), c)
    return [-p * n[i] * ds for i in range(tool.dim)]


QUADRATURE_DEGREE = 4  # Gauss points of the contact integrals (3 per edge)


def edge_measure(mesh: dolfinx.mesh.Mesh, facets: np.ndarray) -> ufl.Measure:
    """The measure ds over the boundary facets `facets` (local indices) of mesh."""
    facets = np.sort(np.asarray(facets)).astype(np.int32)
    tags = dolfinx.mesh.meshtags(
        mesh, mesh.topology.dim - 1, facets, np.ones(len(facets), np.int32)
    )
    return ufl.Measure(
        "ds", mesh, subdomain_data=tags, metadata={"quadrature_degree": QUADRATURE_DEGREE}
    )(1)


def penalty_stiffness(system: System) -> float:
    """k = kappa E / h_e (Pa/m) of the system's contact (SPEC 12)."""
    contact = system.benchmark.contact
    assert contact is not None  # a benchmark with contact
    return contact.kappa * system.material.E / contact.edge_size


def facet_nodes(system: System, facets: np.ndarray) -> np.ndarray:
    """The dofs (local indices, ghosts included) of the vertices of each facet (first-order
    P1/Q1 spaces: a dof a vertex), (facets, vertices a facet), in the facet's own vertex order
    (DOLFINx's reference order: a quadrilateral's is tensor order)."""
    mesh, V = system.mesh, system.V
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    mesh.topology.create_connectivity(tdim - 1, 0)
    mesh.topology.create_connectivity(tdim, 0)
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    f2v = mesh.topology.connectivity(tdim - 1, 0)
    c2v = mesh.topology.connectivity(tdim, 0)
    rows = []
    for f in facets:
        cell = int(f2c.links(f)[0])
        dof_of = dict(zip(c2v.links(cell), V.dofmap.cell_dofs(cell), strict=True))
        rows.append([int(dof_of[v]) for v in f2v.links(f)])
    width = 4 if mesh.topology.cell_name() == "hexahedron" else tdim
    return np.array(rows, dtype=np.int64).reshape(-1, width)


def facet_samples(vertices: int, per_edge: int) -> np.ndarray:
    """The shape functions (points, vertices) of a first-order facet of `vertices` vertices (a
    segment, a triangle or a quadrilateral in tensor order) at a lattice of `per_edge` points
    along each edge (ends included), covering the facet."""
    s = np.linspace(0.0, 1.0, per_edge)
    if vertices == 2:
        return np.column_stack([1 - s, s])
    if vertices == 3:
        p = np.array([(a, b) for a in s for b in s if a + b <= 1 + 1e-12])
        return np.column_stack([1 - p.sum(axis=1), p])
    a, b = (g.ravel() for g in np.meshgrid(s, s, indexing="ij"))
    return np.column_stack([(1 - a) * (1 - b), a * (1 - b), (1 - a) * b, a * b])


class Measures:
    """What SPEC 12 and 13 grade besides the displacement, for displacements of a System with
    contact: the force F that the tissue exerts on the tool (N/m per unit thickness in 2D, N in
    3D; with the run's own penalty), and the interpenetration (m): the largest -g_n over the
    contact surface. In 2D the edge's deformed segments between its nodes (first order) are
    sampled at SAMPLES points each (-g_n is concave along a straight segment: the samples bound
    it within the segment's length squared over the needle's radius); in 3D each deformed facet
    (a triangle, or a bilinear quadrilateral) at a lattice of SAMPLES_3D points an edge."""

    SAMPLES = 9
    SAMPLES_3D = 7  # SPEC 13: at least 6 points a facet edge

    def __init__(self, system: System):
        contact = system.benchmark.contact
        if contact is None:
            raise ValueError("the system has no contact")
        self.system, self.contact = system, contact
        mesh, V = system.mesh, system.V
        self.u = fem.Function(V)
        self.c = fem.Constant(mesh, np.asarray(contact.centre(0.0), dtype=float))
        k = penalty_stiffness(system)
        ds = edge_measure(mesh, contact.facets)
        self.forms = [fem.form(f) for f in needle_force(self.u, self.c, contact.tool, k, ds)]
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        dofs = fem.locate_dofs_topological(V, mesh.topology.dim - 1, contact.facets)
        self.nodes = dofs[dofs < V.dofmap.index_map.size_local]
        self.X = V.tabulate_dof_coordinates()[self.nodes, : system.gdim]
        if system.gdim == 3:
            self.facets = facet_nodes(system, np.asarray(contact.facets))
            self.N = facet_samples(self.facets.shape[1], self.SAMPLES_3D)
            self.X_all = V.tabulate_dof_coordinates()[:, :3]

    def __call__(self, values: np.ndarray, t: float) -> tuple[float, ...]:
        """(the force's gdim components, N/m in 2D and N in 3D, then the interpenetration in
        m) of the owned dof values `values` (m) at time t (s). Collective."""
        comm, gdim = self.system.comm, self.system.gdim
        self.u.x.array[: len(values)] = values
        self.u.x.scatter_forward()
        centre = np.asarray(self.contact.centre(t), dtype=float)
        self.c.value[:] = centre
        F = [comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM) for f in self.forms]
        if gdim == 3:
            x = (self.X_all + self.u.x.array.reshape(-1, 3))[self.facets]  # (facets, v, 3)
            points = np.einsum("pv,fvd->fpd", self.N, x).reshape(-1, 3)
            g = self.contact.tool.signed_distance(points, centre)
            deepest = float(max(0.0, -g.min())) if len(g) else 0.0
            return (*F, comm.allreduce(deepest, op=MPI.MAX))
        x = self.X + np.asarray(values).reshape(-1, gdim)[self.nodes]
        edge = np.concatenate(comm.allgather(np.column_stack([self.X[:, 1], x])))
        edge = edge[np.argsort(edge[:, 0], kind="stable")][:, 1:]  # the edge's chain, by y
        s = np.linspace(0.0, 1.0, self.SAMPLES)[:, None, None]
        points = (1 - s) * edge[None, :-1] + s * edge[None, 1:]
        g = self.contact.tool.signed_distance(points.reshape(-1, 2), centre)
        return F[0], F[1], float(max(0.0, -g.min())) if len(g) else 0.0


def stiffness_bound(system: System) -> PETSc.Mat:
    """k int_Gamma u.w dS on the contact edge (N/m), in the layout of system.K: the penalty's
    tangent k n (x) n with every facet of the edge in contact and both components penalised, an
    upper bound of the stiffness contact adds (the stability limits of the explicit schemes
    count it, SPEC 12)."""
    contact = system.benchmark.contact
    assert contact is not None  # a benchmark with contact
    V = system.V
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    ds = edge_measure(system.mesh, contact.facets)
    k = penalty_stiffness(system)
    bound = dolfinx.fem.petsc.assemble_matrix(fem.form(k * ufl.inner(u, w) * ds))
    bound.assemble()
    return bound
