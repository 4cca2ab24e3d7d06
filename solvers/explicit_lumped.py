"""`explicit-lumped`: central difference with the lumped mass M_L and C = alpha M_L (the
paper's scheme). The step matrix (1 + h alpha / 2) M_L is diagonal: one MatMult with K and
pointwise Vec operations per step, no KSP."""

from tissuebench.solvers.newmark import Newmark


def integrator(system, h, solver="direct"):
    return Newmark(system, h, beta_N=0.0, gamma=0.5, lumped=True, stiffness_damping=False,
                   solver=solver, prefix="explicit_lumped_")
