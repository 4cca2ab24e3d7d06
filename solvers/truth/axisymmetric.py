"""Axisymmetric linear elasticity on the meridian (SPEC 13's truth): the forms and the mesh.

A body of revolution about the z axis, loaded symmetrically, moves as u = u_r(r, z) e_r +
u_z(r, z) e_z. On the meridian (r, z) in [0, R_B] x [0, H] (m) its small strain has the hoop
component u_r / r besides the in-plane ones,

    eps = [[du_r/dr, 0, (du_r/dz + du_z/dr)/2], [0, u_r/r, 0], [sym., 0, du_z/dz]]

(rows and columns r, theta, z), and every volume integral of the body is int (...) 2 pi r dr dz.
Stress sigma = 2 mu eps + lambda tr(eps) I (Pa). On the axis r = 0, u_r = 0 (a Dirichlet
condition; u_z is free there). The forms below are written with the test functions w (and q)
so that a dynamic truth can add its mass and damping terms to them.

Two discretisations, as SPEC 10 asks: Q2 in the displacement (`displacement_form`), and
Taylor-Hood Q2-Q1 (`mixed_form`, the pressure p = -lambda div u, Pa) for nu >= 0.45. The mesh
(`meridian_mesh`) is the uniform n x n grid of quadrilaterals mapped toward the top face's
centre (0, H): a zone of `fine` m from the axis and from the top face holds half the grid lines
of each direction, evenly spaced (cells of h_near = 2 fine / n there), and the rest grow away
from it (a quadratic map, its slope continuous at the zone's edge). The levels n, 2n, 4n nest.
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI

import basix.ufl
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

R_B = 0.5  # m, the cylinder's radius (SPEC 13)
H = 1.0  # m, its height
FINE = 0.035  # m, the side of the evenly fine zone at the top face's centre
TAGS = {"axis": 1, "side": 2, "bottom": 3, "top": 4}  # the meridian's edges


# -- the forms ---------------------------------------------------------------------------------
def radius(mesh: dolfinx.mesh.Mesh) -> ufl.core.expr.Expr:
    """r (m), the first coordinate of the meridian."""
    return ufl.SpatialCoordinate(mesh)[0]


def eps_axi(u: ufl.core.expr.Expr, r: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The small strain (3 x 3, rows r, theta, z) of the meridian displacement u = (u_r, u_z)
    (m) at radius r (m): the in-plane symmetric gradient and the hoop strain u_r / r."""
    g = ufl.grad(u)
    shear = (g[0, 1] + g[1, 0]) / 2
    return ufl.as_tensor([[g[0, 0], 0, shear], [0, u[0] / r, 0], [shear, 0, g[1, 1]]])


def div_axi(u: ufl.core.expr.Expr, r: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """div u = du_r/dr + u_r/r + du_z/dz, the volume change (the strain's trace)."""
    return ufl.tr(eps_axi(u, r))


def sigma(eps: ufl.core.expr.Expr, mu: float, lmbda: float) -> ufl.core.expr.Expr:
    """The linear stress (Pa) of the strain eps: 2 mu eps + lambda tr(eps) I (mu, lambda Pa)."""
    return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(3)


def volume(r: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The volume element's weight 2 pi r (m): dV = 2 pi r dr dz, dA = 2 pi r ds."""
    return 2 * np.pi * r


def displacement_form(
    u: ufl.core.expr.Expr, w: ufl.core.expr.Expr, mu: float, lmbda: float
) -> ufl.Form:
    """The internal virtual work int sigma(u) : eps(w) dV (J for the virtual displacement w in
    m), the displacement form (Q2)."""
    r = ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(u))[0]
    return ufl.inner(sigma(eps_axi(u, r), mu, lmbda), eps_axi(w, r)) * volume(r) * ufl.dx


def mixed_form(
    u: ufl.core.expr.Expr,
    p: ufl.core.expr.Expr,
    w: ufl.core.expr.Expr,
    q: ufl.core.expr.Expr,
    mu: float,
    lmbda: float,
) -> ufl.Form:
    """The mixed displacement-pressure form (Taylor-Hood Q2-Q1) of the linear law, with the
    pressure p = -lambda div u (Pa) as its own unknown:
    int 2 mu eps(u):eps(w) - p div w - q (div u + p / lambda) dV."""
    r = ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(u))[0]
    return (
        (
            2 * mu * ufl.inner(eps_axi(u, r), eps_axi(w, r))
            - p * div_axi(w, r)
            - q * (div_axi(u, r) + p / lmbda)
        )
        * volume(r)
        * ufl.dx
    )


