"""`explicit-lumped`: central difference (beta_N = 0, gamma = 1/2) with the lumped mass M_L
and C = alpha M_L (the paper's scheme). The step matrix (1 + h alpha / 2) M_L is diagonal: a
custom loop per step: pointwise Vec updates, then one compiled pass over K that also
updates a and v (solvers/blockcsr.py), no KSP."""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm, State
from tissuebench.solvers.newmark import Newmark

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


class ExplicitLumped(Newmark):
    """Newmark.step for this scheme as one pass of pointwise updates and one fused pass over K
    (solvers/blockcsr.py): u = ubar needs no correction (beta_N = 0), M_L a0 only touches
    constrained rows (dropped), and 1 / S is applied with zeros on the constrained dofs. The
    same arithmetic up to round-off (tests/test_integrators.py checks it against the general
    step)."""

    def __init__(self, system, h: float, solver: str = "direct"):
        super().__init__(system, h, ALGORITHM, "explicit_lumped_", solver)
        self._alpha_ml = system.ML.copy()
        self._alpha_ml.scale(self.alpha)
        self._inv_s = system.ML.copy()  # 1 / ((1 + gamma h alpha) M_L), 0 on constrained dofs
        self._inv_s.scale(1 + self.gamma * h * self.alpha)
        self._inv_s.reciprocal()
        self._inv_s.array[system.constrained] = 0.0
        self.K_product = system.K_csr  # the matrix that the one product per step reads

    def step(self, state: State) -> State:
        s, h, c = self.system, self.h, self.system.constrained
        i = state.i + 1
        u, v, a = state.u, state.v, state.a
        uc, vc, ac = s.prescribed(i * h)
        u.maxpy([h, h * h / 2], [v, a])  # utilde
        v.axpy((1 - self.gamma) * h, a)  # vtilde
        u.array[c] = uc  # ubar
        v.array[c] = vc  # vbar
        # a = delta = (f - K ubar - alpha M_L vbar) / S (0 on constrained dofs), v += gamma h a
        self.K_product.explicit_lumped(u, s.f, self._inv_s, self._alpha_ml, v, a, self.gamma * h)
        a.array[c] = ac  # ... + a0
        v.array[c] = vc
        state.i, state.t = i, i * h
        return state


def integrator(system: System, h: float, solver: str = "direct") -> ExplicitLumped:
    return ExplicitLumped(system, h, solver)


ALGORITHM = Algorithm(integrator, mass="lumped", stiffness_damping=False, beta_N=0.0, gamma=0.5)
