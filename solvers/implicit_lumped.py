"""`implicit-lumped`: trapezoidal rule with the lumped mass M_L, C = alpha M_L + beta K;
one solve with M_L + hC/2 + h^2 K/4 per step."""

from tissuebench.solvers.newmark import Newmark


def integrator(system, h, solver="direct"):
    return Newmark(system, h, beta_N=0.5, gamma=0.5, lumped=True, solver=solver,
                   prefix="implicit_lumped_")
