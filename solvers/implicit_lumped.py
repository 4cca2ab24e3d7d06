"""`implicit-lumped`: trapezoidal rule with the lumped mass M_L, C = alpha M_L + beta K;
one solve with M_L + hC/2 + h^2 K/4 per step."""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm
from tissuebench.solvers.newmark import Newmark

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def integrator(system: System, h: float, solver: str = "direct") -> Newmark:
    return Newmark(system, h, ALGORITHM, "implicit_lumped_", solver)


ALGORITHM = Algorithm(integrator, mass="lumped", stiffness_damping=True, beta_N=0.5, gamma=0.5)
