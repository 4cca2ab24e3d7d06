"""The truth's solver (SPEC section 10): DOLFINx forms and PETSc solvers that converge to the
continuum problem of sections 1-5 and 8 without locking.

Discretisation (all in SI units: m, s, Pa, kg/m^3):

- Displacement: second-order Lagrange (Q2 on the benchmarks' quadrilateral/hexahedral grids,
  P2 on simplices) on the benchmarks' own first-order meshes (the boxes are straight).
- Displacement only (`displacement`) for the linear law with nu < 0.45:
  sigma_lin(u + beta v) : eps(w).
- Taylor-Hood (Q2-Q1) for the linear law with nu >= 0.45 (`mixed`): unknowns (u, p) with
  p = -lambda div(u + beta v), the Kelvin-Voigt form of SPEC 10's Rayleigh damping:
      2 mu eps(u + beta v) : eps(w) - p div w - q (div(u + beta v) + p / lambda) = 0,
  exactly the linear law with stiffness-proportional damping beta sigma_lin(v), and free of
  volumetric locking as lambda -> infinity.
- Taylor-Hood for `neo-hookean` and `neo-hookean-barrier` (always, `mixed-nh`): unknowns
  (u, p, p_d). The pressure p is the volumetric stress U'(J), held by the equation
  q (U'(J) - p) / kappa = 0, and enters the stress as p J F^-T beside P_iso = dpsi_iso/dF,
  psi_iso = (mu/2)(J^(-2/3) I1 - 3): with p = U'(J) this is SPEC 8's P exactly, for
  U = (kappa/2)(J - 1)^2 (U' = kappa (J - 1)) and the barrier (kappa/4)(J^2 - 1 - 2 ln J)
  (U' = (kappa/2)(J - 1/J)).
  The damping beta sigma_lin(v) = beta (2 mu eps(v) + lambda div v I) carries its volumetric
  part through p_d = lambda beta div v (a second Q1 field, again with 1/lambda), so that it
  does not lock either:
      P_iso(F) : grad w + p J F^-T : grad w + 2 mu beta eps(v) : eps(w) + p_d div w
      + q (U'(J) - p) / kappa + q_d (beta div v - p_d / lambda) = 0.
  2D is plane strain (F33 = 1: I1 = tr(C_2D) + 1, J = det F_2D).
- Axisymmetric (SPEC 13, Problem.axisymmetric): the mesh is a meridian (r, z) of a body of
  revolution about the z axis, u = (u_r, u_z). The strains take the hoop term u_r / r
  (axisymmetric.eps_axi, div_axi), the neo-Hookean F its F_thetatheta = 1 + u_r / r (J =
  det F_2D (1 + u_r / r), I1 = tr C_2D + (1 + u_r / r)^2), every integral (inertia, damping,
  elastic, the Taylor-Hood rows, the contact's ds) is weighted by 2 pi r, so that residuals
  and forces are the revolved body's (N); u_r = 0 on the axis is a Boundary on component 0
  only (Boundary.components). The needle's force is then (0, 0, F_z), N.
- Time: the trapezoidal rule (Newmark beta = 1/4, gamma = 1/2, SPEC 3) with consistent mass,
  a_{n+1} = 4/h^2 (u_{n+1} - u_n - h v_n) - a_n, v_{n+1} = 2/h (u_{n+1} - u_n) - v_n; the
  equation of motion rho a.w + alpha rho v.w + (elastic) = f.w holds at every t_{n+1};
  constrained dofs take their prescribed u, v, a exactly (SPEC 3); u = v = 0 at t = 0 on the
  free dofs and a(0) solves the equation of motion at t = 0.
- Solvers: linear law: the step matrix is assembled and factorised once, as L D L^T (it is
  symmetric: the Taylor-Hood constraint row of a step is divided by d div z / d div u =
  1 + 2 beta / h, which leaves its solution as it is; CHOLESKY); each step is one solve for
  the correction of a predictor whose constrained dofs hold g(t_{n+1}).
  neo-Hookean: Newton (PETSc SNES through dolfinx's NonlinearProblem, MUMPS, relative residual
  1e-10) every step, forms and solver built once. The factorised tangent is kept across
  steps (modified Newton: the same solution to 1e-10) and refreshed before a step when the
  last one took more than REFRESH_ITERATIONS iterations; full Newton with a backtracking line
  search from the step's start where that fails. The residual skips DOLFINx's lifting: the
  iterate holds the prescribed values before each solve, so the lifted term is zero.
  Measured on rod-nh-s1, n = 8, 24 steps, one rank: the tangent refreshed every 6th
  iteration took 55 s, kept 19 s (the assembly of a Q2-Q1-Q1 neo-Hookean tangent, 0.76 s,
  and its factorisation, about 1.5 s, were most of a step), the same tip to 12 digits.

The displacement history is returned as arrays of the owned dof values of the Q2 space V
(`TruthRun.u[i]` at t_i = i h), with V itself, so that it can be graded by interpolation;
the rod's tip (0.5, 0.25, 0.125) m is evaluated at every step. For `neo-hookean`, the smallest
J = det F over the quadrature points of the residual is recorded at every step (SPEC 8: a
state with J <= 0 somewhere is an inverted element), with where and when the run's smallest
one is.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any, Callable  # noqa: F401 (Any: in a type comment)

from mpi4py import MPI
from petsc4py import PETSc

import basix.ufl
import dolfinx.fem.petsc
import dolfinx.geometry
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.meshes.tools import Tool
from tissuebench.solvers import contact
from tissuebench.solvers.truth import axisymmetric as axi

# motion(t, x) -> (u, v, a): prescribed displacement (m), velocity (m/s) and acceleration
# (m/s^2) at time t (s) of the nodes at coordinates x (n x 3); each broadcastable to (n, gdim)
Motion = Callable[[float, np.ndarray], tuple]
# body_force(x, t) -> a UFL vector in N/m^3, x the SpatialCoordinate, t a Constant (s)
BodyForce = Callable[[ufl.core.expr.Expr, fem.Constant], ufl.core.expr.Expr]

# the neo-Hookean models' volumetric stress over kappa, U'(J) / kappa (SPEC 8): p = U'(J) at the
# stationary point of the mixed form
VOLUMETRIC = {
    "neo-hookean": lambda J: J - 1,  # U = (kappa/2) (J - 1)^2
    "neo-hookean-barrier": lambda J: (J - 1 / J) / 2,  # U = (kappa/4) (J^2 - 1 - 2 ln J)
}
MIXED_NU = 0.45  # Poisson's ratio from which the linear law is solved in Taylor-Hood form
# a neo-Hookean step's factorised tangent is built again before the next step when a step took
# more than this many Newton iterations (a full-Newton step takes 3-4)
REFRESH_ITERATIONS = 6
KEEP = -2  # PETSc's lag: build the tangent at the first iteration, then never again
LU = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
# SPEC 12: a contact step's Newton; its absolute floor is CONTACT_ATOL x E (N/m per Pa), above
# the round-off at which the residual settles with a stiff penalty (about 1e-12 E measured)
CONTACT_NEWTON = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-10,
    "snes_stol": 0.0,
    "snes_max_it": 50,
}
CONTACT_ATOL = 1e-11
# the symmetric step and static matrices' factorisation (_linear_solver): in 2D on one rank by
# PETSc's own Cholesky (L D L^T) in nested-dissection order, whose solves took 5 ms against
# MUMPS's 14 (L D L^T) and 16 (LU) on block-MP2-w0.2's finest level (58,403 dofs): a truth's
# steps are mostly solves. Its pivots may be tiny but not zero (the Taylor-Hood matrix is
# quasi-definite; MP2's pressure rows are of order 1e-15 N/m^2 where PETSc's default calls
# 1e-12 zero): zeropivot. In 3D (MUMPS's multifrontal factorisation: PETSc's took 19 s against
# 1.3 s on the rod's n = 8) and on several ranks: MUMPS's L D L^T. Every factorisation's first
# solve must leave at most `residual` relative residual.
CHOLESKY = {"zeropivot": 1e-300, "residual": 1e-8}


@dataclass
class Boundary:
    """Every component of the nodes `nodes` (local block indices of V, owned and ghost)
    follows `motion`; with `components`, those components only (0: x, or r on a meridian),
    the others free."""

    nodes: np.ndarray
    motion: Motion
    components: tuple[int, ...] | None = None


@dataclass
class ContactLaw:
    """SPEC 12: the boundary facets `facets` (local indices) in frictionless penalty contact
    with the rigid `tool` (meshes/tools/), penalty k (Pa/m): the traction p n on the tissue,
    p = k <-g_n>, driven toward its limit by k."""

    facets: np.ndarray
    tool: Tool
    k: float

    def centre(self, t: float) -> np.ndarray:
        """The tool's centre c(t) (m) at time t (s)."""
        return self.tool.centre(t)