def lame(E: float, nu: float) -> tuple[float, float]:
    """(mu, lambda) in Pa of Young's modulus E (Pa) and Poisson's ratio nu."""
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def space(mesh: dolfinx.mesh.Mesh, mixed: bool) -> fem.FunctionSpace:
    """The truth's space: Q2 displacement (u_r, u_z), with the Q1 pressure when mixed."""
    cell = mesh.basix_cell()
    Q2 = basix.ufl.element("Lagrange", cell, 2, shape=(2,))
    if not mixed:
        return fem.functionspace(mesh, Q2)
    return fem.functionspace(
        mesh, basix.ufl.mixed_element([Q2, basix.ufl.element("Lagrange", cell, 1)])
    )


# -- the mesh ----------------------------------------------------------------------------------
def grading(s: np.ndarray, fine: float) -> np.ndarray:
    """The map of [0, 1] onto itself that puts half of the uniform grid s into [0, fine]
    evenly, and the rest on [fine, 1] with a size growing linearly (a quadratic map whose slope
    is continuous at s = 1/2); fine in (0, 1/2)."""
    s = np.asarray(s, dtype=float)
    slope = 2 * fine
    curve = (1 - fine - slope / 2) / 0.25
    t = s - 0.5
    return np.where(s <= 0.5, slope * s, fine + slope * t + curve * t * t)


@dataclass
class Meridian:
    """The graded meridian mesh: n cells a direction, the cell size h_near (m) at the top
    face's centre, and its edges tagged by TAGS."""

    mesh: dolfinx.mesh.Mesh
    n: int
    h_near: float
    edges: dolfinx.mesh.MeshTags


def meridian_mesh(
    n: int,
    fine: float = FINE,
    radius_b: float = R_B,
    height: float = H,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Meridian:
    """The n x n quadrilaterals on [0, radius_b] x [0, height] (m), graded toward the top
    face's centre (0, height): an evenly fine zone [0, fine] x [height - fine, height] of n/2 x
    n/2 cells of side h_near = 2 fine / n, growing away from it. n even. Collective."""
    if n < 2 or n % 2:
        raise ValueError(f"the meridian mesh needs an even n >= 2, got {n}")
    mesh = dolfinx.mesh.create_rectangle(
        comm, [[0.0, 0.0], [1.0, 1.0]], [n, n], dolfinx.mesh.CellType.quadrilateral
    )
    x = mesh.geometry.x
    r, z = x[:, 0].copy(), x[:, 1].copy()
    x[:, 0] = radius_b * grading(r, fine / radius_b)
    x[:, 1] = height * (1 - grading(1 - z, fine / height))
    tol = 1e-9 * height
    where = {
        "axis": lambda p: np.isclose(p[0], 0.0, atol=tol),
        "side": lambda p: np.isclose(p[0], radius_b, atol=tol),
        "bottom": lambda p: np.isclose(p[1], 0.0, atol=tol),
        "top": lambda p: np.isclose(p[1], height, atol=tol),
    }
    mesh.topology.create_connectivity(1, 2)
    found = {name: dolfinx.mesh.locate_entities_boundary(mesh, 1, f) for name, f in where.items()}
    facets = np.concatenate(list(found.values()))
    values = np.concatenate([np.full(len(f), TAGS[name], np.int32) for name, f in found.items()])
    order = np.argsort(facets)
    edges = dolfinx.mesh.meshtags(mesh, 1, facets[order], values[order])
    return Meridian(mesh=mesh, n=n, h_near=2 * fine / n, edges=edges)


def boundary_conditions(
    W: fem.FunctionSpace, meridian: Meridian, mixed: bool
) -> list[fem.DirichletBC]:
    """u_r = 0 on the axis and u = 0 on the bottom face (the cylinder's fixed base)."""
    U = W.sub(0) if mixed else W
    axis = meridian.edges.find(TAGS["axis"])
    bottom = meridian.edges.find(TAGS["bottom"])
    zero = np.float64(0.0)
    bcs = [
        fem.dirichletbc(zero, fem.locate_dofs_topological(U.sub(0), 1, axis), U.sub(0)),
        fem.dirichletbc(zero, fem.locate_dofs_topological(U.sub(0), 1, bottom), U.sub(0)),
        fem.dirichletbc(zero, fem.locate_dofs_topological(U.sub(1), 1, bottom), U.sub(1)),
    ]
    return bcs
