"""Penalty contact with the rigid needle (SPEC section 12), as UFL forms.

On the block's right edge Gamma, with x = X + u the deformed point and g_n(x) its signed
distance to the needle's half-stadium S (meshes/contact.py; m, negative inside), the penalty
energy (J/m, per unit thickness) is

    Pi_c(u) = (k/2) int_Gamma <-g_n(X + u)>^2 dS,   <z> = max(z, 0),

k in Pa/m (SPEC 12: k = kappa E / h_e). Its first variation is the contact residual, whose
traction on the tissue is p n with the pressure p = k <-g_n> (Pa) and n the outward normal of S
at the closest point; UFL differentiates it again for Newton's tangent. The needle's force
per unit thickness (N/m) is what the tissue exerts on it, F = -int_Gamma p n dS, and the
interpenetration is the largest -g_n (m).
"""

from __future__ import annotations

import ufl


def signed_distance(
    x: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float
) -> ufl.core.expr.Expr:
    """The signed distance (m) from the point x to the half-stadium of radius `radius` (m)
    centred at c: the distance to the ray {c + (r, 0), r >= 0} minus the radius."""
    dx = x[0] - c[0]
    dy = x[1] - c[1]
    ray = ufl.conditional(ufl.ge(dx, 0), abs(dy), ufl.sqrt(dx * dx + dy * dy))
    return ray - radius


def outward_normal(x: ufl.core.expr.Expr, c: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The unit outward normal of the half-stadium centred at c at its point closest to x."""
    dx = x[0] - c[0]
    dy = x[1] - c[1]
    r = ufl.sqrt(dx * dx + dy * dy)
    flank = ufl.ge(dx, 0)
    return ufl.as_vector(
        [ufl.conditional(flank, 0.0, dx / r), ufl.conditional(flank, ufl.sign(dy), dy / r)]
    )


def deformed(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The deformed point x = X + u (m) of the displacement u (m)."""
    return ufl.SpatialCoordinate(ufl.domain.extract_unique_domain(u)) + u


def penetration(u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float) -> ufl.core.expr.Expr:
    """<-g_n(X + u)> (m): how far the deformed point lies inside the needle, 0 outside."""
    g = signed_distance(deformed(u), c, radius)
    return ufl.conditional(ufl.lt(g, 0), -g, 0.0)


def energy(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    radius: float,
    k: ufl.core.expr.Expr,
    ds: ufl.Measure,
) -> ufl.Form:
    """The penalty energy (k/2) int <-g_n>^2 dS (J/m) over the measure ds (the right edge)."""
    return 0.5 * k * penetration(u, c, radius) ** 2 * ds


def pressure(
    u: ufl.core.expr.Expr, c: ufl.core.expr.Expr, radius: float, k: ufl.core.expr.Expr
) -> ufl.core.expr.Expr:
    """The contact pressure p = k <-g_n> (Pa)."""
    return k * penetration(u, c, radius)


def needle_force(
    u: ufl.core.expr.Expr,
    c: ufl.core.expr.Expr,
    radius: float,
    k: ufl.core.expr.Expr,
    ds: ufl.Measure,
) -> list[ufl.Form]:
    """The two components of the force per unit thickness (N/m) that the tissue exerts on the
    needle, F = -int p n dS, as scalar forms."""
    p = pressure(u, c, radius, k)
    n = outward_normal(deformed(u), c)
    return [-p * n[i] * ds for i in range(2)]
