"""`neo-hookean-barrier` (SPEC section 8): P = dpsi/dF with
psi = (mu/2)(J^(-2/3) I1 - 3) + (kappa/4)(J^2 - 1 - 2 ln J), I1 = tr(F^T F), J = det F,
kappa = lambda + 2 mu / 3: `neo-hookean` with Simo and Taylor's volumetric energy in place of
(kappa/2)(J - 1)^2. The two volumetric energies agree to second order in J - 1 (both have
second derivative kappa at J = 1), but this one grows without bound as J -> 0 (like -ln J),
so no finite load crushes a volume to nothing; (kappa/2)(J - 1)^2 costs at most kappa/2 per
unit volume. CalculiX's NEO HOOKE is the other law, not this one.
In 2D (plane strain) F33 = 1: I1 = tr(C_2D) + 1, J = det F_2D."""

from __future__ import annotations

import ufl
from ufl.core.expr import Expr

from tissuebench.solvers.models.model import Model
from tissuebench.solvers.models.neo_hookean import c_stress, isochoric_energy


def strain_energy(F: Expr, mu: Expr | float, lmbda: Expr | float) -> Expr:
    """psi(F) in J/m^3 (mu, lmbda in Pa; F dimensionless)."""
    J = ufl.det(F)
    kappa = lmbda + 2 * mu / 3
    return isochoric_energy(F, mu) + kappa / 4 * (J**2 - 1 - 2 * ufl.ln(J))


def first_piola(F: Expr, mu: Expr | float, lmbda: Expr | float, R: Expr | None = None) -> Expr:
    """P = dpsi/dF in Pa."""
    F = ufl.variable(F)
    return ufl.diff(strain_energy(F, mu, lmbda), F)


MODEL = Model(
    "neo-hookean-barrier",
    first_piola,
    description="compressible neo-Hookean with the volumetric barrier (kappa/4)(J^2 - 1 - 2 ln J)",
    c_stress=c_stress("0.5 * kappa * (J - Jinv)"),  # d/dJ (kappa/4)(J^2 - 1 - 2 ln J)
)
