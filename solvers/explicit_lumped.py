"""`explicit-lumped`: central difference (beta_N = 0, gamma = 1/2) with the lumped mass M_L
and C = alpha M_L (the paper's scheme). The step matrix (1 + h alpha / 2) M_L is diagonal: a
custom loop of one MatMult with K and pointwise Vec operations per step, no KSP."""

from petsc4py import PETSc

from tissuebench.solvers.newmark import Newmark, State


class ExplicitLumped(Newmark):
    """Newmark.step for this scheme, in 8 Vec passes and one MatMult instead of 14 and a
    MatMultAdd: u = ubar needs no correction (beta_N = 0), M_L a0 only touches constrained
    rows (dropped), and 1 / S is applied with zeros on the constrained dofs. The same
    arithmetic up to round-off (tests/test_integrators.py checks it against the general step)."""

    def __init__(self, system, h, solver="direct"):
        super().__init__(system, h, beta_N=0.0, gamma=0.5, lumped=True, stiffness_damping=False,
                         solver=solver, prefix="explicit_lumped_")
        self._alpha_ml = system.ML.copy()
        self._alpha_ml.scale(self.alpha)
        self._inv_s = system.ML.copy()  # 1 / ((1 + gamma h alpha) M_L), 0 on constrained dofs
        self._inv_s.scale(1 + self.gamma * h * self.alpha)
        self._inv_s.reciprocal()
        self._inv_s.array[system.constrained] = 0.0
        # K in symmetric block storage (SBAIJ: the upper triangle's blocks), for the one
        # product per step: it moves about half the bytes of BAIJ, the same K
        self.K_product = system.K.copy()
        self.K_product.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        self.K_product.convert("sbaij")  # in place: our own copy

    def step(self, state):
        s, h, c = self.system, self.h, self.system.constrained
        i = state.i + 1
        u, v, a = state.u, state.v, state.a
        uc, vc, ac = s.prescribed(i * h)
        u.maxpy([h, h * h / 2], [v, a])  # utilde
        v.axpy((1 - self.gamma) * h, a)  # vtilde
        u.array[c] = uc  # ubar
        v.array[c] = vc  # vbar
        r, w = self._r, self._w
        self.K_product.mult(u, r)
        r.aypx(-1.0, s.f)
        w.pointwiseMult(self._alpha_ml, v)
        r.axpy(-1.0, w)  # r = f - K ubar - alpha M_L vbar
        a.pointwiseMult(self._inv_s, r)  # a = delta (0 on constrained dofs) ...
        a.array[c] = ac  # ... + a0
        v.axpy(self.gamma * h, a)
        v.array[c] = vc
        return State(i, i * h, u, v, a)


def integrator(system, h, solver="direct"):
    return ExplicitLumped(system, h, solver)
