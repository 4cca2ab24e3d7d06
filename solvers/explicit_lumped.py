"""`explicit-lumped`: central difference (beta_N = 0, gamma = 1/2) with the lumped mass M_L
and C = alpha M_L (the paper's scheme). The step matrix (1 + h alpha / 2) M_L is diagonal: a
custom loop per step, one compiled pass over K and the vectors that does the whole step
(solvers/blockcsr.py), no KSP.

The pass reads ubar = u_{i+1} and writes the next step's predictor u_{i+2}'s free part into
a second buffer (double buffering: the product still reads u while the rows are updated), so
that every vector is read and written once a step; the state's u is then the buffer the pass
read. Before the pass the constrained dofs of ubar get their prescribed values and, under MPI,
its ghost values come from DOLFINx's scatter."""

from __future__ import annotations

from typing import TYPE_CHECKING

from petsc4py import PETSc

import numpy as np

from tissuebench.solvers.algorithm import Algorithm, State
from tissuebench.solvers.newmark import Newmark

if TYPE_CHECKING:
    import dolfinx.la

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


class Predictors:
    """The two ghosted buffers of u for a fused explicit step (beta_N = 0): while a step's pass
    reads ubar = u_{i+1} from one, it writes the next predictor u + h v + h^2/2 a into the
    other. `ubar(state, h, uc)` gives the buffer that holds the state's next ubar (m), its
    constrained dofs set to their prescribed values uc (m); `advance(state, k)` makes buffer k the
    state's u. The state's u is then a view of a buffer, valid until the next step of any state
    (one state at a time): a state that this object did not leave (a new one from start(),
    another step index, another u) gets its predictor by one extra pass first, but a change
    made in place to the free values of the state it left is not seen."""

    def __init__(self, system: System, buffers: tuple[dolfinx.la.Vector, dolfinx.la.Vector]):
        self.system = system
        self.buffers = buffers
        n = system.ML.getLocalSize()
        bs = system.ML.getBlockSize()
        # Vecs over the buffers' owned values (their memory: no copy)
        self.vecs = tuple(
            PETSc.Vec().createWithArray(
                x.array[:n],  # type: ignore[arg-type]  # petsc4py's stubs: it takes an ndarray
                size=(n, PETSc.DECIDE),
                bsize=bs,
                comm=system.comm,
            )
            for x in buffers
        )
        self._left: tuple[State, int, int] | None = None  # (state, its i, its buffer)

    def ubar(self, state: State, h: float, uc: np.ndarray) -> int:
        """The index of the buffer that holds ubar of the state's next step (step h in s), its
        constrained dofs given their prescribed u, uc (m); its ghosts are not yet scattered."""
        left = self._left
        if (
            left is not None
            and left[0] is state
            and left[1] == state.i
            and state.u is self.vecs[left[2]]
        ):
            k = 1 - left[2]
        else:  # a state this object did not leave: its predictor by one more pass
            k = 1 if state.u is self.vecs[0] else 0
            state.u.copy(self.vecs[k])
            self.vecs[k].maxpy([h, h * h / 2], [state.v, state.a])  # utilde
        self.vecs[k].array[self.system.constrained] = uc  # ubar
        return k

    def advance(self, state: State, k: int) -> None:
        """Make buffer k (ubar of the step just taken) the state's u."""
        state.u = self.vecs[k]
        self._left = (state, state.i, k)

    def destroy(self) -> None:
        for vec in self.vecs:
            vec.destroy()


class ExplicitLumped(Newmark):
    """Newmark.step for this scheme as one fused pass over K and the vectors (solvers/blockcsr.py):
    u = ubar needs no correction (beta_N = 0), M_L a0 only touches constrained rows (dropped),
    1 / S is applied with zeros on the constrained dofs, and the pass also writes the next
    step's predictor of u (Predictors). The same arithmetic up to round-off
    (tests/test_integrators.py checks it against the general step)."""

    def __init__(self, system, h: float, solver: str = "direct"):
        super().__init__(system, h, ALGORITHM, "explicit_lumped_", solver)
        self._alpha_ml, self._inv_s = lumped_factors(system, h, self.alpha, self.gamma)
        self.K_product = system.K_csr  # the matrix that the one product per step reads
        K = self.K_product
        self._predictors = Predictors(system, (K.vector(), K.vector()))

    def step(self, state: State) -> State:
        s, h, c = self.system, self.h, self.system.constrained
        i = state.i + 1
        uc, vc, ac = s.prescribed(i * h)
        k = self._predictors.ubar(state, h, uc)
        v, a = state.v, state.a
        # v = vbar, a = delta = (f - K ubar - alpha M_L vbar) / S (0 on constrained dofs),
        # v += gamma h a, and the next utilde into the other buffer
        self.K_product.explicit_lumped(
            self._predictors.buffers[k],
            s.f,
            self._inv_s,
            self._alpha_ml,
            v,
            a,
            self._predictors.vecs[1 - k].array,
            self.gamma,
            h,
        )
        a.array[c] = ac  # ... + a0
        v.array[c] = vc
        state.i, state.t = i, i * h
        self._predictors.advance(state, k)
        return state

    def destroy(self) -> None:
        super().destroy()
        self._predictors.destroy()


def integrator(system: System, h: float, solver: str = "direct") -> ExplicitLumped:
    return ExplicitLumped(system, h, solver)


ALGORITHM = Algorithm(integrator, mass="lumped", stiffness_damping=False, beta_N=0.0, gamma=0.5)