@dataclass
class Problem:
    """The continuum problem of SPEC 10 on one mesh. mu, lmbda in Pa, rho in kg/m^3, alpha in
    1/s, beta in s; model "linear" or "neo-hookean"; `boundaries(V)` gives the constrained
    nodes of the Q2 space V; `probe` a point (m) whose displacement is recorded."""

    mesh: dolfinx.mesh.Mesh
    mu: float
    lmbda: float
    rho: float
    alpha: float
    beta: float
    model: str
    body_force: BodyForce
    boundaries: Callable[[fem.FunctionSpace], list[Boundary]]
    probe: tuple | None = None
    degree: int = 2
    contact: ContactLaw | None = None
    # SPEC 13: the mesh is a meridian (r, z) of a body of revolution about the z axis (r = 0):
    # the hoop strain u_r / r, every integral weighted by 2 pi r (m), so that the residual is
    # the revolved body's (N) and the contact force its axial force (N)
    axisymmetric: bool = False

    @property
    def form(self) -> str:
        """`displacement`, `mixed` (linear Taylor-Hood) or `mixed-nh` (the neo-Hookean
        models)."""
        if self.model in VOLUMETRIC:
            return "mixed-nh"
        if self.model != "linear":
            raise ValueError(
                f"the truth takes the models linear, {', '.join(VOLUMETRIC)}, not {self.model}"
            )
        nu = self.lmbda / (2 * (self.lmbda + self.mu))
        return "mixed" if nu >= MIXED_NU else "displacement"


