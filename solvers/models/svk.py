"""`svk`, St Venant-Kirchhoff (SPEC section 8): P = F S, S = lambda tr(E) I + 2 mu E,
E = (F^T F - I) / 2, the Green-Lagrange strain."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model, small_strain_stress


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr | None = None) -> Expr:
    E = (F.T * F - ufl.Identity(ufl.shape(F)[0])) / 2
    return F * small_strain_stress(E, mu, lmbda)


# P = F S in C (Model.c_stress): E = (F^T F - I) / 2, S = lambda tr(E) I + 2 mu E
C_STRESS = """
double E[D * D], S[D * D], trE = 0.0;
for (int i = 0; i < D; ++i)
  for (int j = 0; j < D; ++j) {
    double c = 0.0;
    for (int k = 0; k < D; ++k) c += F[k * D + i] * F[k * D + j];
    E[i * D + j] = 0.5 * (c - (i == j));
  }
for (int i = 0; i < D; ++i) trE += E[i * D + i];
for (int k = 0; k < D * D; ++k) S[k] = 2.0 * mu * E[k];
for (int i = 0; i < D; ++i) S[i * D + i] += lmbda * trE;
for (int i = 0; i < D; ++i)
  for (int j = 0; j < D; ++j) {
    double p = 0.0;
    for (int k = 0; k < D; ++k) p += F[i * D + k] * S[k * D + j];
    P[i * D + j] = p;
  }
"""

MODEL = Model("svk", first_piola, description="St Venant-Kirchhoff", c_stress=C_STRESS)
