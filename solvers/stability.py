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

from dataclasses import dataclass

from petsc4py import PETSc
from slepc4py import SLEPc

import numpy as np


@dataclass(frozen=True)
class Scheme:
    """A Newmark scheme as solvers/newmark.py runs it: (beta_N, gamma) of SPEC section 3, the
    mass it uses, and whether its damping has the stiffness term beta K."""

    beta_N: float
    gamma: float
    lumped: bool
    stiffness_damping: bool


# The SPEC section 2 table, as the integrators in solvers/ build it (tests check they agree).
SCHEMES = {
    "implicit": Scheme(0.5, 0.5, lumped=False, stiffness_damping=True),
    "implicit-lumped": Scheme(0.5, 0.5, lumped=True, stiffness_damping=True),
    "explicit": Scheme(0.0, 0.5, lumped=False, stiffness_damping=True),
    "explicit-lumped": Scheme(0.0, 0.5, lumped=True, stiffness_damping=False),
}

RHO_TOL = 1e-12  # a spectral radius above 1 + RHO_TOL is growth, not round-off
OMEGA_H_MAX = 1e8  # Omega = h omega up to which a scheme is searched for instability


# --- one mode ----------------------------------------------------------------------------------


def modal_damping(omega, alpha, beta):
    """c = alpha + beta omega^2 (1/s) of the mode omega (rad/s): C = alpha M_s + beta K."""
    return alpha + beta * omega**2


def amplification(h, omega, c, beta_N, gamma):
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
    return np.stack([u_pred + beta_N * h * h / 2 * a_next, v_pred + gamma * h * a_next, a_next], axis=-2)


def spectral_radius(h, omega, c, beta_N, gamma):
    """The largest |eigenvalue| of the amplification matrix (dimensionless), for each h."""
    return np.abs(np.linalg.eigvals(amplification(h, omega, c, beta_N, gamma))).max(axis=-1)


def mode_critical_h(omega, c, beta_N, gamma):
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


def critical_dt(scheme, material, omega_min, omega_max, samples=30):
    """The largest step h (s) stable for every mode with omega_min <= omega <= omega_max (rad/s),
    the scheme's whole discrete spectrum; inf for an unconditionally stable scheme.

    The minimum of the modal limits over the interval is taken on a geometric grid that holds
    both ends; for gamma = 1/2 and beta_N = 0 it is 2 / omega_max whatever the damping."""
    scheme = SCHEMES[scheme] if isinstance(scheme, str) else scheme
    beta = material.beta if scheme.stiffness_damping else 0.0
    omegas = np.geomspace(omega_min, omega_max, samples)
    return min(mode_critical_h(w, modal_damping(w, material.alpha, beta), scheme.beta_N, scheme.gamma)
               for w in omegas)


def growth_per_step(scheme, material, omega, h):
    """The spectral radius of the mode omega (rad/s) with step h (s) in `scheme`: above 1 it is
    the factor by which that mode grows at every step."""
    scheme = SCHEMES[scheme] if isinstance(scheme, str) else scheme
    beta = material.beta if scheme.stiffness_damping else 0.0
    return float(spectral_radius(h, omega, modal_damping(omega, material.alpha, beta),
                                 scheme.beta_N, scheme.gamma))


# --- the discrete spectrum ---------------------------------------------------------------------


def free_dofs(system):
    """The free degrees of freedom as a PETSc IS of global indices (owned ones on each rank)."""
    offset = system.V.dofmap.index_map.local_range[0] * system.gdim
    return PETSc.IS().createGeneral((system.free + offset).astype(PETSc.IntType), comm=system.comm)


def reduced_matrices(system, lumped):
    """(K_ff, M_ff): stiffness (N/m) and mass (kg) on the free dofs; M_ff is diagonal (M_L)
    when `lumped`."""
    free = free_dofs(system)
    K = system.K.createSubMatrix(free, free)
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


def extreme_eigenvalue(K, M, smallest=False, tol=1e-10):
    """The largest (or smallest) eigenvalue lam = omega^2 (rad^2/s^2) of K x = lam M x.
    Collective; every rank gets the same number."""
    eps = _eps(K, M, smallest, tol)
    eps.solve()
    if eps.getConverged() < 1:
        raise RuntimeError(f"SLEPc found no eigenvalue ({'smallest' if smallest else 'largest'}), "
                           f"reason {eps.getConvergedReason()}")
    lam = eps.getEigenvalue(0).real
    eps.destroy()
    return lam


def omega_range(system, lumped):
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
    def unconditional(self):
        return bool(np.isinf(self.critical_dt))


def stability_limits(system, algorithms=tuple(SCHEMES)):
    """{algorithm: Limit} for the Newmark schemes of `system` (quasi-static has no dynamics)."""
    spectra = {}
    limits = {}
    for name in algorithms:
        scheme = SCHEMES[name]
        if scheme.lumped not in spectra:
            spectra[scheme.lumped] = omega_range(system, scheme.lumped)
        w_min, w_max = spectra[scheme.lumped]
        limits[name] = Limit(name, w_min, w_max, critical_dt(scheme, system.material, w_min, w_max))
    return limits
