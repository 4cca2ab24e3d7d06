"""Linear solves for the integrators: a PETSc KSP set up and factorised once, or a diagonal.

Solver choices are PETSc options under a prefix per integrator (for example `implicit_`);
options already in the PETSc database (from the command line or options.set_petsc_options)
win over the defaults below.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from petsc4py import PETSc

from tissuebench.core.errors import UserError

if TYPE_CHECKING:
    from tissuebench.solvers.system import System

SOLVERS: dict[str, dict[str, object]] = {
    # factor once (MUMPS Cholesky: every step matrix here is symmetric positive definite, and
    # Cholesky halves the factorisation's work and memory against LU), then one
    # forward/backward substitution per step
    "direct": {"ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps"},
    # conjugate gradients, warm-started from the last solution, preconditioned by incomplete
    # Cholesky (ICC(0), one block per rank). The step matrices with a mass term are mass-
    # dominated: on the rod ICC(0) takes 19 (n = 16) to 56 (n = 48) iterations, each far
    # cheaper than a multigrid cycle, and beats "gamg" 1.4 to 2x at n = 16 to 32 (tissuebench
    # bench). On the nearly incompressible block (MP1) it weakens with the mesh and with the
    # ranks (N = 214: 106 iterations on 1 rank, 523 on 2; N = 324, 2 ranks: no convergence in 1000):
    # take "gamg" there. SBAIJ storage would save 1.3 to 1.6x per step on the rod, but its
    # block ICC(0) breaks down on the block under mpiexec -n 2 (indefinite preconditioner),
    # shift or not. K alone (quasi-static) takes "gamg".
    "cg": {
        "ksp_type": "cg",
        "pc_type": "bjacobi",
        "sub_pc_type": "icc",
        "ksp_rtol": 1e-12,
        "ksp_atol": 1e-50,
        "ksp_initial_guess_nonzero": True,
        "ksp_max_it": 1000,
    },
    # conjugate gradients with smoothed-aggregation multigrid (the rigid-body modes as its near
    # null space, one symmetric SOR sweep as smoother), warm-started: iterations independent of
    # the mesh, for K alone and for large nearly incompressible meshes (block MP1 at N = 590:
    # 34 iterations on 1 or 2 ranks, where ICC(0) takes 212 on 1 rank and fails on 2)
    "gamg": {
        "ksp_type": "cg",
        "pc_type": "gamg",
        "mg_levels_ksp_type": "richardson",
        "mg_levels_pc_type": "sor",
        "ksp_rtol": 1e-12,
        "ksp_atol": 1e-50,
        "ksp_initial_guess_nonzero": True,
        "ksp_max_it": 1000,
    },
    # the paper's Gauss-Seidel: Richardson iteration preconditioned by SOR
    "gauss-seidel": {
        "ksp_type": "richardson",
        "pc_type": "sor",
        "ksp_rtol": 1e-12,
        "ksp_atol": 1e-50,
        "ksp_initial_guess_nonzero": True,
        "ksp_max_it": 100000,
    },
}
# The one solve with the consistent mass M at step 0 (the initial acceleration): M is well
# conditioned, so CG + Jacobi reaches round-off in a few dozen iterations, with no second
# factorisation. Not a user choice; options under the prefix <integrator>_mass_ still win.
MASS_SOLVER: dict[str, object] = {
    "ksp_type": "cg",
    "pc_type": "jacobi",
    "ksp_rtol": 1e-14,
    "ksp_atol": 1e-50,
    "ksp_norm_type": "unpreconditioned",
    "ksp_max_it": 1000,
}
INTERNAL = {"mass": MASS_SOLVER}  # not a user choice


class SolveError(RuntimeError):
    """A linear solve that did not converge (treated as divergence of the run)."""


class OptionsError(UserError):
    """PETSc options that PETSc refuses (an unknown type, a bad value): bad input."""


def petsc_message(err: PETSc.Error) -> str:
    """The last line of a PETSc error's traceback, the one that says what is wrong."""
    lines = [line.split("] ", 1)[-1].strip() for line in str(err).splitlines() if line.strip()]
    return lines[-1] if lines else f"error code {err.ierr}"  # type: ignore[attr-defined]  # petsc4py's stubs lack Error.ierr


def mumps_failure(ksp: PETSc.KSP) -> str | None:
    """Why a MUMPS factorisation of ksp's preconditioner failed (INFOG(1) < 0), or None.
    MUMPS can fail without a PETSc error and leave inf in every solution."""
    pc = ksp.getPC()
    if pc.getType() not in ("lu", "cholesky") or pc.getFactorSolverType() != "mumps":
        return None
    infog1 = pc.getFactorMatrix().getMumpsInfog(1)
    if infog1 >= 0:
        return None
    infog2 = pc.getFactorMatrix().getMumpsInfog(2)
    return (
        f"MUMPS factorisation failed for {ksp.getOptionsPrefix()}: INFOG(1) = {infog1}, "
        f"INFOG(2) = {infog2}"
    )


