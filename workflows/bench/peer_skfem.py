"""The peer of `tissuebench bench`: the same study written with scikit-fem and SciPy.

It is what a user would otherwise write: K and M assembled by scikit-fem on the same Q1
mesh (2 x 2 (x 2) Gauss points, exact on the benchmarks' box cells), the same constrained
degrees of freedom and prescribed motion, and the same Newmark updates (SPEC section 3),
with the linear solves done by
  - "superlu": scipy.sparse.linalg.splu, factorised once;
  - "pardiso": MKL PARDISO through pypardiso (in the bench extra; skipped if it will not
    import), factorised once (Cholesky);
  - "pyamg":   scipy CG preconditioned by pyamg smoothed aggregation (rigid-body modes),
               warm-started from the last solution, relative residual 1e-12;
and the explicit-lumped step as one CSR matrix-vector product plus numpy updates.
The step matrix is restricted to the free degrees of freedom (constrained ones are known).

Units: SI throughout (m, s, kg, N); times in s. Serial only (SciPy has no MPI).
"""

from __future__ import annotations

import ctypes
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
import skfem
from skfem.helpers import dot
from skfem.models.elasticity import linear_elasticity

if TYPE_CHECKING:
    from skfem.assembly.form.form import FormExtraParams
    from skfem.element import DiscreteField

# an integrator's state: [step i, u, v, a] (m, m/s, m/s^2 per dof)
PeerState = list[Any]  # [i, u, v, a]: the step, then three arrays

# The benchmarks as SPEC sections 4 and 5 define them (the needle tip width is 0).
ROD_GRAVITY = (0.0, -0.05, 0.0)  # m/s^2
NEEDLE = (1.0, 0.5)  # m
NEEDLE_SPEED = -0.08  # m/s, for 0 <= t < 2 s
CG_RTOL = 1e-12  # relative residual of the iterative solves, as tissuebench's "cg"
MASS_RTOL = 1e-14  # relative residual of the one initial consistent-mass solve (CG + Jacobi)


def skfem_mesh(points: np.ndarray, cells: np.ndarray) -> skfem.Mesh:
    """A MeshHex (3D) or MeshQuad (2D) from node coordinates `points` (m, one row per node)
    and `cells` (node indices, any vertex order). Each cell's vertices are put in scikit-fem's
    order by their position in the cell, which needs axis-aligned box cells (as here)."""
    gdim = points.shape[1]
    ref = (skfem.MeshHex() if gdim == 3 else skfem.MeshQuad()).p.T  # reference corners, skfem order
    xc = points[cells]
    lo, hi = xc.min(axis=1, keepdims=True), xc.max(axis=1, keepdims=True)
    code = ((xc - lo) > 0.5 * (hi - lo)) @ (2 ** np.arange(gdim))  # which corner each vertex is
    order = np.argsort(code, axis=1)
    if not (np.take_along_axis(code, order, axis=1) == np.arange(2**gdim)).all():
        raise ValueError("the peer needs axis-aligned box cells")
    ref_code = (ref > 0.5) @ (2 ** np.arange(gdim))
    t = np.take_along_axis(cells, order, axis=1)[:, ref_code]
    mesh_type = skfem.MeshHex if gdim == 3 else skfem.MeshQuad
    return mesh_type(np.ascontiguousarray(points.T), np.ascontiguousarray(t.T))


@skfem.BilinearForm
def mass_form(u: DiscreteField, v: DiscreteField, w: FormExtraParams) -> np.ndarray:
    return w.rho * dot(u, v)


@skfem.LinearForm
def gravity_form(v: DiscreteField, w: FormExtraParams) -> np.ndarray:
    return w.rho * dot(w.g, v)


def rigid_body_modes(points: np.ndarray) -> np.ndarray:
    """The rigid-body motions of the nodes `points` (m) as columns, interleaved dofs."""
    n, gdim = points.shape
    x = points - points.mean(axis=0)
    if gdim == 2:
        B = np.zeros((n, 2, 3))
        B[:, 0, 0] = B[:, 1, 1] = 1.0
        B[:, 0, 2], B[:, 1, 2] = -x[:, 1], x[:, 0]
    else:
        B = np.zeros((n, 3, 6))
        for c in range(3):
            B[:, c, c] = 1.0
        B[:, 0, 3], B[:, 1, 3] = -x[:, 1], x[:, 0]
        B[:, 1, 4], B[:, 2, 4] = -x[:, 2], x[:, 1]
        B[:, 0, 5], B[:, 2, 5] = x[:, 2], -x[:, 0]
    return B.reshape(n * gdim, -1)


