"""`mean-dilatation` (B-bar): Q1 whose volumetric strain is the cell's mean dilatation,
theta_e = (1/V_e) ∫_e div u dx (one pressure per cell, condensed), the deviatoric part with
full Gauss integration (Nagtegaal, Parks and Rice; Hughes's B-bar):

    K = ∫ 2 mu dev eps(u) : dev eps(w) dx + kappa_d sum_e V_e theta_e(u) theta_e(w),

kappa_d = lambda + 2 mu / d. On parallelogram and parallelepiped cells the mean dilatation is
the dilatation at the cell's centre. An affine field has a constant dilatation, so K u is Q1's
(the patch test)."""

from __future__ import annotations

from dolfinx import fem

from tissuebench.solvers.schemes.scheme import EXPLICIT, Scheme, split_stiffness


def stiffness(V, mu, lmbda, parameters):
    # the volumetric part: sum_e V_e theta_e(u) theta_e(w)
    return split_stiffness(V, mu, lmbda, fem.functionspace(V.mesh, ("DG", 0)))


SCHEME = Scheme(
    "mean-dilatation",
    stiffness,
    cells=("quadrilateral", "hexahedron"),
    description="Q1 with the cell's mean dilatation in the volumetric part (B-bar)",
    # F-bar, its nonlinear form: the cell's mean J is not differentiated, so Newton would have
    # no exact tangent; the explicit algorithms need none
    nonlinear=(EXPLICIT,),
    fbar=True,
    colour="tab:green",
)
