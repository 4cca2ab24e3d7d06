"""Every algorithm with a nonlinear elastic model (SPEC section 8): K u replaced by f_int(u).

The scheme data come from the algorithm's registry entry (solvers/algorithm.py), so each
algorithm of the registry runs with each model:

- explicit schemes (beta_N = 0): one f_int evaluation per step, at ubar = u_{i+1}, then the
  same solve with (1 + gamma h alpha) M + gamma h beta K_0 as the linear scheme (none beyond
  the diagonal for a lumped mass);
- implicit schemes: Newton on the free part delta of a_{i+1} (PETSc SNES, line search), with
  the Jacobian (1 + gamma h alpha) M + gamma h beta K_0 + beta_N h^2/2 K_T(u) factorised
  at every iteration;
- quasi-static: Newton on f_int(u) = f from the previous step's solution, the load (the
  prescribed displacements and the body force) sub-stepped by halves when Newton fails.

Stiffness damping is beta K_0 v with the linear K_0 for every model. A step whose Newton
fails, or after which some J = det F <= 0 at a quadrature point, raises SolveError: the run
diverges there (solvers/simulate.py). Units as in solvers/newmark.py.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from petsc4py import PETSc

import numpy as np

from tissuebench.core import interrupt
from tissuebench.solvers import compiled_forces
from tissuebench.solvers.algorithm import Algorithm, State
from tissuebench.solvers.elastic import ElasticForces
from tissuebench.solvers.explicit_lumped import Predictors, lumped_factors
from tissuebench.solvers.linear import SolveError, petsc_defaults, petsc_message
from tissuebench.solvers.models.model import Model
from tissuebench.solvers.newmark import Newmark
from tissuebench.solvers.quasi_static import initial_state

if TYPE_CHECKING:
    from tissuebench.solvers.system import System

    _Mixed = Newmark  # what ModelForces is mixed into
else:
    _Mixed = object

# SPEC 8: relative residual 1e-10. ATOL_SCALE x max diag(K_0) x extent is the absolute floor:
# the force of a 1e-13 relative nodal displacement error, a little above round-off.
NEWTON = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "bt",
    "snes_rtol": 1e-10,
    "snes_stol": 0.0,
    "snes_max_it": 100,  # the corotational tangent (dR dropped) converges only linearly
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
}
ATOL_SCALE = 1e-13
MAX_HALVINGS = 6  # quasi-static: the smallest load increment is 1/64 of a step's


def absolute_tolerance(system: System) -> float:
    """The residual (N) below which round-off, not Newton, decides."""
    d = system.K.getDiagonal()
    return ATOL_SCALE * d.max()[1] * system.benchmark.extent


def make_snes(
    system: System,
    J: PETSc.Mat,
    prefix: str,
    function: Callable[..., None],
    jacobian: Callable[..., None],
) -> PETSc.SNES:
    """A SNES with NEWTON's defaults under `prefix` (options in PETSc's database win)."""
    snes = PETSc.SNES().create(system.comm)
    snes.setOptionsPrefix(prefix)
    snes.setFunction(function, system.K.createVecLeft())
    snes.setJacobian(jacobian, J)
    with petsc_defaults(prefix, {**NEWTON, "snes_atol": absolute_tolerance(system)}):
        snes.setFromOptions()
    snes.setConvergenceHistory(reset=True)  # each solve's own history, not all steps
    return snes


class ModelForces(_Mixed):
    """The Newmark residual with f_int(u) in place of K u (a mixin for Newmark)."""

    forces: ElasticForces

    def residual(self, a0: PETSc.Vec, vbar: PETSc.Vec, ubar: PETSc.Vec) -> PETSc.Vec:
        """r = f - M (a0 + alpha vbar) - beta K_0 vbar - f_int(ubar), zero on constrained dofs."""
        r, w = self._r, self._w
        w.waxpy(self.alpha, vbar, a0)
        self.mass_mult(w, r)
        if self.beta:
            self.system.K_csr.mult(vbar, w)
            r.axpy(self.beta, w)
        self.forces.internal_force(ubar, w)
        r.axpy(1.0, w)
        r.aypx(-1.0, self.system.f)
        r.array[self.system.constrained] = 0.0
        return r

    def start(self) -> State:
        self.forces.set_time(0.0)  # a contact tool at rest
        return super().start()

    def check_inversion(self, t: float) -> None:
        if self.forces.model.linear:  # small strain (with contact): J is not the model's
            return
        smallest = self.forces.min_det()
        if not smallest > 0:
            raise SolveError(f"inverted element: J = {smallest:.3g} <= 0 at t = {t:.4g} s")

    def destroy(self) -> None:
        super().destroy()
        self.forces.destroy()


class ExplicitModel(ModelForces, Newmark):
    """An explicit scheme with a model: f_int(ubar) once per step, ubar being u_{i+1}
    (beta_N = 0), so that the forces' last u is the new step's, which is checked for
    inverted elements. f_int and the smallest det F come from the compiled element loop
    (solvers/compiled_forces.py) where the model has one, unless `compiled` is False (the UFL
    form, as the implicit schemes assemble it)."""

    def __init__(
        self,
        system,
        h,
        scheme: Algorithm,
        model: Model,
        prefix,
        solver="direct",
        compiled: bool = True,
    ):
        self.forces = ElasticForces(system, model, compiled=compiled)
        super().__init__(system, h, scheme, prefix, solver)

    def step(self, state: State) -> State:
        self.forces.set_time((state.i + 1) * self.h)  # f_int(u_{i+1}) at t_{i+1}
        state = super().step(state)
        self.check_inversion(state.t)
        return state


class ExplicitLumpedModel(ExplicitModel):
    """`explicit-lumped` with a model whose f_int is compiled: the Newmark step of
    ExplicitModel as the linear scheme's (solvers/explicit_lumped.py) with f_int(ubar) in place
    of K ubar: one compiled element loop (f_int and the smallest det F) at ubar, the contact's
    penalty force added to f_int where there is one, then one compiled pass vbar = v + (1 -
    gamma) h a, a = (f - f_int - alpha M_L vbar) / S, v = vbar + gamma h a (0 on the
    constrained dofs, which then take their prescribed a and v) that also writes the next
    step's predictor of u into the other of two buffers (explicit_lumped.Predictors). The same
    arithmetic as ExplicitModel's step up to round-off (tests/test_compiled_forces.py)."""

    def __init__(self, system, h, scheme: Algorithm, model: Model, prefix, solver="direct"):
        super().__init__(system, h, scheme, model, prefix, solver, compiled=True)
        compiled = self.forces.compiled
        if compiled is None or not scheme.lumped or self.beta:
            raise ValueError("ExplicitLumpedModel needs M_L, no beta K_0 and a compiled f_int")
        self._alpha_ml, self._inv_s = lumped_factors(system, h, self.alpha, self.gamma)
        self._predictors = Predictors(system, (compiled.vector(), compiled.vector()))

    def step(self, state: State) -> State:
        s, h, c = self.system, self.h, self.system.constrained
        i = state.i + 1
        uc, vc, ac = s.prescribed(i * h)
        k = self._predictors.ubar(state, h, uc)
        ubar = self._predictors.vecs[k]
        f_int = self.forces.compiled_internal_force(self._predictors.buffers[k])  # and min det F
        if self.forces.edge is not None:  # SPEC 12: the contact's penalty force at t_{i+1}
            self.forces.edge.add_to(f_int, ubar.array_r, i * h)
        assert self.forces.compiled is not None  # checked by __init__
        self.forces.compiled.explicit_update(
            s.f.array_r,
            f_int,
            self._inv_s.array_r,
            self._alpha_ml.array_r,
            state.v.array,
            state.a.array,
            ubar.array_r,
            self._predictors.vecs[1 - k].array,
            self.gamma,
            h,
        )
        state.a.array[c] = ac
        state.v.array[c] = vc
        state.i, state.t = i, i * h
        self._predictors.advance(state, k)
        self.check_inversion(state.t)
        return state

    def destroy(self) -> None:
        super().destroy()
        self._predictors.destroy()


