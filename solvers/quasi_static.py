"""`quasi-static`: K u_{i+1} = f_{i+1} at every step, no history; v and a are reported as 0.
Step 0 is the initial state (u = 0, constrained dofs prescribed)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from tissuebench.solvers.algorithm import Algorithm, State
from tissuebench.solvers.linear import step_operator

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def initial_state(system: System) -> State:
    """Step 0: u = 0 on free dofs, the prescribed values on constrained ones; v = a = 0."""
    u, v, a = (system.K.createVecLeft() for _ in range(3))
    for x in (u, v, a):
        x.set(0.0)
    u.array[system.constrained] = system.prescribed(0.0)[0]
    return State(0, 0.0, u, v, a)


class QuasiStatic:
    """An Integrator (solvers/algorithm.py) with one solve with K per step."""

    def __init__(self, system, h: float, solver: str = "direct"):
        if not h > 0:
            raise ValueError(f"time step h must be > 0 s, got {h}")
        self.system, self.h = system, h
        self.solve = step_operator(system, 0.0, 1.0, False, "quasi_static_", solver)
        self._r, self._delta = system.K.createVecLeft(), system.K.createVecLeft()

    def iterations(self) -> int:
        """Linear-solver iterations of the last step's solve (0: direct)."""
        return self.solve.iterations()

    def destroy(self) -> None:
        self.solve.destroy()

    def start(self) -> State:
        return initial_state(self.system)

    def step(self, state: State) -> State:
        """u_{i+1} = ubar + K_bc^-1 (f - K ubar), ubar = prescribed values on constrained dofs."""
        s = self.system
        i = state.i + 1
        t = i * self.h
        u = state.u
        u.set(0.0)
        u.array[s.constrained] = s.prescribed(t)[0]
        r = self._r
        s.K_csr.mult(u, r)
        r.aypx(-1.0, s.f)
        r.array[s.constrained] = 0.0
        self.solve(r, self._delta)
        self._delta.array[s.constrained] = 0.0
        u.axpy(1.0, self._delta)
        state.i, state.t = i, t
        return state


def integrator(system: System, h: float, solver: str = "direct") -> QuasiStatic:
    return QuasiStatic(system, h, solver)


ALGORITHM = Algorithm(integrator, mass="none", stiffness_damping=False)