class Material:
    """Lame parameters mu, lmbda (Pa; plane strain in 2D), density rho (kg/m^3) and Rayleigh
    alpha (1/s), beta (s): the values tissuebench uses, passed in (no tissuebench import)."""

    def __init__(self, mu, lmbda, rho, alpha, beta):
        self.mu, self.lmbda, self.rho, self.alpha, self.beta = mu, lmbda, rho, alpha, beta


class PeerSystem:
    """K (N/m), M and M_L (kg), f (N) of the rod or block on the mesh (points, cells), with the
    constrained dofs found by their coordinates. `assembly_s` holds the assembly times (s)."""

    def __init__(self, benchmark, points, cells, material):
        self.benchmark = benchmark
        gdim = points.shape[1]
        self.gdim, self.points = gdim, points
        self.material = mat = material
        mu, lmbda = mat.mu, mat.lmbda
        self.mesh = skfem_mesh(points, cells)
        element = skfem.ElementVector(skfem.ElementHex1() if gdim == 3 else skfem.ElementQuad1())
        self.basis = skfem.Basis(self.mesh, element, intorder=3)  # 2 Gauss points per direction
        self.assembly_s = {}
        start = time.perf_counter()
        self.K = linear_elasticity(lmbda, mu).assemble(self.basis).tocsr()
        self.assembly_s["K"] = time.perf_counter() - start
        start = time.perf_counter()
        self.M = mass_form.assemble(self.basis, rho=mat.rho).tocsr()
        self.assembly_s["M"] = time.perf_counter() - start
        g = np.array(ROD_GRAVITY if gdim == 3 else (0.0, 0.0))  # the rod is 3D, the block 2D
        self.f = gravity_form.assemble(self.basis, rho=mat.rho, g=g[:, None, None])
        self.ML = np.asarray(self.M.sum(axis=1)).ravel()
        self._constrain()

    def _constrain(self):
        x = self.mesh.p.T  # skfem node i is row i of `points`; its dofs are gdim*i + c
        if self.gdim == 3:  # the rod
            fixed = np.isclose(x[:, 0], 0.0)
            needle = np.zeros(len(x), dtype=bool)
        else:
            fixed = np.isclose(x[:, 0], 0.0) | np.isclose(x[:, 1], 0.0) | np.isclose(x[:, 1], 1.0)
            needle = np.isclose(x[:, 0], NEEDLE[0]) & np.isclose(x[:, 1], NEEDLE[1])
        gdim = self.gdim
        nodes = np.flatnonzero(fixed | needle)
        self.constrained = (gdim * nodes[:, None] + np.arange(gdim)).ravel()
        self.needle = (gdim * np.flatnonzero(needle)[:, None] + np.arange(gdim)).ravel()
        self.free = np.setdiff1d(np.arange(self.K.shape[0]), self.constrained)

    def prescribed(self, t: float) -> np.ndarray:
        """(u, v, a) of the constrained dofs at time t (s): zero but for the needle's x motion."""
        values = np.zeros((3, self.K.shape[0]))
        values[0, self.needle[0::2]] = NEEDLE_SPEED * min(t, 2.0)
        values[1, self.needle[0::2]] = NEEDLE_SPEED if t < 2.0 else 0.0
        return values[:, self.constrained]

    def num_dofs(self) -> int:
        return self.K.shape[0]


_PARDISO: list[Any] = []  # MKL's pardiso function, found once (pypardiso's library search is slow)


def mkl_pardiso() -> Callable[..., None]:
    if not _PARDISO:
        import pypardiso

        _PARDISO.append(pypardiso.PyPardisoSolver()._mkl_pardiso)
    return _PARDISO[0]


class Pardiso:
    """MKL PARDISO for a symmetric positive definite matrix (mtype 2, upper triangle, MKL's
    default parameters), factorised once; each solve is phase 33 only."""

    def __init__(self, A):
        self.A = sp.triu(A, format="csr")
        self.A.sort_indices()
        self._ia = (self.A.indptr + 1).astype(np.int32)
        self._ja = (self.A.indices + 1).astype(np.int32)
        self._pt = np.zeros(64, dtype=np.int64)  # PARDISO's handle
        self._iparm = np.zeros(64, dtype=np.int32)  # all 0: MKL's defaults
        self._call(12, np.zeros(A.shape[0]))

    def _call(self, phase, b):
        A = self.A
        x = np.zeros_like(b)
        err = ctypes.c_int32(0)
        i32 = ctypes.POINTER(ctypes.c_int32)
        one = ctypes.byref(ctypes.c_int32(1))
        mkl_pardiso()(
            self._pt.ctypes.data_as(ctypes.POINTER(ctypes.c_int64)),
            one,
            one,
            ctypes.byref(ctypes.c_int32(2)),
            ctypes.byref(ctypes.c_int32(phase)),
            ctypes.byref(ctypes.c_int32(A.shape[0])),
            A.data.ctypes.data_as(ctypes.c_void_p),
            self._ia.ctypes.data_as(i32),
            self._ja.ctypes.data_as(i32),
            None,
            one,
            self._iparm.ctypes.data_as(i32),
            ctypes.byref(ctypes.c_int32(0)),
            b.ctypes.data_as(ctypes.c_void_p),
            x.ctypes.data_as(ctypes.c_void_p),
            ctypes.byref(err),
        )
        if err.value != 0:
            raise RuntimeError(f"PARDISO error {err.value}")
        return x

    def __call__(self, b):
        return self._call(33, np.ascontiguousarray(b))

    def free(self) -> None:
        self._call(-1, np.zeros(self.A.shape[0]))


