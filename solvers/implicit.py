"""`implicit`, the reference: trapezoidal rule (beta_N = gamma = 1/2), consistent mass M,
C = alpha M + beta K; one solve with M + hC/2 + h^2 K/4 per step."""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm
from tissuebench.solvers.newmark import Newmark

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def integrator(system: System, h: float, solver: str = "direct") -> Newmark:
    return Newmark(system, h, ALGORITHM, "implicit_", solver)


ALGORITHM = Algorithm(integrator, mass="consistent", stiffness_damping=True, beta_N=0.5, gamma=0.5)
