"""Penalty contact with the rigid needle (SPEC section 12), as UFL forms.

On the block's right edge Gamma, with x = X + u the deformed point and g_n(x) its signed
distance to the needle's half-stadium S (meshes/contact.py; m, negative inside), the penalty
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

from tissuebench.meshes.contact import signed_distance as signed_distance_numpy

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def signed_distance(
    x: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float
) -> ufl.core.expr.Expr:
    """The signed distance (m) from the point x to the half-stadium of radius `radius` (m)
    centred at c: the distance to the ray {c + (r, 0), r >= 0} minus the radius."""
    dx = x[0] - c[0]
    dy = x[1] - c[1]
    ray = ufl.conditional(ufl.ge(dx, 0), abs(dy), ufl.sqrt(dx * dx + dy * dy))
    return ray - radius


def outward_normal(x: ufl.core.expr.Expr, c: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The unit outward normal of the half-stadium centred at c at its point closest to x."""
    dx = x[0] - c[0]
    dy = x[1] - c[1]
    r = ufl.sqrt(dx * dx + dy * dy)
    flank = ufl.ge(dx, 0)
    return ufl.as_vector(
        [ufl.conditional(flank, 0.0, dx / r), ufl.conditional(flank, ufl.sign(dy), dy / r)]
    )


def deformed(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The deformed point x = X + u (m) of the displacement u (m)."""
    return ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(u)) + u


def penetration(u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float) -> ufl.core.expr.Expr:
    """<-g_n(X + u)> (m): how far the deformed point lies inside the needle, 0 outside."""
    g = signed_distance(deformed(u), c, radius)
    return ufl.conditional(ufl.lt(g, 0), -g, 0.0)


def energy(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    radius: float,
    k: ufl.core.expr.Expr | float,
    ds: ufl.Measure,
) -> ufl.Form:
    """The penalty energy (k/2) int <-g_n>^2 dS (J/m) over the measure ds (the right edge)."""
    return 0.5 * k * penetration(u, c, radius) ** 2 * ds


def pressure(
    u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float, k: ufl.core.expr.Expr | float
) -> ufl.core.expr.Expr:
    """The contact pressure p = k <-g_n> (Pa)."""
    return k * penetration(u, c, radius)


def needle_force(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    radius: float,
    k: ufl.core.expr.Expr | float,
    ds: ufl.Measure,
) -> list[ufl.Form]:
    """The two components of the force per unit thickness (N/m) that the tissue exerts on the
    needle, F = -int p n dS, as scalar forms."""
    p = pressure(u, c, radius, k)
    n = outward_normal(deformed(u), c)
    return [-p * n[i] * ds for i in range(2)]


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


class Measures:
    """What SPEC 12 grades besides the displacement, for displacements of a System with
    contact: the needle's force per unit thickness F (N/m, the force the tissue exerts on it,
    with the run's own penalty), and the interpenetration (m): the largest -g_n over the
    contact edge, whose deformed segments between its nodes (first order) are sampled at
    SAMPLES points each (-g_n is concave along a straight segment: the samples bound it within
    the segment's length squared over the needle's radius)."""

    SAMPLES = 9

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
        self.forms = [fem.form(f) for f in needle_force(self.u, self.c, contact.radius, k, ds)]
        mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
        dofs = fem.locate_dofs_topological(V, mesh.topology.dim - 1, contact.facets)
        self.nodes = dofs[dofs < V.dofmap.index_map.size_local]
        self.X = V.tabulate_dof_coordinates()[self.nodes, : system.gdim]

    def __call__(self, values: np.ndarray, t: float) -> tuple[float, float, float]:
        """(F_x, F_y in N/m, interpenetration in m) of the owned dof values `values` (m) at
        time t (s). Collective."""
        comm, gdim = self.system.comm, self.system.gdim
        self.u.x.array[: len(values)] = values
        self.u.x.scatter_forward()
        centre = np.asarray(self.contact.centre(t), dtype=float)
        self.c.value[:] = centre
        F = [comm.allreduce(fem.assemble_scalar(f), op=MPI.SUM) for f in self.forms]
        x = self.X + np.asarray(values).reshape(-1, gdim)[self.nodes]
        edge = np.concatenate(comm.allgather(np.column_stack([self.X[:, 1], x])))
        edge = edge[np.argsort(edge[:, 0], kind="stable")][:, 1:]  # the edge's chain, by y
        s = np.linspace(0.0, 1.0, self.SAMPLES)[:, None, None]
        points = (1 - s) * edge[None, :-1] + s * edge[None, 1:]
        g = signed_distance_numpy(points.reshape(-1, 2), centre, self.contact.radius)
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
