"""Linear solves for the integrators: a PETSc KSP set up and factorised once, or a diagonal.

Solver choices are PETSc options under a prefix per integrator (for example `implicit_`);
options already in the PETSc database (from the command line or `set_petsc_options`) win
over the defaults below.
"""

from contextlib import contextmanager

from petsc4py import PETSc

from tissuebench.meshes.errors import UserError

SOLVERS = {
    # factor once (MUMPS Cholesky: every step matrix here is symmetric positive definite, and
    # Cholesky halves the factorisation's work and memory against LU), then one
    # forward/backward substitution per step
    "direct": {"ksp_type": "preonly", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps"},
    # conjugate gradients, warm-started from the last solution, preconditioned by incomplete
    # Cholesky (ICC(0), one block per rank). The step matrices with a mass term are mass-
    # dominated: on the rod ICC(0) takes 19 (n = 16) to 56 (n = 48) iterations, each far
    # cheaper than a multigrid cycle, and beats "gamg" 1.4 to 2x at n = 16 to 32 (tissuebench
    # bench). On the nearly incompressible block (MP1) it weakens with the mesh and with the ranks (N =
    # 214: 106 iterations on 1 rank, 523 on 2; N = 324, 2 ranks: no convergence in 1000):
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
MASS_SOLVER = {
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
    return lines[-1] if lines else f"error code {err.ierr}"


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
    return f"MUMPS factorisation failed for {ksp.getOptionsPrefix()}: INFOG(1) = {infog1}, INFOG(2) = {infog2}"


def parse_petsc_options(text: str) -> list[tuple[str, str]]:
    """The (name without its dash, value) pairs of options such as "-implicit_ksp_type cg
    -implicit_ksp_monitor" ("" for an option without a value); OptionsError if malformed."""
    words = text.split()
    pairs = []
    i = 0
    while i < len(words):
        if not words[i].startswith("-") or words[i].strip("-") == "":
            raise OptionsError(
                f"PETSc options: expected -name [value], got {words[i]!r} in {text!r}"
            )
        key = words[i].lstrip("-")
        if i + 1 < len(words) and not words[i + 1].startswith("-"):
            pairs.append((key, words[i + 1]))
            i += 2
        else:
            pairs.append((key, ""))
            i += 1
    return pairs


def set_petsc_options(text: str) -> None:
    """Put options such as "-implicit_ksp_type cg -implicit_pc_type gamg" in PETSc's database."""
    opts = PETSc.Options()
    for key, value in parse_petsc_options(text):
        opts[key] = value


def prefixes() -> list[str]:
    """The options prefixes of tissuebench's solvers: one per integrator (`implicit_`,
    `implicit_lumped_`, ...; its step solve and, for a nonlinear model, its Newton solver),
    and that prefix followed by `mass_` for the initial acceleration."""
    from tissuebench.solvers import ALGORITHMS

    steps = [name.replace("-", "_") + "_" for name in ALGORITHMS]
    return steps + [p + "mass_" for p in steps]


def prefix_of(key: str) -> str | None:
    """The longest of prefixes() that the option name `key` starts with, or None."""
    found = [p for p in prefixes() if key.startswith(p) and len(key) > len(p)]
    return max(found, key=len) if found else None


@contextmanager
def silent_stdout():
    """Standard output (file descriptor 1, and Python's sys.stdout, which petsc4py may route
    PETSc's printing to: monitors, views) is dropped while the block runs; C's buffers are
    flushed on either side."""
    import ctypes
    import io
    import os
    import sys
    from contextlib import redirect_stdout

    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    libc.fflush(None)
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        with redirect_stdout(io.StringIO()):
            yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def _try_prefix(prefix: str, solver: str, keys: list[str], comm) -> None:
    """Set up and run a KSP under `prefix` on a small SPD matrix (tridiagonal, 4 rows per
    rank), with the defaults that the run's solver takes there, and a Newton solver (SNES)
    if `keys` hold SNES options: PETSc reads and checks the options as in a run."""
    if prefix.endswith("mass_"):
        defaults = MASS_SOLVER
    else:  # K alone (quasi-static) takes gamg where the others take cg (step_operator)
        chosen = "gamg" if solver == "cg" and prefix == "quasi_static_" else solver
        defaults = SOLVERS[chosen]
    n = 4
    A = PETSc.Mat().createAIJ(((n, None), (n, None)), nnz=(3, 1), comm=comm)
    start, end = A.getOwnershipRange()
    size = A.getSize()[0]
    for i in range(start, end):
        A.setValue(i, i, 4.0)
        for j in (i - 1, i + 1):
            if 0 <= j < size:
                A.setValue(i, j, -1.0)
    A.assemble()
    A.setOption(PETSc.Mat.Option.SPD, True)
    b, x = A.createVecs()
    b.set(1.0)
    objects = [A, b, x]
    try:
        with petsc_defaults(prefix, defaults), silent_stdout():  # no monitor of this dry run
            ksp = PETSc.KSP().create(comm)
            objects.append(ksp)
            ksp.setOptionsPrefix(prefix)
            ksp.setOperators(A)
            ksp.setFromOptions()
            ksp.setUp()
            ksp.solve(b, x)
        if any(key[len(prefix) :].startswith("snes_") for key in keys):
            from tissuebench.solvers.nonlinear import NEWTON

            with petsc_defaults(prefix, NEWTON):
                snes = PETSc.SNES().create(comm)
                objects.append(snes)
                snes.setOptionsPrefix(prefix)
                snes.setFromOptions()
    finally:
        for obj in objects:
            obj.destroy()


def check_petsc_options(text: str, solver: str, comm=None) -> None:
    """Put the --petsc options in PETSc's database and check them before anything runs
    (collective; the same OptionsError, one line, on every rank): each must be under one of
    prefixes() (global options such as -log_view and -help are not taken: tissuebench passes
    solver options only); PETSc must accept each value (a type it has, a number where it
    wants one) and find each solver package (-..._pc_factor_mat_solver_type pastix where
    PETSc was built without it); and each must be read by a solver set up as the run sets
    it up with `solver` (an option that nothing reads, a misspelt name or a tolerance of a
    direct solve, would be ignored)."""
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    pairs = parse_petsc_options(text)
    outside = [f"-{key}" for key, _ in pairs if prefix_of(key) is None]
    if outside:
        steps = [p for p in prefixes() if not p.endswith("mass_")]
        raise OptionsError(
            f"PETSc option(s) {', '.join(outside)}: not under a solver's prefix "
            f"({', '.join(steps)}, each optionally followed by mass_); --petsc takes solver "
            "options only, not global ones such as -log_view or -help"
        )
    set_petsc_options(text)
    groups: dict[str, list[str]] = {}
    for key, _ in pairs:
        groups.setdefault(prefix_of(key), []).append(key)
    error = None
    for prefix, keys in groups.items():
        try:
            _try_prefix(prefix, solver, keys, comm)
        except OptionsError as err:
            error = str(err)
        except PETSc.Error as err:
            error = f"PETSc options for prefix {prefix!r}: {petsc_message(err)}"
        if error:
            break
    error = next((e for e in comm.allgather(error) if e), None)
    unread = [f"-{key}" for key, _ in pairs if not PETSc.Options().used(key)]
    if unread and not error:
        error = (
            f"PETSc option(s) {', '.join(unread)}: read by no solver with --solver {solver} "
            "(a misspelt name, or an option of another solver type); PETSc would ignore them"
        )
    if error:
        for key, _ in pairs:  # out of the database: PETSc would list them as unused at exit
            PETSc.Options().delValue(key)
        raise OptionsError(error)


@contextmanager
def petsc_defaults(prefix: str, defaults: dict):
    """Put `defaults` under `prefix` in PETSc's options database while the block runs (options
    already there, from the command line or `set_petsc_options`, win), and turn PETSc's
    refusal of an option into OptionsError. The defaults are removed afterwards, so that they
    do not leak into the next solver."""
    opts = PETSc.Options()
    added = [prefix + k for k in defaults if not opts.hasName(prefix + k)]
    for key in added:
        opts[key] = defaults[key[len(prefix) :]]
    try:
        yield
    except PETSc.Error as err:
        raise OptionsError(f"PETSc options for prefix {prefix!r}: {petsc_message(err)}") from None
    finally:
        for key in added:
            opts.delValue(key)


def make_ksp(A, prefix, solver="direct"):
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


def step_operator(system, mass_coef, stiffness_coef, lumped, prefix, solver="direct"):
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
            S.axpy(stiffness_coef, system.K, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
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
