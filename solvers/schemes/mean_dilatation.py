"""`mean-dilatation` (B-bar): Q1 whose volumetric strain is the cell's mean dilatation,
theta_e = (1/V_e) ∫_e div u dx (one pressure per cell, condensed), the deviatoric part with
full Gauss integration (Nagtegaal, Parks and Rice; Hughes's B-bar):

    K = ∫ 2 mu dev eps(u) : dev eps(w) dx + kappa_d sum_e V_e theta_e(u) theta_e(w),

kappa_d = lambda + 2 mu / d. On parallelogram and parallelepiped cells the mean dilatation is
the dilatation at the cell's centre. An affine field has a constant dilatation, so K u is Q1's
(the patch test)."""

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
    Q = fem.functionspace(V.mesh, ("DG", 0))
    K_vol = projected_product(V, Q, ufl.div)  # sum_e V_e theta_e(u) theta_e(w)
    return add(K_dev, K_vol, bulk_modulus(mu, lmbda, d))


SCHEME = Scheme(
    "mean-dilatation",
    stiffness,
    cells=("quadrilateral", "hexahedron"),
    description="Q1 with the cell's mean dilatation in the volumetric part (B-bar)",
)