@dataclass
class TruthRun:
    """A truth computation: V the Q2 displacement space; u[k] the owned dof values (m) of V
    at times[k] (s); tip[k] the probe's displacement (m); dofs the global number of unknowns;
    wall the wall time (s)."""

    V: fem.FunctionSpace
    times: np.ndarray
    u: np.ndarray | None
    tip: np.ndarray | None
    dofs: int
    wall: float
    min_jacobian: JacobianRecord | None = None
    force: np.ndarray | None = None  # SPEC 12: the needle's force (N/m; x, y) at every step
    # SPEC 13: V is on a meridian (r, z); its force is (0, 0, F_z) in N, F_z the axial force
    axisymmetric: bool = False


@dataclass
class JacobianRecord:
    """The smallest J = det F (dimensionless) over the quadrature points at every step of a
    run (values[k] at times[k] of the run, t = 0 included), and the smallest of all: its time
    `at_time` (s) and its point `at_point` (m, undeformed)."""

    values: np.ndarray
    at_time: float
    at_point: np.ndarray


@dataclass
class _LinearSolver:
    """A residual linear in the unknown (form R), its factorised Jacobian A (KSP), the vectors
    of its residual b and correction dx; `checked`: its first solve's residual was checked."""

    R: Any
    A: PETSc.Mat
    ksp: PETSc.KSP
    b: PETSc.Vec
    dx: PETSc.Vec
    checked: bool = False

    def destroy(self) -> None:
        for obj in (self.A, self.ksp, self.b, self.dx):
            obj.destroy()


def _eps(u):
    return ufl.sym(ufl.grad(u))


def _grad_axi(u, r):
    """The displacement gradient (3 x 3, rows and columns r, theta, z) of the meridian
    displacement u = (u_r, u_z) (m) at radius r (m): grad u in the plane, u_r / r the hoop
    stretch's part."""
    g = ufl.grad(u)
    return ufl.as_tensor([[g[0, 0], 0, g[0, 1]], [0, u[0] / r, 0], [g[1, 0], 0, g[1, 1]]])