@contextmanager
def petsc_defaults(prefix: str, defaults: dict) -> Iterator[None]:
    """Put `defaults` under `prefix` in PETSc's options database while the block runs (options
    already there, from the command line or `set_petsc_options`, win), and turn PETSc's
    refusal of an option into OptionsError. The defaults are removed afterwards, so that they
    do not leak into the next solver."""
    opts = PETSc.Options()
    added = [prefix + k for k in defaults if not opts.hasName(prefix + k)]
    for key in added:
        opts[key] = defaults[key[len(prefix) :]]  # type: ignore[index]  # petsc4py's stubs lack Options.__setitem__
    try:
        yield
    except PETSc.Error as err:
        raise OptionsError(f"PETSc options for prefix {prefix!r}: {petsc_message(err)}") from None
    finally:
        for key in added:
            opts.delValue(key)


def make_ksp(A: PETSc.Mat, prefix: str, solver: str = "direct") -> PETSc.KSP:
    """A KSP for the constant matrix A, set up (and factorised) once. `solver` is a key of
    SOLVERS or of INTERNAL."""
    if solver not in SOLVERS and solver not in INTERNAL:
        raise ValueError(f"unknown solver {solver!r}: use one of {', '.join(SOLVERS)}")
    ksp = PETSc.KSP().create(A.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    with petsc_defaults(prefix, SOLVERS[solver] if solver in SOLVERS else INTERNAL[solver]):
        ksp.setFromOptions()
    ksp.setUp()
    return ksp


class KSPSolve:
    """x = A^-1 b with a KSP built once."""

    def __init__(self, A, prefix, solver="direct"):
        self.A = A
        self.failure = None  # a failed set-up is the run's divergence at its first solve
        try:
            self.ksp = make_ksp(A, prefix, solver)
            self.failure = mumps_failure(self.ksp)
        except PETSc.Error as err:
            self.failure = f"{prefix} solver set-up failed: {petsc_message(err)}"
            return
        if self.ksp.getType() == "richardson" and self.ksp.getPC().getType() == "sor":
            # PETSc's Richardson + SOR fast path (PCApplyRichardson) runs all ksp_max_it sweeps
            # whatever the tolerance; with a monitor set, KSPSolve_Richardson takes its general
            # loop, which tests the residual every sweep (23 sweeps instead of 100000 on the rod)
            self.ksp.setMonitor(lambda ksp, its, rnorm: None)

    def iterations(self) -> int:
        """Iterations of the last solve (1 for a direct solve, PETSc's count)."""
        return 0 if self.failure else self.ksp.getIterationNumber()

    def destroy(self) -> None:
        if not self.failure:
            self.ksp.destroy()

    def __call__(self, b, x):
        if self.failure:
            raise SolveError(self.failure)
        self.ksp.solve(b, x)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SolveError(
                f"KSP {self.ksp.getOptionsPrefix()} did not converge (reason {reason})"
            )


class DiagonalSolve:
    """x = b / d, pointwise: a lumped mass needs no KSP."""

    def __init__(self, d):
        self.d = d

    def iterations(self) -> int:
        return 0

    def destroy(self) -> None:
        pass

    def __call__(self, b, x):
        x.pointwiseDivide(b, self.d)


def step_operator(
    system: System,
    mass_coef: float,
    stiffness_coef: float,
    lumped: bool,
    prefix: str,
    solver: str = "direct",
) -> KSPSolve | DiagonalSolve:
    """The solve with S = mass_coef (M or M_L) + stiffness_coef K, constrained rows and columns
    replaced by the identity. A diagonal S (lumped mass, no K) is solved pointwise."""
    if lumped and stiffness_coef == 0:
        d = system.ML.copy()
        d.scale(mass_coef)
        d.array[system.constrained] = 1.0
        return DiagonalSolve(d)
    if lumped:
        S = system.K.copy()
        S.scale(stiffness_coef)
        d = system.ML.copy()
        d.scale(mass_coef)
        S.setDiagonal(d, addv=PETSc.InsertMode.ADD_VALUES)
    else:
        S = system.M.copy()
        S.scale(mass_coef)
        if stiffness_coef != 0:
            # a scheme's K may reach further than M (anp: the neighbours' neighbours)
            same = getattr(system, "scheme", "standard") == "standard"
            structure = (
                PETSc.Mat.Structure.SAME_NONZERO_PATTERN
                if same
                else PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN
            )
            S.axpy(stiffness_coef, system.K, structure=structure)
    if (
        "baij" in S.getType()
    ):  # System(matrix_type="baij"): factorisations and preconditioners want AIJ
        S.convert("aij")  # in place: S is our own copy
    S.zeroRowsColumns(system.constrained_global, diag=1.0)
    if solver == "cg" and mass_coef == 0:
        solver = "gamg"  # K alone is not mass-dominated
    S.setOption(PETSc.Mat.Option.SPD, True)  # M or M_L plus c K, constrained rows and columns -> I
    S.setNearNullSpace(system.rigid_body_modes)  # for GAMG, chosen or by option
    return KSPSolve(S, prefix, solver)