def pardiso_available() -> bool:
    try:
        mkl_pardiso()
        return True
    except (ImportError, OSError):
        return False


class PyamgCG:
    """CG with a pyamg smoothed-aggregation preconditioner, warm-started from the last solution."""

    def __init__(self, A, B):
        import pyamg

        self.A = A
        self.ml = pyamg.smoothed_aggregation_solver(A, B=B, symmetry="hermitian")
        self.P = self.ml.aspreconditioner(cycle="V")
        self.x = np.zeros(A.shape[0])
        self.iterations = []

    def __call__(self, b):
        count = [0]

        def callback(xk):
            count[0] += 1

        x, info = spla.cg(
            self.A, b, x0=self.x, rtol=CG_RTOL, atol=0.0, M=self.P, maxiter=1000, callback=callback
        )
        if info != 0:
            raise RuntimeError(f"CG + pyamg did not converge (info {info})")
        self.iterations.append(count[0])
        self.x = x
        return x


def direct_superlu(A: sp.csr_matrix) -> Callable[[np.ndarray], np.ndarray]:
    """splu factorised once, with the ordering for a symmetric positive definite matrix."""
    lu = spla.splu(
        A.tocsc(),
        permc_spec="MMD_AT_PLUS_A",
        diag_pivot_thresh=0.0,
        options={"SymmetricMode": True},
    )
    return lu.solve


def make_solver(
    A: sp.csr_matrix, solver: str, system: PeerSystem
) -> Callable[[np.ndarray], np.ndarray]:
    """x = A^-1 b for the free-dof matrix A with `solver` (superlu, pardiso or pyamg)."""
    if solver == "superlu":
        return direct_superlu(A)
    if solver == "pardiso":
        return Pardiso(A)
    if solver == "pyamg":
        B = rigid_body_modes(system.points)[system.free]
        return PyamgCG(A, B)
    raise ValueError(f"unknown peer solver {solver!r}")


def jacobi_cg(A: sp.csr_matrix, b: np.ndarray) -> np.ndarray:
    """A^-1 b by CG with a Jacobi preconditioner (the consistent mass is well conditioned)."""
    d = A.diagonal()
    P = spla.LinearOperator(A.shape, matvec=lambda r: r / d)
    x, info = spla.cg(A, b, rtol=MASS_RTOL, atol=0.0, M=P, maxiter=2000)
    if info != 0:
        raise RuntimeError(f"mass CG did not converge (info {info})")
    return x