class Truth:
    """The discrete truth problem: spaces, forms and solvers of one Problem, built once."""

    def __init__(self, problem: Problem):
        self.problem = pb = problem
        mesh = pb.mesh
        self.comm = mesh.comm
        self.gdim = gdim = mesh.geometry.dim
        self.kind = pb.form
        cell = mesh.basix_cell()
        vector = basix.ufl.element("Lagrange", cell, pb.degree, shape=(gdim,))
        scalar = basix.ufl.element("Lagrange", cell, pb.degree - 1)
        n_pressures = {"displacement": 0, "mixed": 1, "mixed-nh": 2}[self.kind]
        if n_pressures:
            self.W = fem.functionspace(
                mesh, basix.ufl.mixed_element([vector] + [scalar] * n_pressures)
            )
            self.V, dofs = self.W.sub(0).collapse()
            self.to_W = np.asarray(dofs).reshape(-1)  # type: np.ndarray | None
        else:
            self.W = self.V = fem.functionspace(mesh, vector)
            self.to_W = None
        if self.kind != "displacement" and pb.lmbda <= 0:
            raise ValueError("the Taylor-Hood truth needs lambda > 0 Pa")
        V = self.V
        self.bs = gdim
        self.n_owned = V.dofmap.index_map.size_local * gdim

        # constrained nodes: later boundaries win on shared nodes
        self.boundaries = pb.boundaries(V)
        nodes = np.unique(
            np.concatenate([b.nodes for b in self.boundaries] + [np.zeros(0, np.int32)])
        )
        self.cnodes = nodes.astype(np.int32)
        self.cdofs = (gdim * nodes[:, None] + np.arange(gdim)).ravel()
        # some components only (u_r on the axis): the constrained dofs one by one
        self._by_component = any(b.components is not None for b in self.boundaries)
        if self._by_component:
            self.cdofs = np.unique(
                np.concatenate(
                    [
                        (gdim * b.nodes[:, None] + np.asarray(self._components(b))).ravel()
                        for b in self.boundaries
                    ]
                )
            ).astype(np.int64)
        self.xnodes = V.tabulate_dof_coordinates()
        self.g = fem.Function(V)  # prescribed values of the current solve
        zero = fem.Function(V)
        if self.to_W is None and self._by_component:  # V's own dofs, unrolled
            pair = [self.cdofs.astype(np.int32)] * 2
            self.bc = fem.dirichletbc(self.g, pair, V)  # type: ignore[arg-type]  # dolfinx's annotation: a (V's, g's) dof pair
            self.bc0 = fem.dirichletbc(zero, pair, V)  # type: ignore[arg-type]  # as above
        elif self.to_W is None:
            self.bc = fem.dirichletbc(self.g, self.cnodes)
            self.bc0 = fem.dirichletbc(zero, self.cnodes)
        else:
            wdofs = self.to_W[self.cdofs]
            order = np.argsort(wdofs)
            pair = [wdofs[order].astype(np.int32), self.cdofs[order].astype(np.int32)]
            self.bc = fem.dirichletbc(self.g, pair, self.W.sub(0))  # type: ignore[arg-type]  # dolfinx's annotation: the (W's, V's) dof pair of a subspace
            self.bc0 = fem.dirichletbc(zero, pair, self.W.sub(0))  # type: ignore[arg-type]  # dolfinx's annotation: the (W's, V's) dof pair of a subspace

        # state at t_n (V), and the known parts of v_{n+1}, a_{n+1}
        self.un, self.vn, self.an = (fem.Function(V) for _ in range(3))
        self.vpred, self.apred = fem.Function(V), fem.Function(V)
        self.c1 = fem.Constant(mesh, 0.0)  # 2/h, 1/s
        self.c2 = fem.Constant(mesh, 0.0)  # 4/h^2, 1/s^2
        self.t = fem.Constant(mesh, 0.0)  # s
        self.load = fem.Constant(mesh, 1.0)  # load factor (1: the whole load)
        self.U = fem.Function(self.W)
        self.f = pb.body_force(ufl.SpatialCoordinate(mesh), self.t)
        # type comments, not annotations: the truth's cache key hashes the code's syntax tree
        self._step_solver = None  # type: Any  # a _LinearSolver or a NonlinearProblem
        self._full_newton = None  # type: dolfinx.fem.petsc.NonlinearProblem | None  # full Newton, built where the modified one first fails
        self._refresh = False  # build the modified Newton's tangent again before the next step
        self._step_h = None  # type: float | None  # the step of the factorised linear step matrix, s
        self._probe = _Probe(V, pb.probe) if pb.probe is not None else None
        self._jacobian = (
            _Jacobian(self.un, 2 * pb.degree, pb.axisymmetric) if self.kind == "mixed-nh" else None
        )
        # SPEC 12: the needle at the time of the solve, and the contact edge's measure
        self.needle = None  # type: fem.Constant | None
        if pb.contact is not None:
            self.needle = fem.Constant(mesh, np.asarray(pb.contact.centre(0.0), dtype=float))
            self._ds = contact.edge_measure(mesh, pb.contact.facets)
            self._contact_solver = None  # type: Any  # the contact steps' NonlinearProblem
            self._penalty = fem.Constant(mesh, 1.0)  # the penalty's factor: k x this
            c = pb.contact
            if pb.axisymmetric:  # SPEC 13: the axial force (N), over dA = 2 pi r ds
                weight = axi.volume(axi.radius(mesh))
                forces = contact.needle_force(
                    self._split(self.U)[0], self.needle, c.tool, c.k * weight, self._ds
                )
                self._force = [fem.form(forces[1])]
            else:
                self._force = [
                    fem.form(f)
                    for f in contact.needle_force(
                        self._split(self.U)[0], self.needle, c.tool, c.k, self._ds
                    )
                ]

    def _components(self, b: Boundary) -> tuple[int, ...]:
        """The components a boundary constrains."""
        return tuple(range(self.gdim)) if b.components is None else b.components

    # -- forms -----------------------------------------------------------------------------
    def _split(self, U):
        if self.to_W is None:
            return U, ()
        parts = ufl.split(U)
        return parts[0], tuple(parts[1:])

    def _elastic(self, u, v, ps, w, qs, scale=1.0):
        """The elastic and stiffness-damping terms of the residual (N/m^3 times w); the linear
        Taylor-Hood form's constraint row divided by `scale` (the step's d div z / d div u, so
        that its step matrix is symmetric: the same solution)."""
        pb = self.problem
        mu, lmbda, beta = pb.mu, pb.lmbda, pb.beta
        if pb.axisymmetric:
            return self._elastic_axi(u, v, ps, w, qs, scale)
        if self.kind == "displacement":
            z = u + beta * v
            return ufl.inner(
                2 * mu * _eps(z) + lmbda * ufl.div(z) * ufl.Identity(self.gdim), _eps(w)
            )
        if self.kind == "mixed":
            (p,), (q,) = ps, qs
            z = u + beta * v
            return (
                2 * mu * ufl.inner(_eps(z), _eps(w))
                - p * ufl.div(w)
                - q * (ufl.div(z) + p / lmbda) / scale
            )
        (p, pd), (q, qd) = ps, qs
        kappa = lmbda + 2 * mu / 3
        F = ufl.variable(ufl.Identity(self.gdim) + ufl.grad(u))
        J = ufl.det(F)
        I1 = ufl.tr(F.T * F) + (3 - self.gdim)
        P_iso = ufl.diff(mu / 2 * (J ** (-2 / 3) * I1 - 3), F)
        return (
            ufl.inner(P_iso + p * J * ufl.inv(F).T, ufl.grad(w))
            + 2 * mu * beta * ufl.inner(_eps(v), _eps(w))
            + pd * ufl.div(w)
            + q * (VOLUMETRIC[pb.model](J) - p / kappa)
            + qd * (beta * ufl.div(v) - pd / lmbda)
        )

    def _elastic_axi(self, u, v, ps, w, qs, scale):
        """_elastic on a meridian (SPEC 13; per unit volume: the caller weights by 2 pi r):
        the strains with the hoop term u_r / r (axisymmetric.eps_axi, div_axi) and the
        neo-Hookean F with F_thetatheta = 1 + u_r / r (J = det F_2D (1 + u_r / r),
        I1 = tr C_2D + (1 + u_r / r)^2)."""
        pb = self.problem
        mu, lmbda, beta = pb.mu, pb.lmbda, pb.beta
        r = axi.radius(self.problem.mesh)
        if self.kind == "displacement":
            z = u + beta * v
            return ufl.inner(axi.sigma(axi.eps_axi(z, r), mu, lmbda), axi.eps_axi(w, r))
        if self.kind == "mixed":
            (p,), (q,) = ps, qs
            z = u + beta * v
            return (
                2 * mu * ufl.inner(axi.eps_axi(z, r), axi.eps_axi(w, r))
                - p * axi.div_axi(w, r)
                - q * (axi.div_axi(z, r) + p / lmbda) / scale
            )
        (p, pd), (q, qd) = ps, qs
        kappa = lmbda + 2 * mu / 3
        F = ufl.variable(ufl.Identity(3) + _grad_axi(u, r))
        J = ufl.det(F)
        I1 = ufl.tr(F.T * F)
        P_iso = ufl.diff(mu / 2 * (J ** (-2 / 3) * I1 - 3), F)
        return (
            ufl.inner(P_iso + p * J * ufl.inv(F).T, _grad_axi(w, r))
            + 2 * mu * beta * ufl.inner(axi.eps_axi(v, r), axi.eps_axi(w, r))
            + pd * axi.div_axi(w, r)
            + q * (VOLUMETRIC[pb.model](J) - p / kappa)
            + qd * (beta * axi.div_axi(v, r) - pd / lmbda)
        )

    def _residual(self, u, v, a, ps, scale=1.0):
        pb = self.problem
        w, qs = self._split(ufl.TestFunction(self.W))
        inertia = pb.rho * ufl.inner(a + pb.alpha * v, w) if a is not None else 0
        # Gauss with degree + 1 points per direction: exact for the linear forms on affine cells
        dx = ufl.dx(metadata={"quadrature_degree": 2 * pb.degree})
        force = self.load * ufl.inner(self.f, w)
        if pb.axisymmetric:  # SPEC 13: dV = 2 pi r dr dz, dA = 2 pi r ds
            weight = axi.volume(axi.radius(pb.mesh))
            residual = (inertia + self._elastic(u, v, ps, w, qs, scale) - force) * weight * dx
        else:
            residual = (inertia + self._elastic(u, v, ps, w, qs, scale) - force) * dx
        if pb.contact is not None:  # the traction p n of the needle on the tissue (SPEC 12)
            c = pb.contact
            k = c.k * self._penalty
            if pb.axisymmetric:
                k = k * weight
            traction = contact.pressure(u, self.needle, c.tool, k) * c.tool.ufl_outward_normal(
                contact.deformed(u), self.needle
            )
            residual = residual - ufl.inner(traction, w) * self._ds
        return residual

    def step_residual(self) -> ufl.Form:
        """The residual at t_{n+1} with unknown u_{n+1} (trapezoidal rule)."""
        u, ps = self._split(self.U)
        v = self.vpred + self.c1 * u
        a = self.apred + self.c2 * u
        return self._residual(u, v, a, ps, 1 + self.problem.beta * self.c1)

    # -- solves ----------------------------------------------------------------------------
    def _prescribe(self, t: float) -> np.ndarray:
        """(u, v, a) at t (s) on the constrained nodes, as (nodes, gdim) arrays in V's order."""
        n, gdim = len(self.xnodes), self.gdim
        values = np.zeros((3, n, gdim))
        for b in self.boundaries:
            for k, val in enumerate(b.motion(t, self.xnodes[b.nodes])):
                full = np.broadcast_to(np.asarray(val, dtype=float), (len(b.nodes), gdim))
                if b.components is None:
                    values[k, b.nodes] = full
                else:
                    comps = list(b.components)
                    values[k, b.nodes[:, None], comps] = full[:, comps]
        if self._by_component:
            return values.reshape(3, -1)[:, self.cdofs]
        return values[:, self.cnodes].reshape(3, -1)

    def _linear_solver(self, residual, U, symmetric=False):
        """The solver of a residual linear in U, with homogeneous constraints on the
        correction: its Jacobian assembled and factorised once (_LinearSolver). `symmetric`:
        the Jacobian is symmetric (the step and static matrices: SPD, or quasi-definite in
        Taylor-Hood form), factorised as L D L^T (CHOLESKY)."""
        R = fem.form(residual)
        A = dolfinx.fem.petsc.assemble_matrix(fem.form(ufl.derivative(residual, U)), bcs=[self.bc0])
        A.assemble()
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOperators(A)
        ksp.setType("preonly")
        pc = ksp.getPC()
        if not symmetric:
            pc.setType("lu")
            pc.setFactorSolverType("mumps")
        elif self.comm.size == 1 and self.gdim == 2:
            pc.setType("cholesky")
            pc.setFactorSolverType("petsc")
            pc.setFactorOrdering("nd")
            pc.setFactorPivot(zeropivot=CHOLESKY["zeropivot"])
        else:
            A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
            pc.setType("cholesky")
            pc.setFactorSolverType("mumps")
        b = dolfinx.fem.petsc.create_vector(self.W)
        return _LinearSolver(R, A, ksp, b, b.duplicate())

    def _linear_solve(self, solver, U) -> None:
        """One Newton step on a residual linear in U: U -= J^-1 R(U) by `solver`
        (_linear_solver); U's constrained dofs must hold their values. The first solve of a
        factorisation checks it: its relative residual at most CHOLESKY["residual"]."""
        b, dx = solver.b, solver.dx
        with b.localForm() as loc:
            loc.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, solver.R)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        dolfinx.fem.petsc.set_bc(b, [self.bc0])
        solver.ksp.solve(b, dx)
        if solver.ksp.getConvergedReason() <= 0:
            raise RuntimeError(
                f"truth: the linear solve failed ({solver.ksp.getConvergedReason()})"
            )
        if not solver.checked:
            r = b.duplicate()
            solver.A.mult(dx, r)
            r.axpy(-1.0, b)
            error = r.norm() / max(b.norm(), np.finfo(float).tiny)
            r.destroy()
            if not error <= CHOLESKY["residual"]:
                raise RuntimeError(
                    f"truth: a factorised matrix solves with relative residual "
                    f"{error:.1e} (> {CHOLESKY['residual']:.0e})"
                )
            solver.checked = True
        U.x.petsc_vec.axpy(-1.0, dx)
        U.x.scatter_forward()

    def _set_u(self, U, values_V):
        """Write V's values into U's displacement part (owned and ghost)."""
        if self.to_W is None:
            U.x.array[:] = values_V
        else:
            U.x.array[self.to_W] = values_V

    def _get_u(self, U) -> np.ndarray:
        return U.x.array.copy() if self.to_W is None else U.x.array[self.to_W]

    def initial_state(self) -> None:
        """u, v at t = 0 (zero on the free dofs, prescribed on the constrained) and a(0) from
        the equation of motion at t = 0."""
        ug, vg, ag = self._prescribe(0.0)
        for fn, val in ((self.un, ug), (self.vn, vg)):
            fn.x.array[:] = 0.0
            fn.x.array[self.cdofs] = val
        self.t.value = 0.0  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        if self.needle is not None:  # SPEC 12: the needle at rest, touching the edge
            self.needle.value[:] = self.problem.contact.centre(0.0)  # type: ignore[union-attr]  # a Problem with contact: no assert here, the truth's cache key hashes this code
        A = fem.Function(self.W)  # unknown: the acceleration and the pressures at t = 0
        a, ps = self._split(A)
        residual = self._residual(self.un, self.vn, a, ps)
        self.g.x.array[self.cdofs] = ag
        self.bc.set(A.x.array)
        solver = self._linear_solver(residual, A)
        self._linear_solve(solver, A)
        solver.destroy()
        self.an.x.array[:] = self._get_u(A)
        self.an.x.array[self.cdofs] = ag
        self.U.x.array[:] = A.x.array  # the pressures at t = 0: the first Newton guess
        self._set_u(self.U, self.un.x.array)

    def step(self, t_next: float, h: float) -> None:
        """Advance (u, v, a) from t_n to t_next = t_n + h (s)."""
        ug, vg, ag = self._prescribe(t_next)
        self.c1.value, self.c2.value = 2 / h, 4 / h**2  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        self.t.value = t_next  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        un, vn, an = self.un.x.array, self.vn.x.array, self.an.x.array
        self.vpred.x.array[:] = -2 / h * un - vn
        self.apred.x.array[:] = -4 / h**2 * (un + h * vn) - an
        # constrained dofs: v, a exactly prescribed given u = g
        self.vpred.x.array[self.cdofs] = vg - 2 / h * ug
        self.apred.x.array[self.cdofs] = ag - 4 / h**2 * ug
        self.g.x.array[self.cdofs] = ug
        if self._step_solver is not None and self._step_h != h:  # its tangent holds h
            if self.kind != "mixed-nh":
                self._step_solver.destroy()
            self._step_solver = self._full_newton = None
        self._step_h = h
        if self.needle is not None:
            self.needle.value[:] = self.problem.contact.centre(t_next)  # type: ignore[union-attr]  # a Problem with contact: no assert here, the truth's cache key hashes this code
            self._contact_step(h)
        elif self.kind == "mixed-nh":
            self._newton()
        else:
            self.bc.set(self.U.x.array)
            if self._step_solver is None:  # the step's form built with its solver, once per h
                self._step_solver = self._linear_solver(self.step_residual(), self.U, True)
            self._linear_solve(self._step_solver, self.U)
        u = self._get_u(self.U)
        self.vn.x.array[:] = self.vpred.x.array + 2 / h * u
        self.an.x.array[:] = self.apred.x.array + 4 / h**2 * u
        self.un.x.array[:] = u

    def _newton_solver(self, full: bool):
        """A step's Newton solver (dolfinx's NonlinearProblem, MUMPS). Modified Newton: the
        factorised tangent is kept across steps, rebuilt on request (_newton). Full Newton, the
        fallback: with a backtracking line search, which shortens a step that would invert a
        cell (the residual NaN: on the block at N = 80, as the needle stops at t = 2 s)."""
        lag = 1 if full else KEEP
        options = {
            "snes_type": "newtonls",
            "snes_linesearch_type": "bt" if full else "basic",
            "snes_rtol": 1e-10,
            "snes_atol": 1e-13,
            "snes_stol": 0.0,
            "snes_max_it": 30,
            "snes_lag_jacobian": lag,
            "snes_lag_jacobian_persists": True,
            "snes_lag_preconditioner": lag,
            "snes_lag_preconditioner_persists": True,
            **LU,
        }
        problem = dolfinx.fem.petsc.NonlinearProblem(
            self.step_residual(),
            self.U,
            bcs=[self.bc],
            petsc_options=options,
            petsc_options_prefix=f"truth_{id(self)}_{'full' if full else 'modified'}_",
        )
        residual = fem.form(self.step_residual())
        bcs = [self.bc]

        def assemble(_snes, x, b):
            """The residual at x with the prescribed rows x - g: DOLFINx's assemble_residual
            without its lifting, zero here since x holds g on the prescribed dofs."""
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            dolfinx.fem.petsc.assign(x, self.U)
            with b.localForm() as local:
                local.set(0.0)
            dolfinx.fem.petsc.assemble_vector(b, residual)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            dolfinx.fem.petsc.set_bc(b, bcs, x0=x, alpha=-1.0)
            b.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

        problem.solver.setFunction(assemble, problem.b)
        return problem

    def _newton(self) -> None:
        # modified Newton (the tangent changes little in a step), built again (a new tangent)
        # before the step after one that took many iterations; where it fails, full Newton
        # from the step's start (petsc4py sets no lag once a SNES is built: new solvers)
        self.bc.set(self.U.x.array)  # the prescribed values, so that lifting is not needed
        if self._step_solver is None or self._refresh:
            self._step_solver = self._newton_solver(full=False)
            self._refresh = False
        start = self.U.x.array.copy()
        solver = self._step_solver
        solver.solve()
        snes = solver.solver
        failed = snes.getConvergedReason() <= 0
        self._refresh = failed or snes.getIterationNumber() > REFRESH_ITERATIONS
        if failed:
            self.U.x.array[:] = start
            if self._full_newton is None:
                self._full_newton = self._newton_solver(full=True)
            solver = self._full_newton
            solver.solve()
        reason = solver.solver.getConvergedReason()
        if reason <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int
            raise RuntimeError(f"truth: Newton did not converge at t = {self.t.value} s ({reason})")

    def _contact_step(self, h: float) -> None:
        """A step with contact: full Newton (basic line search: the backtracking one stalls as
        the active set changes) from u_n + h v_n, the tissue carried along at its velocity;
        where it fails, from the same guess through the penalty k 1e-3, 1e-2 and 1e-1 times as
        stiff first (each solve's active set close to the next one's)."""
        if self._contact_solver is None:
            mu, lmbda = self.problem.mu, self.problem.lmbda
            E = mu * (3 * lmbda + 2 * mu) / (lmbda + mu)
            self._contact_solver = dolfinx.fem.petsc.NonlinearProblem(
                self.step_residual(),
                self.U,
                bcs=[self.bc],
                petsc_options={**CONTACT_NEWTON, "snes_atol": CONTACT_ATOL * E, **LU},
                petsc_options_prefix=f"truth_contact_{id(self)}_",
            )
        self._set_u(self.U, self.un.x.array + h * self.vn.x.array)
        self.bc.set(self.U.x.array)
        guess = self.U.x.array.copy()
        for scales in ((1.0,), (1e-3, 1e-2, 1e-1, 1.0)):
            self.U.x.array[:] = guess
            for scale in scales:
                self._penalty.value = scale  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
                self._contact_solver.solve()
                if self._contact_solver.solver.getConvergedReason() <= 0:
                    break
            self._penalty.value = 1.0  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
            if self._contact_solver.solver.getConvergedReason() > 0 and scale == 1.0:
                return
        raise RuntimeError(
            f"truth: Newton with contact did not converge at t = {float(self.t.value):.4g} s"
        )

    def static(self, t: float) -> np.ndarray:
        """The static solution at t (s) (no inertia, no damping): owned dof values of V (m).
        neo-Hookean: Newton on the whole load (prescribed motion and body force) from rest;
        where that fails, from the state at hand (after a damped run, its last: near rest).
        RuntimeError when both fail (sub-steps of the load did not help where these failed:
        rod-nh-s3 at n = 8, up to 64 of them)."""
        ug, _, _ = self._prescribe(t)
        self.t.value = t  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        U = fem.Function(self.W)
        u, ps = self._split(U)
        rest = fem.Constant(self.problem.mesh, np.zeros(self.gdim))  # v = 0
        residual = self._residual(u, rest, None, ps)
        if self.kind != "mixed-nh":
            self.g.x.array[self.cdofs] = ug
            self.bc.set(U.x.array)
            solver = self._linear_solver(residual, U, symmetric=True)
            self._linear_solve(solver, U)
            solver.destroy()
            return self._get_u(U)[: self.n_owned]
        problem = dolfinx.fem.petsc.NonlinearProblem(
            residual,
            U,
            bcs=[self.bc],
            petsc_options={"snes_rtol": 1e-10, "snes_atol": 1e-13, "snes_stol": 0.0, **LU},
            petsc_options_prefix=f"truth_static_{id(self)}_",
        )
        U.x.array[:] = 0.0  # from rest
        self.g.x.array[self.cdofs] = ug
        problem.solve()
        if problem.solver.getConvergedReason() <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int; from the state at hand
            U.x.array[:] = self.U.x.array
            problem.solve()
        if problem.solver.getConvergedReason() <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int
            raise RuntimeError(
                "truth: the static Newton solve failed from rest and from the state at hand"
            )
        return self._get_u(U)[: self.n_owned]

    def tip(self, values: np.ndarray) -> np.ndarray:
        """The probe's displacement (m) for owned dof values of V. Collective."""
        return self._probe(values)  # type: ignore[misc]  # tip() needs a probe; no assert here: the truth's cache key hashes this code

    def num_dofs(self) -> int:
        im = self.W.dofmap.index_map
        return im.size_global * self.W.dofmap.index_map_bs

    def run(
        self, h: float, steps: int, keep: int = 1, on_step: Callable[[int], None] | None = None
    ) -> TruthRun:
        """Integrate `steps` steps of size h (s) from t = 0; keep every `keep`-th step's
        displacement (0: none) and the probe at every step; on_step(i) after step i."""
        start = time.perf_counter()
        self.initial_state()
        history, tips, times, jacobians, forces = [], [], [], [], []

        def record(i):
            values = self.un.x.array[: self.n_owned]
            if keep and i % keep == 0:
                history.append(values.copy())
                times.append(i * h)
                if self._jacobian is not None:
                    jacobians.append(self._jacobian())
            if self._probe is not None:
                tips.append(self.tip(values))
            if self.needle is not None:  # the force of U, which holds u at this step
                values = [self.comm.allreduce(fem.assemble_scalar(f)) for f in self._force]
                if self.problem.axisymmetric:  # (0, 0, F_z): the revolved body's force, N
                    values = [0.0, 0.0, values[0]]
                forces.append(values)

        record(0)
        for i in range(steps):
            self.step((i + 1) * h, h)
            record(i + 1)
            if on_step is not None:
                on_step(i + 1)
        times = np.array(times) if keep else np.arange(steps + 1) * h
        record_j = None
        if jacobians:
            k = int(np.argmin([j for j, _ in jacobians]))
            record_j = JacobianRecord(
                np.array([j for j, _ in jacobians]), float(times[k]), jacobians[k][1]
            )
        return TruthRun(
            V=self.V,
            times=times,
            u=np.array(history) if keep else None,
            tip=np.array(tips) if tips else None,
            dofs=self.num_dofs(),
            wall=time.perf_counter() - start,
            min_jacobian=record_j,
            force=np.array(forces) if forces else None,
            axisymmetric=self.problem.axisymmetric,
        )


