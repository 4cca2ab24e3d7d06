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


def lumped_factors(system: System, h: float, alpha: float, gamma: float) -> tuple:
    """(alpha M_L, 1 / ((1 + gamma h alpha) M_L)) as Vecs, the second 0 on constrained dofs:
    the diagonal parts of a lumped explicit step (h in s, alpha in 1/s)."""
    alpha_ml = system.ML.copy()
    alpha_ml.scale(alpha)
    inv_s = system.ML.copy()
    inv_s.scale(1 + gamma * h * alpha)
    inv_s.reciprocal()
    inv_s.array[system.constrained] = 0.0
    return alpha_ml, inv_s


def predict(system: System, state: State, h: float, gamma: float) -> tuple:
    """The predictor of an explicit step, in place: u = ubar = u + h v + h^2/2 a and
    v = vtilde = v + (1 - gamma) h a, the constrained dofs given their prescribed u, v at the
    new time. Returns (i, (u_c, v_c, a_c)): the new step's index and prescribed values."""
    i = state.i + 1
    u, v, a = state.u, state.v, state.a
    uc, vc, ac = system.prescribed(i * h)
    u.maxpy([h, h * h / 2], [v, a])  # utilde
    v.axpy((1 - gamma) * h, a)  # vtilde
    u.array[system.constrained] = uc  # ubar
    v.array[system.constrained] = vc  # vbar
    return i, (uc, vc, ac)


class ExplicitLumped(Newmark):
    """Newmark.step for this scheme as one pass of pointwise updates and one fused pass over K
    (solvers/blockcsr.py): u = ubar needs no correction (beta_N = 0), M_L a0 only touches
    constrained rows (dropped), and 1 / S is applied with zeros on the constrained dofs. The
    same arithmetic up to round-off (tests/test_integrators.py checks it against the general
    step)."""

    def __init__(self, system, h: float, solver: str = "direct"):
        super().__init__(system, h, ALGORITHM, "explicit_lumped_", solver)
        self._alpha_ml, self._inv_s = lumped_factors(system, h, self.alpha, self.gamma)
        self.K_product = system.K_csr  # the matrix that the one product per step reads

    def step(self, state: State) -> State:
        s, h, c = self.system, self.h, self.system.constrained
        u, v, a = state.u, state.v, state.a
        i, (uc, vc, ac) = predict(s, state, h, self.gamma)
        # a = delta = (f - K ubar - alpha M_L vbar) / S (0 on constrained dofs), v += gamma h a
        self.K_product.explicit_lumped(u, s.f, self._inv_s, self._alpha_ml, v, a, self.gamma * h)
        a.array[c] = ac  # ... + a0
        v.array[c] = vc
        state.i, state.t = i, i * h
        return state


def integrator(system: System, h: float, solver: str = "direct") -> ExplicitLumped:
    return ExplicitLumped(system, h, solver)


ALGORITHM = Algorithm(integrator, mass="lumped", stiffness_damping=False, beta_N=0.0, gamma=0.5)
