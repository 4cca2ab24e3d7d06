"""`anp` (average nodal pressure, Bonet and Burton): P1 whose volumetric energy is evaluated
with nodal dilatations, each the volume-weighted mean of the dilatations of the cells around
the node:

    theta_n = sum_e (V_e/(d+1)) theta_e / V_n,   V_n = sum_e V_e/(d+1),
    K = ∫ 2 mu dev eps(u) : dev eps(w) dx + kappa_d sum_n V_n theta_n(u) theta_n(w),

kappa_d = lambda + 2 mu / d. In matrix form, B_nj = ∫ phi_n div phi_j dx and V_n = ∫ phi_n dx
(P1's lumped mass), so the volumetric part is B^T diag(1/V_n) B: it couples the nodes of
neighbouring patches, a wider pattern than P1's. An affine field has the same dilatation in
every cell, so K u is P1's (the patch test)."""

from __future__ import annotations

import ufl
from dolfinx import fem

from tissuebench.solvers.schemes.scheme import (
    Scheme,
    add,
    assemble,
    bulk_modulus,
    deviator,
    projected_product,
)


def stiffness(V, mu, lmbda, parameters):
    d = V.mesh.geometry.dim
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    dev_u, dev_w = deviator(ufl.sym(ufl.grad(u))), deviator(ufl.sym(ufl.grad(w)))
    K_dev = assemble(2 * mu * ufl.inner(dev_u, dev_w) * ufl.dx)
    Q = fem.functionspace(V.mesh, ("Lagrange", 1))
    K_vol = projected_product(V, Q, ufl.div)  # sum_n V_n theta_n(u) theta_n(w)
    return add(K_dev, K_vol, bulk_modulus(mu, lmbda, d))


SCHEME = Scheme(
    "anp",
    stiffness,
    cells=("triangle", "tetrahedron"),
    description="P1 with average nodal pressure (Bonet-Burton)",
)
