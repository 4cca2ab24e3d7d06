"""`explicit`: central difference (beta_N = 0, gamma = 1/2) with the consistent mass M,
C = alpha M + beta K; one solve with M + hC/2 per step."""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm
from tissuebench.solvers.newmark import Newmark

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def integrator(system: System, h: float, solver: str = "direct") -> Newmark:
    return Newmark(system, h, ALGORITHM, "explicit_", solver)


ALGORITHM = Algorithm(integrator, mass="consistent", stiffness_damping=True, beta_N=0.0, gamma=0.5)