class NewtonModel(ModelForces, Newmark):
    """An implicit scheme with a model: Newton on delta at every step."""

    def __init__(self, system, h, scheme: Algorithm, model: Model, prefix, solver="direct"):
        self.forces = ElasticForces(system, model)
        super().__init__(system, h, scheme, prefix, solver)
        self.c_u = self.beta_N * h * h / 2  # u = ubar + c_u delta
        self._lumped_mass = None
        if self.lumped:
            self._lumped_mass = system.ML.copy()
            self._lumped_mass.array[system.constrained] = 0.0
        J = self._jacobian_matrix()
        self.snes = make_snes(system, J, prefix, self._function, self._jacobian)
        K = system.K
        self._trial, self._w2, self._a2 = K.createVecLeft(), K.createVecLeft(), K.createVecLeft()
        self._state: State | None = None
        self.newton_iterations = 0
        self.residual_norms: list[float] = []

    def step_solver(self, prefix: str, solver: str) -> None:
        return None  # the Newton iterations factorise their own Jacobian

    def iterations(self) -> int:
        return self.newton_iterations

    def _jacobian_matrix(self) -> PETSc.Mat:
        h = self.h
        return self.forces.jacobian(
            self.c_u,
            self.gamma * h * self.beta,
            1 + self.gamma * h * self.alpha,
            self._lumped_mass,
        )

    def _unknowns(self, x):
        """(u, v, a) of step i + 1 for the Newton unknown x = delta (in work vectors)."""
        ubar, vbar, a0 = self._state.u, self._state.v, self._state.a
        u, v, a = self._trial, self._w2, self._a2
        u.waxpy(self.c_u, x, ubar)
        v.waxpy(self.gamma * self.h, x, vbar)
        a.waxpy(1.0, x, a0)
        return u, v, a

    def _function(self, snes, x, g):
        """g = M (a + alpha v) + beta K_0 v + f_int(u) - f on the free dofs, 0 on constrained."""
        u, v, a = self._unknowns(x)
        r = ModelForces.residual(self, a, v, u)  # f - (the same terms)
        r.copy(g)
        g.scale(-1.0)

    def _jacobian(self, snes, x, J, P):
        u, _, _ = self._unknowns(x)
        self.forces.set_u(u)
        self._jacobian_matrix()

    def step(self, state: State) -> State:
        self.predict(state)
        self._state = state
        delta = self._delta
        delta.set(0.0)
        t = (state.i + 1) * self.h
        self.forces.set_time(t)
        try:
            with interrupt.calling_back():  # a signal in _function: raised, not a divergence
                self.snes.solve(None, delta)
        except PETSc.Error as err:
            raise SolveError(f"Newton at t = {t:.4g} s: {petsc_message(err)}") from None
        reason = self.snes.getConvergedReason()
        self.newton_iterations = self.snes.getIterationNumber()
        self.residual_norms = list(self.snes.getConvergenceHistory()[0])
        if reason <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int
            raise SolveError(f"Newton did not converge at t = {t:.4g} s (SNES reason {reason})")
        delta.array[self.system.constrained] = 0.0
        self.correct(state, delta)
        self.forces.set_u(state.u)
        self.check_inversion(state.t)
        return state

    def destroy(self) -> None:
        self.snes.destroy()
        self.mass_solve.destroy()
        self.forces.destroy()


