"""`hourglass`: the one-point (uniform gradient) Q1 element with hourglass control, the element
of total Lagrangian explicit dynamics (TLED) in its small-strain form.

The strain of a cell is its mean gradient, G_e(u) = (1/V_e) ∫_e grad u dx (Flanagan and
Belytschko's uniform gradient: the gradient at the centre of a parallelogram or parallelepiped
cell), so the cell's stiffness is V_e times one point's. Its zero-energy (hourglass) modes,
the part of grad u that G_e does not see, are held by a stiffness of their own:

    K = sum_e V_e sigma(G_e u) : G_e w + c_hg mu ∫ (grad u - G_e u) : (grad w - G_e w) dx.

The hourglass term vanishes on every field with a constant gradient, so an affine field
gives Q1's K u (the patch test) whatever c_hg; c_hg (dimensionless, in units of the shear
modulus) is this scheme's parameter, stated and swept. Flanagan and Belytschko's hourglass base
vectors span the same modes on parallelepipeds; the coefficient here weighs them by their
gradient energy instead of by their nodal amplitudes."""

from __future__ import annotations

import ufl
from dolfinx import fem

from tissuebench.solvers.models.model import small_strain_stress
from tissuebench.solvers.schemes.scheme import (
    Parameter,
    Scheme,
    add,
    assemble,
    projected_product,
)

C_HG = 0.1  # default hourglass stiffness, in units of the shear modulus
C_HG_MAX = 100.0  # beyond it the hourglass modes are stiffer than anything they stand for


def stiffness(V, mu, lmbda, parameters):
    d = V.mesh.geometry.dim
    Q = fem.functionspace(V.mesh, ("DG", 0, (d, d)))
    p, q = ufl.TrialFunction(Q), ufl.TestFunction(Q)
    material = ufl.inner(small_strain_stress(ufl.sym(p), mu, lmbda), q) * ufl.dx
    K_uniform = projected_product(V, Q, ufl.grad, material)  # sum_e V_e sigma(G u) : G w
    c = parameters["c_hg"]
    if c == 0:
        return K_uniform
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    # ∫ (grad u - G u) : (grad w - G w) = ∫ grad u : grad w - sum_e V_e G u : G w
    L = assemble(ufl.inner(ufl.grad(u), ufl.grad(w)) * ufl.dx)
    hourglass = add(L, projected_product(V, Q, ufl.grad), -1.0)
    return add(K_uniform, hourglass, c * mu)


SCHEME = Scheme(
    "hourglass",
    stiffness,
    cells=("quadrilateral", "hexahedron"),
    parameters={
        "c_hg": Parameter(C_HG, 0.0, C_HG_MAX, "hourglass stiffness in units of the shear modulus")
    },
    description="one-point Q1 (uniform gradient) with hourglass control, TLED's element",
    colour="tab:olive",
)
