"""Stability of the time integrators: the extreme natural frequencies of the discrete system and
the largest stable time step of each Newmark scheme (SPEC sections 2 and 3).

On the free degrees of freedom (the constrained rows and columns removed: a reduced operator,
so no artificial eigenvalue from the boundary conditions), every scheme's matrices are
diagonalised by the eigenvectors of

    K phi = omega^2 M_s phi,     M_s = M (consistent) or M_L (lumped),

because every scheme's damping is Rayleigh damping with its own mass, C = alpha M_s + beta_s K
(beta_s = beta, or 0 for `explicit-lumped`). Each mode then obeys

    a + c(omega) v + omega^2 u = 0,    c(omega) = alpha + beta_s omega^2 = 2 zeta omega,

and one Newmark step maps (u, v, a)_i to (u, v, a)_{i+1} by a 3 x 3 amplification matrix
A(h, omega). A step h is stable when the spectral radius of A is at most 1 for every mode.

Units: omega in rad/s, h in s, alpha in 1/s, beta in s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import overload

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
from slepc4py import SLEPc

from tissuebench.meshes import BENCHMARKS, get_benchmark
from tissuebench.solvers import ALGORITHMS, get_integrator
from tissuebench.solvers.algorithm import Algorithm
from tissuebench.solvers.materials import Material
from tissuebench.solvers.simulate import max_nodal_displacement, simulate
from tissuebench.solvers.system import System


def newmark_schemes() -> dict[str, Algorithm]:
    """The Newmark schemes of the algorithm registry (solvers/__init__.py), by name: each entry
    carries beta_N, gamma, its mass (lumped or not) and whether C holds beta K."""
    return {name: a for name, a in ALGORITHMS.items() if a.newmark}


def explicit_schemes() -> tuple[str, ...]:
    """The names of the explicit Newmark schemes (beta_N = 0): conditionally stable."""
    return tuple(name for name, a in newmark_schemes().items() if a.explicit)


RHO_TOL = 1e-12  # a spectral radius above 1 + RHO_TOL is growth, not round-off
OMEGA_H_MAX = 1e8  # Omega = h omega up to which a scheme is searched for instability


# --- one mode ----------------------------------------------------------------------------------


@overload
def modal_damping(omega: float, alpha: float, beta: float) -> float: ...
@overload
def modal_damping(omega: np.ndarray, alpha: float, beta: float) -> np.ndarray: ...
def modal_damping(omega: float | np.ndarray, alpha: float, beta: float) -> float | np.ndarray:
    """c = alpha + beta omega^2 (1/s) of the mode omega (rad/s): C = alpha M_s + beta K."""
    return alpha + beta * omega**2


def amplification(
    h: float | np.ndarray, omega: float, c: float, beta_N: float, gamma: float
) -> np.ndarray:
    """The matrix A with (u, v, a)_{i+1} = A (u, v, a)_i for a + c v + omega^2 u = 0 and step h
    (s; an array of steps gives an array of matrices, shape (..., 3, 3)):

        u~ = u + h v + (1 - beta_N) h^2/2 a,  v~ = v + (1 - gamma) h a
        (1 + gamma h c + beta_N h^2/2 omega^2) a_{i+1} = -c v~ - omega^2 u~
        u_{i+1} = u~ + beta_N h^2/2 a_{i+1},  v_{i+1} = v~ + gamma h a_{i+1}
    """
    h = np.asarray(h, dtype=float)[..., None]
    k = omega**2
    one, zero = np.ones_like(h), np.zeros_like(h)
    u_pred = np.concatenate([one, h, (1 - beta_N) * h * h / 2], axis=-1)
    v_pred = np.concatenate([zero, one, (1 - gamma) * h], axis=-1)
    a_next = -(c * v_pred + k * u_pred) / (1 + gamma * h * c + beta_N * h * h / 2 * k)
    return np.stack(
        [u_pred + beta_N * h * h / 2 * a_next, v_pred + gamma * h * a_next, a_next], axis=-2
    )


def spectral_radius(
    h: float | np.ndarray, omega: float, c: float, beta_N: float, gamma: float
) -> float | np.ndarray:
    """The largest |eigenvalue| of the amplification matrix (dimensionless), for each h."""
    return np.abs(np.linalg.eigvals(amplification(h, omega, c, beta_N, gamma))).max(axis=-1)


def mode_critical_h(omega: float, c: float, beta_N: float, gamma: float) -> float:
    """The largest stable step h (s) of the mode omega (rad/s) with damping c (1/s); inf when
    the spectral radius stays at most 1 for every Omega = h omega up to OMEGA_H_MAX.

    Omega is scanned on a geometric grid for the first unstable value, then bisected."""

    def stable(Omega):
        return spectral_radius(np.asarray(Omega) / omega, omega, c, beta_N, gamma) <= 1 + RHO_TOL

    grid = np.geomspace(1e-3, OMEGA_H_MAX, 221)
    unstable = np.flatnonzero(~stable(grid))
    if len(unstable) == 0:
        return np.inf
    if unstable[0] == 0:
        raise ValueError(f"mode omega = {omega} rad/s is unstable for every step tried")
    lo, hi = grid[unstable[0] - 1], grid[unstable[0]]
    while hi - lo > 1e-12 * hi:
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if stable(mid) else (lo, mid)
    return float(lo / omega)


def critical_dt(
    scheme: str | Algorithm,
    material: Material,
    omega_min: float,
    omega_max: float,
    samples: int = 30,
) -> float:
    """The largest step h (s) stable for every mode with omega_min <= omega <= omega_max (rad/s),
    the scheme's whole discrete spectrum; inf for an unconditionally stable scheme.

    The minimum of the modal limits over the interval is taken on a geometric grid that holds
    both ends; for gamma = 1/2 and beta_N = 0 it is 2 / omega_max whatever the damping."""
    scheme = newmark_schemes()[scheme] if isinstance(scheme, str) else scheme
    assert scheme.beta_N is not None and scheme.gamma is not None  # a Newmark scheme's
    beta = material.beta if scheme.stiffness_damping else 0.0
    omegas = np.geomspace(omega_min, omega_max, samples)
    return min(
        mode_critical_h(w, modal_damping(w, material.alpha, beta), scheme.beta_N, scheme.gamma)
        for w in omegas
    )


def growth_per_step(scheme: str | Algorithm, material: Material, omega: float, h: float) -> float:
    """The spectral radius of the mode omega (rad/s) with step h (s) in `scheme`: above 1 it is
    the factor by which that mode grows at every step."""
    scheme = newmark_schemes()[scheme] if isinstance(scheme, str) else scheme
    assert scheme.beta_N is not None and scheme.gamma is not None  # a Newmark scheme's
    beta = material.beta if scheme.stiffness_damping else 0.0
    return float(
        spectral_radius(
            h, omega, modal_damping(omega, material.alpha, beta), scheme.beta_N, scheme.gamma
        )
    )


# --- the discrete spectrum ---------------------------------------------------------------------


def free_dofs(system: System) -> PETSc.IS:
    """The free degrees of freedom as a PETSc IS of global indices (owned ones on each rank)."""
    offset = system.V.dofmap.index_map.local_range[0] * system.gdim
    return PETSc.IS().createGeneral((system.free + offset).astype(PETSc.IntType), comm=system.comm)


def reduced_matrices(system: System, lumped: bool) -> tuple[PETSc.Mat, PETSc.Mat]:
    """(K_ff, M_ff): stiffness (N/m) and mass (kg) on the free dofs; M_ff is diagonal (M_L)
    when `lumped`. With contact (SPEC 12), K counts the penalty's stiffness with the whole
    contact edge touching (solvers/contact.py's stiffness_bound)."""
    free = free_dofs(system)
    stiffness = system.K
    if system.benchmark.contact is not None:
        from tissuebench.solvers.contact import stiffness_bound

        bound = stiffness_bound(system)
        stiffness = system.K.copy()
        stiffness.axpy(1.0, bound, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        bound.destroy()
    K = stiffness.createSubMatrix(free, free)
    if stiffness is not system.K:
        stiffness.destroy()
    if not lumped:
        return K, system.M.createSubMatrix(free, free)
    d = system.ML.getSubVector(free)
    ML = PETSc.Mat().createAIJ(K.getSizes(), nnz=(1, 0), comm=K.getComm())  # the diagonal only
    ML.setDiagonal(d)
    ML.assemble()
    system.ML.restoreSubVector(free, d)
    return K, ML


def _eps(K, M, smallest, tol):
    """A SLEPc solver for K x = lam M x (both symmetric, M positive definite), for the largest
    eigenvalue or (shift-and-invert about 0) the smallest; linear solves by MUMPS LU, or for the
    largest with a diagonal M (the lumped mass) by Jacobi, which is exact there."""
    eps = SLEPc.EPS().create(K.getComm())
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setDimensions(nev=1)
    eps.setTolerances(tol, 1000)
    st = eps.getST()
    if smallest:
        st.setType(SLEPc.ST.Type.SINVERT)
        eps.setTarget(0.0)
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
    else:
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_REAL)
    ksp = st.getKSP()
    ksp.setType(PETSc.KSP.Type.PREONLY)
    diagonal = M.getInfo(PETSc.Mat.InfoType.GLOBAL_SUM)["nz_used"] <= M.getSize()[0]
    if diagonal and not smallest:
        ksp.getPC().setType(PETSc.PC.Type.JACOBI)
    else:
        ksp.getPC().setType(PETSc.PC.Type.LU)
        ksp.getPC().setFactorSolverType("mumps")
    eps.setOptionsPrefix("stability_")
    eps.setFromOptions()
    return eps


def extreme_eigenvalue(
    K: PETSc.Mat, M: PETSc.Mat, smallest: bool = False, tol: float = 1e-10
) -> float:
    """The largest (or smallest) eigenvalue lam = omega^2 (rad^2/s^2) of K x = lam M x.
    Collective; every rank gets the same number."""
    eps = _eps(K, M, smallest, tol)
    eps.solve()
    if eps.getConverged() < 1:
        raise RuntimeError(
            f"SLEPc found no eigenvalue ({'smallest' if smallest else 'largest'}), "
            f"reason {eps.getConvergedReason()}"
        )
    lam = eps.getEigenvalue(0).real
    eps.destroy()
    return lam


def omega_range(system: System, lumped: bool) -> tuple[float, float]:
    """(omega_min, omega_max) in rad/s: the extreme natural frequencies of the free dofs with
    the consistent (lumped=False) or lumped mass."""
    K, M = reduced_matrices(system, lumped)
    lam_min = extreme_eigenvalue(K, M, smallest=True)
    lam_max = extreme_eigenvalue(K, M, smallest=False)
    K.destroy()
    M.destroy()
    return float(np.sqrt(lam_min)), float(np.sqrt(lam_max))


@dataclass
class Limit:
    """One scheme's stability on one system: the extreme frequencies of its mass (rad/s) and
    its critical step (s; inf: unconditionally stable)."""

    algorithm: str
    omega_min: float
    omega_max: float
    critical_dt: float

    @property
    def unconditional(self) -> bool:
        return bool(np.isinf(self.critical_dt))


def stability_limits(system: System, algorithms: Sequence[str] | None = None) -> dict[str, Limit]:
    """{algorithm: Limit} for the Newmark schemes of `system` (quasi-static has no dynamics)."""
    schemes = newmark_schemes()
    spectra = {}
    limits = {}
    for name in schemes if algorithms is None else algorithms:
        scheme = schemes[name]
        if scheme.lumped not in spectra:
            spectra[scheme.lumped] = omega_range(system, scheme.lumped)
        w_min, w_max = spectra[scheme.lumped]
        limits[name] = Limit(name, w_min, w_max, critical_dt(scheme, system.material, w_min, w_max))
    return limits


# --- checks against real runs, and the studies of `tissuebench stability` ---------------------

GROWTH_TO_DIVERGE = 1e20  # a mode seeded at round-off (1e-18 m) must grow this much to pass 100 m
# every benchmark with each of its materials: at its default mesh, and on its study meshes
DEFAULTS = [
    (name, m, e.mesh_size) for name, e in BENCHMARKS.items() if e.studied for m in e.materials
]
SWEEP = [
    (name, m, e.study_sizes) for name, e in BENCHMARKS.items() if e.studied for m in e.materials
]


def system_for(
    benchmark: str,
    material: str | None = None,
    mesh_size: int | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> System:
    options = {} if mesh_size is None else {"mesh_size": mesh_size}
    return System(get_benchmark(benchmark, comm=comm, **options), material)


def steps_to_diverge(growth: float, max_steps: int) -> int:
    """Steps for a mode growing by `growth` per step to grow by GROWTH_TO_DIVERGE, at most
    max_steps."""
    if growth <= 1:
        return max_steps
    return min(max_steps, math.ceil(math.log(GROWTH_TO_DIVERGE) / math.log(growth)))


def check_run(
    system: System, algorithm: str, h: float, steps: int
) -> tuple[str, int | None, float, float]:
    """Run `algorithm` with step h (s) for `steps` steps: (status, diverged step, largest nodal
    displacement reached in m, wall time in s)."""
    bench = system.benchmark
    peak = [0.0]

    def track(state):
        peak[0] = max(peak[0], max_nodal_displacement(state.u.array_r, system.gdim, system.comm))

    run = simulate(
        get_integrator(algorithm, system, h),
        steps,
        bench.extent,
        algorithm,
        on_step=track,
        keep=False,
    )
    return run.status, run.diverged_step, peak[0], run.wall_time_s


def run_check(
    system: System, limits: dict[str, Limit], margin: float = 0.05, max_steps: int = 100_000
) -> list[dict]:
    """For each explicit scheme, real runs at (1 + margin) and (1 - margin) times the predicted
    critical step. The run above goes on for the steps its fastest mode needs to grow by
    GROWTH_TO_DIVERGE (at most max_steps), the run below for as many steps as the run above
    took, and at least to the benchmark's end time T. A list of dicts, one per run."""
    rows = []
    for name in explicit_schemes():
        limit = limits[name]
        above = (1 + margin) * limit.critical_dt
        growth = growth_per_step(name, system.material, limit.omega_max, above)
        steps = steps_to_diverge(growth, max_steps)
        for factor in (1 + margin, 1 - margin):
            h = factor * limit.critical_dt
            status, step, peak, wall = check_run(system, name, h, steps)
            rows.append(
                {
                    "algorithm": name,
                    "h": h,
                    "ratio": factor,
                    "steps": steps,
                    "growth_per_step": growth_per_step(name, system.material, limit.omega_max, h),
                    "status": status,
                    "diverged_step": step,
                    "diverged_time": None if step is None else step * h,
                    "peak_displacement": peak,
                    "wall_time_s": wall,
                }
            )
            if (
                status == "diverged"
            ):  # the run below: as many steps as the run above took, at least to T
                assert step is not None  # a diverged run's
                steps = max(
                    step, math.ceil(system.benchmark.end_time / ((1 - margin) * limit.critical_dt))
                )
    return rows


def system_end(case: dict) -> float:
    return case["end_time"]


def case_summary(system: System, limits: dict[str, Limit]) -> dict:
    """The JSON record of one benchmark, material and mesh."""
    m = system.material
    algorithms = {}
    for name, limit in limits.items():
        algorithms[name] = {
            "critical_dt": None if limit.unconditional else limit.critical_dt,
            "unconditionally_stable": limit.unconditional,
            "omega_max": limit.omega_max,
            "omega_min": limit.omega_min,
            "mass": ALGORITHMS[name].mass,
            "damping": ALGORITHMS[name].damping,
        }
    return {
        "benchmark": system.benchmark.name,
        "material": m.name,
        "mesh_size": system.benchmark.mesh_size,
        "cell_size": BENCHMARKS[system.benchmark.name].cell_size(system.benchmark.mesh_size),
        "end_time": system.benchmark.end_time,
        "material_data": {"E": m.E, "nu": m.nu, "rho": m.rho, "alpha": m.alpha, "beta": m.beta},
        "units": {
            "critical_dt": "s",
            "omega_max": "rad/s",
            "omega_min": "rad/s",
            "cell_size": "m",
            "end_time": "s",
        },
        "algorithms": algorithms,
    }


def sweep(comm: MPI.Comm) -> list[dict]:
    """Every (benchmark, material, size) of SWEEP: a list of case summaries (explicit schemes)."""
    cases = []
    for bench, material, sizes in SWEEP:
        for size in sizes:
            system = system_for(bench, material, size, comm)
            cases.append(case_summary(system, stability_limits(system, explicit_schemes())))
    return cases
