"""`linear` (SPEC sections 1-7): small strain, P = sigma(eps), eps = sym(F) - I; f_int = K u."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model, small_strain_stress


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr | None = None) -> Expr:
    return small_strain_stress(ufl.sym(F) - ufl.Identity(ufl.shape(F)[0]), mu, lmbda)


MODEL = Model("linear", first_piola, linear=True, description="small strain, f_int = K u")
