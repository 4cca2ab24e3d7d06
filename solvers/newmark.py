"""Newmark time stepping in the paper's parameterisation (SPEC section 3):

    u_{i+1} = u_i + h v_i + (1 - beta_N) h^2/2 a_i + beta_N h^2/2 a_{i+1}
    v_{i+1} = v_i + (1 - gamma) h a_i + gamma h a_{i+1}
    M a_{i+1} + C v_{i+1} + K u_{i+1} = f_{i+1},   C = alpha M + beta K

Constrained dofs take their prescribed (u, v, a) at every t_i; the free ones solve the
equation of motion with the constrained values moved to the right-hand side. With the
prescribed values put into the predictors, the unknown is the free part delta of a_{i+1}:

    S delta = f - M (a0 + alpha vbar) - K (ubar + beta vbar),
    S = (1 + gamma h alpha) M + (gamma h beta + beta_N h^2/2) K.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm, State
from tissuebench.solvers.linear import DiagonalSolve, KSPSolve, step_operator

if TYPE_CHECKING:
    from petsc4py import PETSc

    from tissuebench.solvers.system import System

__all__ = ["Newmark", "State"]


class Newmark:
    """One Newmark scheme, its data taken from its registry entry (solvers/algorithm.py): an
    Integrator (`start()`, `step(state)` in place)."""

    def __init__(
        self, system: System, h: float, scheme: Algorithm, prefix: str, solver: str = "direct"
    ):
        if not h > 0:
            raise ValueError(f"time step h must be > 0 s, got {h}")
        self.system, self.h = system, h
        assert scheme.beta_N is not None and scheme.gamma is not None  # a Newmark scheme's
        self.beta_N, self.gamma, self.lumped = scheme.beta_N, scheme.gamma, scheme.lumped
        self.alpha = system.material.alpha
        self.beta = system.material.beta if scheme.stiffness_damping else 0.0
        self.solve = self.step_solver(prefix, solver)
        # step 0 only: M a0 = r by CG + Jacobi (linear.MASS_SOLVER), or pointwise for M_L
        self.mass_solve = step_operator(system, 1.0, 0.0, self.lumped, prefix + "mass_", "mass")
        K = system.K
        self._r, self._w, self._delta = K.createVecLeft(), K.createVecLeft(), K.createVecLeft()

    def step_solver(self, prefix: str, solver: str) -> KSPSolve | DiagonalSolve | None:
        """The solve with S = (1 + gamma h alpha) M + (gamma h beta + beta_N h^2/2) K."""
        h = self.h
        return step_operator(
            self.system,
            1 + self.gamma * h * self.alpha,
            self.gamma * h * self.beta + self.beta_N * h * h / 2,
            self.lumped,
            prefix,
            solver,
        )

    def iterations(self) -> int:
        """Linear-solver iterations of the last step's solve (0: direct or diagonal)."""
        assert self.solve is not None  # step_solver's (None in subclasses that override this)
        return self.solve.iterations()

    def destroy(self) -> None:
        """Free the PETSc solvers."""
        assert self.solve is not None  # step_solver's (None in subclasses that override this)
        self.solve.destroy()
        self.mass_solve.destroy()

    def mass_mult(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """y = M x (consistent) or M_L x (lumped)."""
        if self.lumped:
            y.pointwiseMult(self.system.ML, x)
        else:
            self.system.M_csr.mult(x, y)

    def residual(self, a0: PETSc.Vec, vbar: PETSc.Vec, ubar: PETSc.Vec) -> PETSc.Vec:
        """r = f - M (a0 + alpha vbar) - K (ubar + beta vbar), zero on constrained dofs."""
        r, w = self._r, self._w
        w.waxpy(self.alpha, vbar, a0)
        self.mass_mult(w, r)  # r = M (a0 + alpha vbar)
        w.waxpy(self.beta, vbar, ubar)
        self.system.K_csr.mult(w, r, add=True)  # r += K (ubar + beta vbar)
        r.aypx(-1.0, self.system.f)  # r = f - r
        r.array[self.system.constrained] = 0.0
        return r

    def start(self) -> State:
        """Step 0: u = v = 0 on free dofs, constrained dofs prescribed, and M a = f - C v - K u."""
        s, K = self.system, self.system.K
        u, v, a = K.createVecLeft(), K.createVecLeft(), K.createVecLeft()
        uc, vc, ac = s.prescribed(0.0)
        for x, xc in ((u, uc), (v, vc), (a, ac)):
            x.set(0.0)
            x.array[s.constrained] = xc
        r = self.residual(a, v, u)
        self.mass_solve(r, self._delta)
        self._delta.array[s.constrained] = 0.0
        a.axpy(1.0, self._delta)
        return State(0, 0.0, u, v, a)

    def step(self, state: State) -> State:
        """Advance (u, v, a) from t_i to t_{i+1} = (i + 1) h, in place."""
        self.predict(state)
        r = self.residual(state.a, state.v, state.u)
        delta = self._delta
        assert self.solve is not None  # step_solver's (None in subclasses that override this)
        self.solve(r, delta)
        delta.array[self.system.constrained] = 0.0
        return self.correct(state, delta)

    def predict(self, state: State) -> None:
        """Turn (u_i, v_i, a_i) into (ubar, vbar, a0) of step i + 1, in place: the known part
        of the update, with the prescribed values on the constrained dofs."""
        s, h = self.system, self.h
        uc, vc, ac = s.prescribed((state.i + 1) * h)
        u, v, a = state.u, state.v, state.a
        u.axpy(h, v)
        u.axpy((1 - self.beta_N) * h * h / 2, a)  # u is now utilde
        v.axpy((1 - self.gamma) * h, a)  # v is now vtilde
        a.set(0.0)
        a.array[s.constrained] = ac  # a is now a0
        u.axpy(self.beta_N * h * h / 2, a)
        v.axpy(self.gamma * h, a)
        u.array[s.constrained] = uc  # ubar
        v.array[s.constrained] = vc  # vbar

    def correct(self, state: State, delta: PETSc.Vec) -> State:
        """Add the free part delta of a_{i+1} (zero on constrained dofs): state is step i + 1."""
        h = self.h
        state.u.axpy(self.beta_N * h * h / 2, delta)
        state.v.axpy(self.gamma * h, delta)
        state.a.axpy(1.0, delta)
        state.i += 1
        state.t = state.i * h
        return state
