"""What an algorithm is: a registry entry with the scheme data of SPEC sections 2 and 3 (its
mass, damping and Newmark parameters, from which the stability analysis derives), and the
Integrator interface that every time integrator follows.

Units: h in s; the state's u, v, a in m, m/s, m/s^2.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from petsc4py import PETSc

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


@dataclass
class State:
    """(u, v, a) at step i, t = i h: PETSc Vecs in m, m/s, m/s^2."""

    i: int
    t: float
    u: PETSc.Vec
    v: PETSc.Vec
    a: PETSc.Vec


class Integrator(Protocol):
    """A time integrator on one System with step h (s).

    `start()` gives the initial state (step 0); `step(state)` advances it to the next step in
    place and returns it; `iterations()` is the number of linear-solver iterations of the last
    solve (0 for a direct or diagonal solve); `destroy()` frees its PETSc solvers.
    """

    h: float
    system: System

    def start(self) -> State: ...

    def step(self, state: State) -> State: ...

    def iterations(self) -> int: ...

    def destroy(self) -> None: ...


@dataclass(frozen=True)
class Algorithm:
    """One row of SPEC section 2's table, and how to build its integrator.

    mass: "consistent" (M), "lumped" (M_L) or "none" (quasi-static); stiffness_damping: C holds
    beta K as well as alpha times the mass; beta_N, gamma: the Newmark parameters of SPEC
    section 3 (None for quasi-static, which has no history)."""

    build: Callable[..., Integrator]  # build(system, h, solver="direct")
    mass: str
    stiffness_damping: bool
    beta_N: float | None = None
    gamma: float | None = None

    @property
    def lumped(self) -> bool:
        return self.mass == "lumped"

    @property
    def newmark(self) -> bool:
        """A Newmark scheme (it has a stability limit to analyse)."""
        return self.beta_N is not None

    @property
    def explicit(self) -> bool:
        return self.beta_N == 0

    @property
    def damping(self) -> str:
        """C as SPEC section 2 writes it."""
        if self.mass == "none":
            return "none"
        mass = "M_L" if self.lumped else "M"
        return f"α{mass} + βK" if self.stiffness_damping else f"α{mass}"
