"""`neo-hookean` (SPEC section 8): P = dpsi/dF with
psi = (mu/2)(J^(-2/3) I1 - 3) + (kappa/2)(J - 1)^2, I1 = tr(F^T F), J = det F,
kappa = lambda + 2 mu / 3: CalculiX's and Abaqus's NEO HOOKE with C10 = mu/2, D1 = 2/kappa.
In 2D (plane strain) F33 = 1: I1 = tr(C_2D) + 1, J = det F_2D."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model


def isochoric_energy(F: Expr, mu: Expr | float) -> Expr:
    """(mu/2)(J^(-2/3) I1 - 3) in J/m^3, the part both neo-Hookean laws share."""
    d = ufl.shape(F)[0]
    I1 = ufl.tr(F.T * F) + (3 - d)  # the out-of-plane stretch 1 in plane strain
    return mu / 2 * (ufl.det(F) ** (-2 / 3) * I1 - 3)


def strain_energy(F: Expr, mu: Expr | float, lmbda: Expr | float) -> Expr:
    """psi(F) in J/m^3."""
    kappa = lmbda + 2 * mu / 3
    return isochoric_energy(F, mu) + kappa / 2 * (ufl.det(F) - 1) ** 2


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr | None = None) -> Expr:
    F = ufl.variable(F)
    return ufl.diff(strain_energy(F, mu, lmbda), F)


def c_stress(volumetric: str) -> str:
    """P = mu J^(-2/3) (F - (I1/3) F^-T) + p cof F in C (Model.c_stress), the volumetric part's
    p = dpsi_vol/dJ (Pa) given as a C expression of J, Jinv = 1/J and kappa. J^(-1/3) by
    inv_cbrt (no libm call and no division, so that the compiled loop vectorises), NaN for
    J <= 0 as the UFL form's pow."""
    return f"""
double C[D * D], I1 = 3 - D;
cofactor(F, C);
for (int k = 0; k < D * D; ++k) I1 += F[k] * F[k];
const double r = inv_cbrt(J), kappa = lmbda + 2.0 * mu / 3.0;
const double jm23 = r * r, Jinv = jm23 * r;
const double a = mu * jm23, b = -a * I1 * Jinv * (1.0 / 3.0) + ({volumetric});
for (int k = 0; k < D * D; ++k) P[k] = a * F[k] + b * C[k];
"""


MODEL = Model(
    "neo-hookean",
    first_piola,
    description="compressible neo-Hookean (NEO HOOKE)",
    c_stress=c_stress("kappa * (J - 1.0)"),  # d/dJ (kappa/2)(J - 1)^2
)