class PeerNewmark:
    """Newmark in the paper's parameterisation, as solvers/newmark.py: the free part delta of
    a_{i+1} solves S delta = f - M (a0 + alpha vbar) - K (ubar + beta vbar) with
    S = (1 + gamma h alpha) M + (gamma h beta + beta_N h^2/2) K on the free dofs."""

    def __init__(self, system, h, beta_N, gamma, lumped, stiffness_damping=True, solver="superlu"):
        s = system
        self.system, self.h, self.beta_N, self.gamma, self.lumped = s, h, beta_N, gamma, lumped
        self.alpha = s.material.alpha
        self.beta = s.material.beta if stiffness_damping else 0.0
        cm = 1 + gamma * h * self.alpha
        ck = gamma * h * self.beta + beta_N * h * h / 2
        free = s.free
        if lumped and ck == 0:
            self.solve = lambda b, d=cm * s.ML[free]: b / d
        else:
            mass = sp.diags(s.ML) if lumped else s.M
            S = (cm * mass + ck * s.K).tocsr()[free][:, free]
            self.solve = make_solver(S.tocsr(), solver, s)

    def mass_mult(self, x: np.ndarray) -> np.ndarray:
        return self.system.ML * x if self.lumped else self.system.M @ x

    def residual(self, a0: np.ndarray, vbar: np.ndarray, ubar: np.ndarray) -> np.ndarray:
        s = self.system
        r = s.f - self.mass_mult(a0 + self.alpha * vbar)
        r -= s.K @ (ubar + self.beta * vbar) if self.beta else s.K @ ubar
        return r

    def start(self) -> PeerState:
        """Step 0: u = v = 0 on free dofs, constrained dofs prescribed, M a = f - C v - K u."""
        s = self.system
        n = s.num_dofs()
        u, v, a = np.zeros(n), np.zeros(n), np.zeros(n)
        u[s.constrained], v[s.constrained], a[s.constrained] = s.prescribed(0.0)
        r = self.residual(a, v, u)[s.free]
        if self.lumped:
            a[s.free] += r / s.ML[s.free]
        else:
            a[s.free] += jacobi_cg(s.M[s.free][:, s.free], r)
        return [0, u, v, a]

    def step(self, state: PeerState) -> PeerState:
        """Advance [i, u, v, a] from t_i to t_{i+1} = (i + 1) h, in place."""
        s, h, c = self.system, self.h, self.system.constrained
        i, u, v, a = state
        i += 1
        uc, vc, ac = s.prescribed(i * h)
        u += h * v + ((1 - self.beta_N) * h * h / 2) * a
        v += ((1 - self.gamma) * h) * a
        a[:] = 0.0
        a[c] = ac  # a0; u and v on constrained dofs are set to their prescribed values:
        u[c], v[c] = uc, vc
        delta = self.solve(self.residual(a, v, u)[s.free])
        u[s.free] += (self.beta_N * h * h / 2) * delta
        v[s.free] += (self.gamma * h) * delta
        a[s.free] += delta
        state[0] = i
        return state


class PeerExplicitLumped(PeerNewmark):
    """explicit-lumped written as a SciPy user would: one CSR product K u per step."""

    def __init__(self, system, h):
        super().__init__(system, h, 0.0, 0.5, True, stiffness_damping=False)
        s = self.system
        self.inv_mass = 1.0 / ((1 + h * self.alpha / 2) * s.ML)
        self.inv_mass[s.constrained] = 0.0

    def step(self, state: PeerState) -> PeerState:
        s, h, c = self.system, self.h, self.system.constrained
        i, u, v, a = state
        i += 1
        uc, vc, ac = s.prescribed(i * h)
        u += h * v + (h * h / 2) * a
        v += (h / 2) * a
        u[c], v[c] = uc, vc
        r = s.f - s.K @ u - (self.alpha * s.ML) * v  # the constrained rows are dropped below
        a[:] = self.inv_mass * r
        a[c] = ac
        v += (h / 2) * a
        v[c] = vc
        state[0] = i
        return state


class PeerQuasiStatic:
    """K u_{i+1} = f_{i+1} on the free dofs, constrained dofs prescribed; v = a = 0."""

    def __init__(self, system, h, solver="superlu"):
        s = system
        self.system, self.h = s, h
        self.solve = make_solver(s.K[s.free][:, s.free].tocsr(), solver, s)

    def start(self) -> PeerState:
        s = self.system
        n = s.num_dofs()
        u = np.zeros(n)
        u[s.constrained] = s.prescribed(0.0)[0]
        return [0, u, np.zeros(n), np.zeros(n)]

    def step(self, state: PeerState) -> PeerState:
        s = self.system
        i = state[0] + 1
        u = state[1]
        u[:] = 0.0
        u[s.constrained] = s.prescribed(i * self.h)[0]
        r = s.f - s.K @ u
        u[s.free] += self.solve(r[s.free])
        state[0] = i
        return state


def get_peer_integrator(
    name: str, system: PeerSystem, h: float, solver: str = "superlu"
) -> PeerNewmark | PeerQuasiStatic:
    """The peer of tissuebench's integrator `name` with time step h (s)."""
    if name == "implicit":
        return PeerNewmark(system, h, 0.5, 0.5, lumped=False, solver=solver)
    if name == "implicit-lumped":
        return PeerNewmark(system, h, 0.5, 0.5, lumped=True, solver=solver)
    if name == "explicit":
        return PeerNewmark(system, h, 0.0, 0.5, lumped=False, solver=solver)
    if name == "explicit-lumped":
        return PeerExplicitLumped(system, h)
    if name == "quasi-static":
        return PeerQuasiStatic(system, h, solver)
    raise ValueError(f"unknown algorithm {name!r}")


def sort_by_coordinates(points: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(points, values) with the nodes in the order solvers.system.gather_by_coordinates uses:
    by x, then y, then z, coordinates rounded to 1e-10 m. `values` has one row per node."""
    order = np.lexsort(np.round(points, 10).T[::-1])
    return points[order], values[order]
