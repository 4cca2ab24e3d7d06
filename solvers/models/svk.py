"""`svk`, St Venant-Kirchhoff (SPEC section 8): P = F S, S = lambda tr(E) I + 2 mu E,
E = (F^T F - I) / 2, the Green-Lagrange strain."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model, small_strain_stress


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr | None = None) -> Expr:
    E = (F.T * F - ufl.Identity(ufl.shape(F)[0])) / 2
    return F * small_strain_stress(E, mu, lmbda)


MODEL = Model("svk", first_piola, description="St Venant-Kirchhoff")
