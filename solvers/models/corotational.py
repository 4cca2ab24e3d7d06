"""`corotational` (SPEC section 8): per cell, R is the rotation of the polar decomposition of
F at the cell centre, and f_int,e = R K_e (R^T x_e - X_e). As a stress:
P = R sigma(sym(R^T F) - I), the linear stress of the unrotated strain, rotated back. R is a
piecewise-constant coefficient updated before each evaluation (solvers/elastic.py); its
derivative is dropped, so the tangent is R K_e R^T, as real-time codes do."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model, small_strain_stress


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr) -> Expr:
    eps = ufl.sym(R.T * F) - ufl.Identity(ufl.shape(F)[0])
    return R * small_strain_stress(eps, mu, lmbda)


# P = R sigma(sym(R^T F) - I) in C (Model.c_stress), R the cell's rotation
C_STRESS = """
double e[D * D], s[D * D], tr = 0.0;
for (int i = 0; i < D; ++i)
  for (int j = 0; j < D; ++j) {
    double c = 0.0;
    for (int k = 0; k < D; ++k) c += R[k * D + i] * F[k * D + j];
    e[i * D + j] = c;
  }
for (int i = 0; i < D; ++i) tr += e[i * D + i] - 1.0;
for (int i = 0; i < D; ++i)
  for (int j = 0; j < D; ++j)
    s[i * D + j] = mu * (e[i * D + j] + e[j * D + i]) - 2.0 * mu * (i == j);
for (int i = 0; i < D; ++i) s[i * D + i] += lmbda * tr;
for (int i = 0; i < D; ++i)
  for (int j = 0; j < D; ++j) {
    double p = 0.0;
    for (int k = 0; k < D; ++k) p += R[i * D + k] * s[k * D + j];
    P[i * D + j] = p;
  }
"""

MODEL = Model(
    "corotational",
    first_piola,
    rotated=True,
    description="corotational (per-cell R)",
    c_stress=C_STRESS,
)
