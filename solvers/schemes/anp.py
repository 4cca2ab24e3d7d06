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

from dolfinx import fem

from tissuebench.solvers.schemes.scheme import Scheme, split_stiffness


def stiffness(V, mu, lmbda, parameters):
    # the volumetric part: sum_n V_n theta_n(u) theta_n(w)
    return split_stiffness(V, mu, lmbda, fem.functionspace(V.mesh, ("Lagrange", 1)))


SCHEME = Scheme(
    "anp",
    stiffness,
    cells=("triangle", "tetrahedron"),
    description="P1 with average nodal pressure (Bonet-Burton)",
    colour="tab:red",
)
