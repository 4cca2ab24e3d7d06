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


MODEL = Model("corotational", first_piola, rotated=True, description="corotational (per-cell R)")