class _Probe:
    """Evaluate a V function at one point; the colliding cell is located once. Collective."""

    def __init__(self, V: fem.FunctionSpace, point: tuple):
        mesh = V.mesh
        self.fn = fem.Function(V)
        self.point = np.zeros((1, 3))
        self.point[0, : len(point)] = point
        tree = dolfinx.geometry.bb_tree(mesh, mesh.topology.dim)
        candidates = dolfinx.geometry.compute_collisions_points(tree, self.point)
        cells = dolfinx.geometry.compute_colliding_cells(mesh, candidates, self.point).links(0)
        owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.cells = cells[cells < owned][:1]
        comm = mesh.comm
        self.owner = comm.allreduce(comm.rank if len(self.cells) else comm.size, op=MPI.MIN)
        if self.owner == comm.size:
            raise ValueError(f"point {point} is outside the mesh")

    def __call__(self, values: np.ndarray) -> np.ndarray:
        self.fn.x.array[: len(values)] = values
        self.fn.x.scatter_forward()
        comm = self.fn.function_space.mesh.comm
        value = None
        if comm.rank == self.owner:
            value = np.asarray(self.fn.eval(self.point, self.cells)).reshape(-1)
        return comm.bcast(value, root=self.owner)


class _Jacobian:
    """The smallest J = det(I + grad u) over the quadrature points (Gauss, exact to `degree`)
    of the owned cells of every rank, and the undeformed point (m) where it is; on a meridian
    (`axisymmetric`), J = det(I + grad u) (1 + u_r / r). Collective."""

    def __init__(self, u: fem.Function, degree: int, axisymmetric: bool = False):
        mesh = u.function_space.mesh
        gdim = mesh.geometry.dim
        points, _ = basix.make_quadrature(mesh.basix_cell(), degree)
        self.mesh = mesh
        owned = mesh.topology.index_map(mesh.topology.dim).size_local
        self.cells = np.arange(owned, dtype=np.int32)
        J = ufl.det(ufl.Identity(gdim) + ufl.grad(u))
        if axisymmetric:
            J = J * (1 + u[0] / axi.radius(mesh))
        self.J = fem.Expression(J, points)  # type: ignore[arg-type]  # basix annotates its arrays as ArrayLike
        x = fem.Expression(ufl.SpatialCoordinate(mesh), points)  # type: ignore[arg-type]  # basix annotates its arrays as ArrayLike
        self.x = x.eval(mesh, self.cells).reshape(-1, gdim)

    def __call__(self) -> tuple[float, np.ndarray]:
        values = self.J.eval(self.mesh, self.cells).reshape(-1)
        k = int(np.argmin(values)) if len(values) else -1
        mine = (float(values[k]), tuple(self.x[k])) if k >= 0 else (np.inf, ())
        smallest, where = self.mesh.comm.allreduce(mine, op=MPI.MIN)
        return smallest, np.asarray(where, dtype=float)
