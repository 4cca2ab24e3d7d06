"""What an elastic model is (SPEC section 8): the first Piola stress P(F) of a deformation
gradient F, from which the internal force f_int(u) = ∫ P(F) : ∇v dX and its tangent follow.

Units: mu and lmbda (the Lamé constants) in Pa, P in Pa; F is dimensionless.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import ufl
from ufl.core.expr import Expr

# the elastic forms' quadrature, UFL's (solvers/elastic.py) and the compiled loop's
# (solvers/compiled_forces.py): 2 Gauss points per direction, full integration of Q1, as K uses
QUADRATURE_DEGREE = 2


@dataclass(frozen=True)
class Model:
    """first_piola(F, mu, lmbda, R) -> P. R is the per-cell rotation (a piecewise-constant
    tensor) for a model with `rotated`, None otherwise; its derivative is not taken, so the
    tangent of such a model drops dR (SPEC 8's corotational). `linear`: f_int = K u, the
    system's assembled stiffness, with no per-step assembly.

    `c_stress`: the same P(F) in C, the body of
    `void stress(const double* F, double J, const double* R, double mu, double lmbda,
    double* P)` with F, R and P row-major D x D (D = gdim, a macro), J = det F, R the cell's
    rotation (NULL unless `rotated`), mu and lmbda in Pa, P in Pa; `cofactor(F, C)` (C = cof F
    = J F^-T) and `inv_cbrt(x)` (x^(-1/3)) are at hand, and libm, though a libm call keeps the
    loop over a batch of cells from vectorising. The explicit schemes assemble f_int with it
    in a compiled element loop (solvers/compiled_forces.py); a model without it takes the UFL
    form there too. It must agree with `first_piola` (tests/test_compiled_forces.py)."""

    name: str
    first_piola: Callable[..., ufl.core.expr.Expr]
    linear: bool = False
    rotated: bool = False
    description: str = ""
    c_stress: str = ""


def small_strain_stress(eps: Expr, mu: Expr | float, lmbda: Expr | float) -> Expr:
    """Linear isotropic stress 2 mu eps + lambda tr(eps) I of a (symmetric) strain eps."""
    return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(ufl.shape(eps)[0])