class QuasiStaticModel:
    """quasi-static with a model: f_int(u_{i+1}) = f_{i+1} by Newton from u_i, the load
    sub-stepped (halved up to MAX_HALVINGS times) where Newton fails. v and a are 0."""

    def __init__(self, system, h: float, model: Model, prefix: str, solver: str = "direct"):
        if not h > 0:
            raise ValueError(f"time step h must be > 0 s, got {h}")
        self.system, self.h = system, h
        self.forces = ElasticForces(system, model)
        J = self.forces.jacobian(1.0, 0.0, 0.0)
        self.snes = make_snes(system, J, prefix, self._function, self._jacobian)
        K = system.K
        self._g, self._good = K.createVecLeft(), K.createVecLeft()
        self._load = 0.0  # the body-force factor of the last converged state
        self._theta = 0.0  # the body-force factor of the Newton solve under way
        self.newton_iterations = 0
        self.residual_norms: list[float] = []

    def iterations(self) -> int:
        return self.newton_iterations

    def destroy(self) -> None:
        self.snes.destroy()
        self.forces.destroy()

    def _function(self, snes, x, g):
        """g = f_int(x) - theta f on the free dofs, 0 on the constrained ones."""
        self.forces.internal_force(x, g)
        g.axpy(-self._theta, self.system.f)
        g.array[self.system.constrained] = 0.0

    def _jacobian(self, snes, x, J, P):
        self.forces.set_u(x)
        self.forces.jacobian(1.0, 0.0, 0.0)

    def start(self) -> State:
        self._load = 0.0  # u = 0 is the equilibrium without load
        return initial_state(self.system)

    def _newton(self, u) -> bool:
        try:
            with interrupt.calling_back():  # a signal in _function: raised, not a failure
                self.snes.solve(None, u)
        except PETSc.Error:
            return False
        self.newton_iterations += self.snes.getIterationNumber()
        self.residual_norms = list(self.snes.getConvergenceHistory()[0])
        return self.snes.getConvergedReason() > 0  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int

    def step(self, state: State) -> State:
        s, c = self.system, self.system.constrained
        i = state.i + 1
        t = i * self.h
        u = state.u
        start_uc, end_uc = u.array[c].copy(), s.prescribed(t)[0]
        start_load, end_load = self._load, 1.0
        u.copy(self._good)
        done, increment, halvings = 0.0, 1.0, 0
        self.newton_iterations = 0
        while done < 1.0:
            theta = min(1.0, done + increment)
            u.array[c] = start_uc + theta * (end_uc - start_uc)
            self._theta = start_load + theta * (end_load - start_load)
            self.forces.set_time(state.t + theta * self.h)  # a contact tool moves with the load
            if self._newton(u):
                done = theta
                u.copy(self._good)
                continue
            self._good.copy(u)
            halvings += 1
            if halvings > MAX_HALVINGS:
                raise SolveError(
                    f"Newton did not converge at t = {t:.4g} s, even with the load in "
                    f"increments of 1/{2**MAX_HALVINGS} "
                    f"(SNES reason {self.snes.getConvergedReason()})"
                )
            increment /= 2
        self._load = end_load
        smallest = np.inf if self.forces.model.linear else self.forces.min_det(u)
        if not smallest > 0:
            raise SolveError(f"inverted element: J = {smallest:.3g} <= 0 at t = {t:.4g} s")
        state.i, state.t = i, t
        return state


def integrator(
    scheme: Algorithm,
    system: System,
    h: float,
    model: Model,
    prefix: str,
    solver: str = "direct",
) -> NewtonModel | QuasiStaticModel | ExplicitModel:
    """The integrator of `scheme` (an ALGORITHMS entry) with a nonlinear `model`."""
    if not scheme.newmark:
        return QuasiStaticModel(system, h, model, prefix, solver)
    if scheme.explicit:
        cell = system.mesh.topology.cell_name()
        fused = scheme.lumped and not scheme.stiffness_damping
        if fused and compiled_forces.available(model, cell):
            return ExplicitLumpedModel(system, h, scheme, model, prefix, solver)
        return ExplicitModel(system, h, scheme, model, prefix, solver)
    return NewtonModel(system, h, scheme, model, prefix, solver)
