"""`explicit`: central difference (beta_N = 0, gamma = 1/2) with the consistent mass M,
C = alpha M + beta K; one solve with M + hC/2 per step."""

from tissuebench.solvers.newmark import Newmark


def integrator(system, h, solver="direct"):
    return Newmark(system, h, beta_N=0.0, gamma=0.5, lumped=False, solver=solver, prefix="explicit_")
