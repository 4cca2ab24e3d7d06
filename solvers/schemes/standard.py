"""`standard`: the plain element of SPEC section 2, Q1 on quadrilaterals and hexahedra, P1 on
triangles and tetrahedra, with full Gauss integration: K = ∫ sigma(u) : eps(w) dx."""

from __future__ import annotations

import ufl

from tissuebench.solvers.models.model import small_strain_stress
from tissuebench.solvers.schemes.scheme import EXPLICIT, IMPLICIT, Scheme, assemble


def stiffness(V, mu, lmbda, parameters):
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps_u, eps_w = ufl.sym(ufl.grad(u)), ufl.sym(ufl.grad(w))
    return assemble(ufl.inner(small_strain_stress(eps_u, mu, lmbda), eps_w) * ufl.dx)


SCHEME = Scheme(
    "standard",
    stiffness,
    cells=("quadrilateral", "hexahedron", "triangle", "tetrahedron"),
    description="Q1 (P1 on simplices), full integration: the paper's element",
    nonlinear=(IMPLICIT, EXPLICIT),  # every model with every algorithm
    colour={
        "quadrilateral": "tab:blue",
        "hexahedron": "tab:blue",
        "triangle": "tab:orange",
        "tetrahedron": "tab:orange",
    },
)
