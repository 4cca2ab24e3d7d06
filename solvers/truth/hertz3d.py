"""The Hertz check of SPEC 13: the rigid capsule pushed statically into the top face's centre of
the linear MP1 cylinder, solved on the meridian (solvers/truth/axisymmetric.py), its force and
contact radius against Hertz's sphere on a half-space and Sneddon's exact rigid sphere.

The cylinder r <= R_B = 0.5 m, 0 <= z <= H = 1 m (fixed bottom, free side, the top free but for
contact) is pushed by the capsule of radius R = 0.1 m (meshes/tools/capsule.py, posed on the
meridian as its half-stadium along +z) moved a depth d (m) into it: c = (0, H + R - d).
Discretisation as the truth's (SPEC 10 and 13): Taylor-Hood Q2-Q1 for nu >= 0.45 (Q2 below),
on the meridian grid graded toward (0, H); contact by the penalty driven to its limit, the
energy (k/2) int <-g_n>^2 2 pi r ds over the top face, k = kappa E / h_near (Pa/m), solved
with kappa and 10 kappa, the depth applied in load steps, Newton (PETSc SNES, line search,
MUMPS) with the penalty's tangent.

Measured from the solution: P (N), the force on the capsule along z, P = -int p n_z 2 pi r ds
(n the capsule's outward normal, p = k <-g_n> Pa); p0 (Pa), the largest pressure over the Q2
nodes of the top face; a (m), the contact radius from the pressure's second moment,
a^2 = (5/2) int r^2 t_z dA / int t_z dA, dA = 2 pi r ds, r the point's distance from the axis in
the reference configuration and t_z = -p n_z the traction along z (int t_z dA = P), as the
laws' linear theory has them; the interpenetration (m), the largest -g_n at the top face's Q2
nodes. The contact is posed at the deformed point X + u, and the capsule's tilted normal pushes
the top face outward (u_r / r = +1.7 % at the centre, +0.4 % at 0.9 a): `a_deformed` is the
second moment over the deformed point's rho with p itself, the measure used before, 1.0 %
larger on SPEC 13's body (0.022308 against 0.022088 m at n = 64: 0.8 % from rho, 0.2 % from
p against t_z), which lowers 3 P / (2 pi a^2) by 2.0 %.
Measured while writing this (n = 64, body 8 times SPEC 13's): with the contact posed at (r,
H + u_z) instead, as the linear theory poses it, this a is 0.02 % from Sneddon's second moment,
the centre traction 0.04 % from Sneddon's p0, and P 0.08 % below Sneddon's; posed at X + u,
P is 0.28 % below, a 0.32 % below and the centre pressure 2.0 % above Sneddon's. The largest
nodal pressure is the centre's traction -sigma_zz, sampled: at n = 64 the penalty's nodal
values alternate by 0.5 % between the Q2 corner and midside nodes (the axis node 0.6 % below
the largest), and the largest is 0.06 % above -sigma_zz on the axis (37.293 against 37.273 Pa);
at n = 128, 0.001 %.

The laws (E* = E / (1 - nu^2)): Hertz, P = (4/3) E* R^(1/2) d^(3/2), a = (3 P R / (4 E*))^(1/3),
p0 = 3 P / (2 pi a^2); Sneddon's rigid sphere, d = (a/2) ln((R + a)/(R - a)),
P = (E*/2)((a^2 + R^2) ln((R + a)/(R - a)) - 2 a R).

`push_3d` poses the same push on a 3D mesh of the cylinder (P2 or P2-P1 tetrahedra, the
capsule's own 3D signed distance), which SPEC 13 asks the meridian's truth to be shown equal to.
Measured while writing this (MP1, static 5 mm, k = 5e6 Pa/m in both, a quarter cylinder graded
to h = 16, 8, 4 mm at the contact): P = 0.038498, 0.037699, 0.037660 N in 3D against 0.037642
(n = 32) and 0.037646 N (n = 64) on the meridian. With SPEC 13's body the finite cylinder
lowers P by 0.85 % from the half-space's (n = 64: P on bodies 1, 2, 4 and 8 times SPEC 13's is
-1.02, -0.61, -0.40 and -0.28 % from Sneddon's, -0.17 % extrapolated in 1 / s), a and p0 by
0.29 % each (workflows/contact/hertz3d.py judges the laws on the half-space's values).
"""

from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI

import basix.ufl
import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.core.errors import UserError
from tissuebench.meshes.tools import Capsule, Tool
from tissuebench.solvers.truth import axisymmetric as axi

RADIUS = 0.1  # m, the capsule's radius R (SPEC 13)
DEPTH = 0.005  # m, SPEC 13's small push
KAPPA = 1e3  # the penalty's kappa (k = kappa E / h_near); the check also solves with 10 kappa
LOAD_STEPS = 4  # the depth in this many equal steps, with the soft penalty
SOFT = 1.0  # the soft penalty's kappa of the load steps, then stiffened tenfold at a time
MIXED_FROM = 0.45  # Taylor-Hood Q2-Q1 for nu >= this (SPEC 10), Q2 below
LU = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}


def capsule(radius: float = RADIUS, height: float = axi.H) -> Capsule:
    """SPEC 13's capsule of radius `radius` (m) at rest, touching the top face's centre (0, 0,
    height), not moving by itself: the static push sets its centre."""
    return Capsule(
        radius=radius,
        c0=(0.0, 0.0, height + radius),
        motion=lambda t: (np.zeros(3), np.zeros(3)),
    )


# -- the laws ------------------------------------------------------------------------------------
def effective_modulus(E: float, nu: float) -> float:
    """E* = E / (1 - nu^2) (Pa) of a rigid indenter on the elastic half-space."""
    return E / (1 - nu * nu)


def hertz_force(E: float, nu: float, depth: float, radius: float = RADIUS) -> float:
    """Hertz: the force (N) of a rigid sphere of radius `radius` (m) pushed `depth` (m) into
    the half-space, P = (4/3) E* R^(1/2) d^(3/2)."""
    return 4 / 3 * effective_modulus(E, nu) * np.sqrt(radius) * depth**1.5


def hertz_radius(P: float, E: float, nu: float, radius: float = RADIUS) -> float:
    """Hertz: the contact radius (m) under the force P (N), a = (3 P R / (4 E*))^(1/3)."""
    return float((3 * P * radius / (4 * effective_modulus(E, nu))) ** (1 / 3))


def hertz_pressure(P: float, a: float) -> float:
    """Hertz: the largest pressure (Pa) of the force P (N) on the contact radius a (m),
    p0 = 3 P / (2 pi a^2)."""
    return 3 * P / (2 * np.pi * a * a)


def sneddon(E: float, nu: float, depth: float, radius: float = RADIUS) -> tuple[float, float]:
    """Sneddon's exact rigid sphere of radius R (m) pushed `depth` (m) into the half-space:
    (a in m, P in N), a from d = (a/2) ln((R + a)/(R - a)) (by bisection on 0 < a < R; d grows
    with a), P = (E*/2)((a^2 + R^2) ln((R + a)/(R - a)) - 2 a R)."""
    R = radius

    def d(a: float) -> float:
        return a / 2 * np.log((R + a) / (R - a))

    if not 0 < depth < d(R * (1 - 1e-12)):
        raise UserError(f"Sneddon's sphere needs 0 < depth < its largest, got {depth}")
    lo, hi = 0.0, R
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if d(mid) < depth else (lo, mid)
        if hi - lo <= 1e-15 * R:
            break
    a = (lo + hi) / 2
    log = np.log((R + a) / (R - a))
    return float(a), float(effective_modulus(E, nu) / 2 * ((a * a + R * R) * log - 2 * a * R))


def sneddon_pressure(
    rho: np.ndarray, E: float, nu: float, depth: float, radius: float = RADIUS
) -> np.ndarray:
    """Sneddon's contact pressure (Pa) of the rigid sphere at the radii rho (m, 0 at and beyond
    a): p(rho) = -(E*/pi) int_rho^a F'(t) / (t^2 - rho^2)^(1/2) dt, with the surface's Abel
    function F(t) = d - (t/2) ln((R + t)/(R - t)) (F(a) = 0 makes the edge smooth); the
    integral by Gauss-Legendre in s = (t^2 - rho^2)^(1/2), where it is smooth."""
    a, _ = sneddon(E, nu, depth, radius)
    R = radius
    rho = np.atleast_1d(np.asarray(rho, dtype=float))
    x, w = np.polynomial.legendre.leggauss(64)
    p = np.zeros(len(rho))
    for i, r in enumerate(rho):
        if r >= a:
            continue
        S = np.sqrt(a * a - r * r)
        s = (x + 1) / 2 * S
        t = np.sqrt(r * r + s * s)
        # F'(t) / t, finite at t = 0
        dF_t = -np.log((R + t) / (R - t)) / (2 * np.maximum(t, 1e-300)) - R / (R * R - t * t)
        dF_t = np.where(t > 0, dF_t, -2 / R)
        p[i] = -effective_modulus(E, nu) / np.pi * np.sum(w * S / 2 * dF_t)
    return p


def sneddon_second_moment(E: float, nu: float, depth: float, radius: float = RADIUS) -> float:
    """The contact radius (m) that the pressure's second moment gives for Sneddon's pressure,
    ((5/2) int rho^2 p dA / int p dA)^(1/2), dA = 2 pi rho d rho (by Gauss-Legendre in rho =
    a sin theta, smooth at the edge); Hertz's elliptical pressure would give a itself."""
    a, _ = sneddon(E, nu, depth, radius)
    x, w = np.polynomial.legendre.leggauss(64)
    theta = (x + 1) / 2 * (np.pi / 2)
    rho = a * np.sin(theta)
    weight = w * np.pi / 4 * a * np.cos(theta) * 2 * np.pi * rho
    p = sneddon_pressure(rho, E, nu, depth, radius)
    return float(np.sqrt(2.5 * np.sum(weight * rho * rho * p) / np.sum(weight * p)))


# -- the push ------------------------------------------------------------------------------------
@dataclass
class Push:
    """One static push: depth (m), n (cells a direction of the meridian), h_near (m, the cell
    size at the contact), h_edge (m, the radial cell size at r = a), kappa, k (Pa/m), dofs, the
    measures P (N), p0 (Pa), a (m; a_deformed, the deformed point's second moment), the
    interpenetration (m), and the pressure profile: rho (m, the reference r) and p (Pa) at the
    top face's Q2 nodes with p > 0, sorted by rho; the Newton
    iterations of all the solves up to this penalty, and the wall time (s) from the start of
    the push (the mesh included) to this penalty's solution."""

    depth: float
    n: int
    h_near: float
    h_edge: float
    kappa: float
    k: float
    dofs: int
    P: float
    p0: float
    a: float
    a_deformed: float
    interpenetration: float
    rho: np.ndarray
    p: np.ndarray
    newton: int
    seconds: float


def push(
    E: float,
    nu: float,
    n: int,
    depth: float = DEPTH,
    kappas: tuple[float, ...] = (KAPPA, 10 * KAPPA),
    radius: float = RADIUS,
    body: tuple[float, float] = (axi.R_B, axi.H),
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[Push]:
    """Push the capsule of radius `radius` (m) `depth` (m) into the cylinder of Young's modulus
    E (Pa) and Poisson ratio nu, on the n x n graded meridian of the body (radius, height) in m
    (SPEC 13's by default); one Push per penalty kappa (ascending), each from the last's
    solution. Collective."""
    if not (E > 0 and -1 < nu < 0.5 and 0 < depth < radius):
        raise UserError(
            f"a Hertz push needs E > 0, -1 < nu < 0.5, 0 < depth < R, got {E}, {nu}, {depth}"
        )
    start = MPI.Wtime()
    height = body[1]
    meridian = axi.meridian_mesh(n, radius_b=body[0], height=height, comm=comm)
    mesh = meridian.mesh
    mu, lmbda = axi.lame(E, nu)
    mixed = nu >= MIXED_FROM
    W = axi.space(mesh, mixed)
    U = fem.Function(W)
    if mixed:
        u, p = ufl.split(U)
        w, q = ufl.TestFunctions(W)
        elastic = axi.mixed_form(u, p, w, q, mu, lmbda)
    else:
        u, w = U, ufl.TestFunction(W)
        elastic = axi.displacement_form(u, w, mu, lmbda)
    x = ufl.SpatialCoordinate(mesh) + u  # the deformed point (r, z)
    ds = ufl.Measure("ds", mesh, subdomain_data=meridian.edges, metadata={"quadrature_degree": 8})
    setup = comm.allreduce(MPI.Wtime() - start, op=MPI.MAX)
    pushes = _drive(
        Setting(
            E=E,
            depth=depth,
            radius=radius,
            height=height,
            h_near=meridian.h_near,
            U=U,
            mixed=mixed,
            elastic=elastic,
            bcs=axi.boundary_conditions(W, meridian, mixed),
            tool=capsule(radius, height).meridian(),
            x=x,
            rho=axi.radius(mesh),
            weight=axi.volume(axi.radius(mesh)),  # dA = 2 pi r ds
            ds=ds(axi.TAGS["top"]),
            top=meridian.edges.find(axi.TAGS["top"]),
            share=1.0,
        ),
        kappas,
        comm,
    )
    h_edge = edge_size(meridian, sneddon(E, nu, depth, radius)[0])
    for one in pushes:
        one.n, one.h_edge = n, h_edge
        one.seconds += setup
    return pushes


@dataclass
class Setting:
    """What the penalty push needs of a discretisation: the Young's modulus E (Pa), the depth,
    the capsule's radius and the top face's height (m), the penalty's cell size h_near (m); the
    unknown U (the displacement, or the displacement and pressure when `mixed`), the elastic
    residual and its Dirichlet conditions; the tool (the capsule, or its meridian), the
    deformed point x, the reference point's distance rho (m) from the axis, the weight of the
    top face's area
    element (2 pi r on the meridian, 1 in 3D), the measure ds and the local facets of the top
    face; `share` the part of the revolved body the mesh is (1, or 1/4 of a quarter)."""

    E: float
    depth: float
    radius: float
    height: float
    h_near: float
    U: fem.Function
    mixed: bool
    elastic: ufl.Form
    bcs: list
    tool: Tool
    x: ufl.core.expr.Expr
    rho: ufl.core.expr.Expr
    weight: ufl.core.expr.Expr | float
    ds: ufl.Measure
    top: np.ndarray
    share: float


def _drive(setting: Setting, kappas: tuple[float, ...], comm: MPI.Comm) -> list[Push]:
    """The push of a Setting: the depth in load steps with the soft penalty, then the penalty
    stiffened tenfold at a time to each kappa (ascending); one Push each (n and h_edge 0, for
    the caller). Collective."""
    start = MPI.Wtime()
    s = setting
    U = s.U
    W = U.function_space
    mesh = W.mesh
    gdim = mesh.geometry.dim
    axis = gdim - 1  # z
    V, to_W = W.sub(0).collapse() if s.mixed else (W, np.arange(len(U.x.array)))
    c = fem.Constant(mesh, np.array([0.0] * axis + [s.height + s.radius]))
    k = fem.Constant(mesh, 0.0)
    g = s.tool.ufl_signed_distance(s.x, c)
    inside = ufl.conditional(ufl.lt(g, 0), -g, 0.0)  # <-g_n>, m
    pressure = k * inside
    energy = 0.5 * k * inside**2 * s.weight * s.ds
    residual = s.elastic + ufl.derivative(energy, U, ufl.TestFunction(W))
    problem = dolfinx.fem.petsc.NonlinearProblem(
        residual,
        U,
        bcs=s.bcs,
        petsc_options={
            "snes_type": "newtonls",
            "snes_linesearch_type": "basic",
            "snes_rtol": 1e-10,
            # the residual (N) settles at round-off: stop at 1e-9 of the load's scale E d R
            "snes_atol": 1e-9 * s.E * s.depth * s.radius,
            "snes_stol": 0.0,
            "snes_max_it": 50,
            **LU,
        },
        petsc_options_prefix=f"hertz{gdim}d_",
    )
    top_dofs = fem.locate_dofs_topological(V, gdim - 1, s.top)
    owned = top_dofs < V.dofmap.index_map.size_local
    X_top = V.tabulate_dof_coordinates()[top_dofs, :gdim]
    n_c = s.tool.ufl_outward_normal(s.x, c)
    traction = -pressure * n_c[axis]  # t_z (Pa), its integral P
    force = fem.form(traction * s.weight * s.ds)
    rho_deformed = ufl.sqrt(sum(s.x[i] ** 2 for i in range(axis)))
    moments = [
        fem.form(traction * s.weight * s.ds),
        fem.form(s.rho * s.rho * traction * s.weight * s.ds),
        fem.form(pressure * s.weight * s.ds),
        fem.form(rho_deformed**2 * pressure * s.weight * s.ds),
    ]
    size = W.dofmap.index_map.size_global * W.dofmap.index_map_bs
    newton = 0

    def total(form: fem.Form) -> float:
        return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    def solve(what: str) -> None:
        nonlocal newton
        problem.solve()
        reason = problem.solver.getConvergedReason()
        newton += problem.solver.getIterationNumber()
        if reason <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int
            raise RuntimeError(f"Hertz 3D push: Newton failed at {what} (SNES reason {reason})")

    k.value = SOFT * s.E / s.h_near  # type: ignore[assignment]  # a Constant's value takes a float
    for i in range(1, LOAD_STEPS + 1):
        c.value[axis] = s.height + s.radius - s.depth * i / LOAD_STEPS
        solve(f"depth {s.depth * i / LOAD_STEPS:g} m, kappa {SOFT:g}")
    results = []
    kappa = SOFT
    for target in sorted(kappas):
        while kappa < target:
            kappa = min(10 * kappa, target)
            k.value = kappa * s.E / s.h_near  # type: ignore[assignment]  # as above
            solve(f"depth {s.depth:g} m, kappa {kappa:g}")
        values = U.x.array[to_W].reshape(-1, gdim)[top_dofs]
        x_top = X_top + values
        gap = s.tool.signed_distance(x_top, c.value)
        rho = np.hypot(*X_top[:, :axis].T) if axis == 2 else X_top[:, 0]
        mine = np.column_stack([rho, k.value * np.maximum(-gap, 0)])[owned]
        gathered = np.concatenate(comm.allgather(mine))
        gathered = gathered[np.argsort(gathered[:, 0], kind="stable")]
        contacting = gathered[gathered[:, 1] > 0]
        m0, m2, m0_deformed, m2_deformed = (total(f) for f in moments)
        results.append(
            Push(
                depth=s.depth,
                n=0,
                h_near=s.h_near,
                h_edge=0.0,
                kappa=kappa,
                k=float(k.value),
                dofs=size,
                P=total(force) / s.share,
                p0=float(gathered[:, 1].max()),
                a=float(np.sqrt(2.5 * m2 / m0)),
                a_deformed=float(np.sqrt(2.5 * m2_deformed / m0_deformed)),
                interpenetration=float(gathered[:, 1].max() / k.value),
                rho=contacting[:, 0],
                p=contacting[:, 1],
                newton=newton,
                seconds=comm.allreduce(MPI.Wtime() - start, op=MPI.MAX),
            )
        )
    return results


def edge_size(meridian: axi.Meridian, a: float) -> float:
    """The radial size (m) of the top face's cell at r = a (m). Collective."""
    mesh = meridian.mesh
    x = mesh.geometry.x
    top = np.isclose(x[:, 1], mesh.comm.allreduce(x[:, 1].max(), op=MPI.MAX))
    r = np.unique(np.concatenate(mesh.comm.allgather(x[top, 0])))
    i = min(int(np.searchsorted(r, a)), len(r) - 1)
    return float(r[i] - r[max(i - 1, 0)])


def push_3d(
    E: float,
    nu: float,
    mesh: dolfinx.mesh.Mesh,
    top: np.ndarray,
    bottom: np.ndarray,
    h_near: float,
    symmetry: dict[int, np.ndarray] | None = None,
    share: float = 1.0,
    depth: float = DEPTH,
    kappas: tuple[float, ...] = (KAPPA,),
    radius: float = RADIUS,
    height: float = axi.H,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[Push]:
    """The same static push on a 3D mesh of the cylinder (or of a part of it cut by symmetry
    planes through the axis), to show the meridian's truth equal to a 3D computation (SPEC 13):
    P2 displacement (P2-P1 Taylor-Hood for nu >= 0.45) on `mesh`, the capsule's own 3D signed
    distance, the penalty k = kappa E / h_near (h_near in m) over the facets `top`, u = 0 on
    the facets `bottom`, and u_i = 0 on the facets symmetry[i] (the plane x_i = 0). `share` is
    the part of the cylinder the mesh is (1/4 for a quarter): P is the whole body's (N).
    Collective."""
    start = MPI.Wtime()
    mu, lmbda = axi.lame(E, nu)
    mixed = nu >= MIXED_FROM
    cell = mesh.basix_cell()
    P2 = basix.ufl.element("Lagrange", cell, 2, shape=(3,))
    element = basix.ufl.mixed_element([P2, basix.ufl.element("Lagrange", cell, 1)]) if mixed else P2
    W = fem.functionspace(mesh, element)
    U = fem.Function(W)

    def eps(z: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        return ufl.sym(ufl.grad(z))

    if mixed:
        u, p = ufl.split(U)
        w, q = ufl.TestFunctions(W)
        elastic = (
            2 * mu * ufl.inner(eps(u), eps(w)) - p * ufl.div(w) - q * (ufl.div(u) + p / lmbda)
        ) * ufl.dx
    else:
        u, w = U, ufl.TestFunction(W)
        elastic = (2 * mu * ufl.inner(eps(u), eps(w)) + lmbda * ufl.div(u) * ufl.div(w)) * ufl.dx
    S = W.sub(0) if mixed else W
    zero = np.float64(0.0)
    bcs = [
        fem.dirichletbc(zero, fem.locate_dofs_topological(S.sub(i), 2, bottom), S.sub(i))
        for i in range(3)
    ]
    for i, facets in (symmetry or {}).items():
        bcs.append(
            fem.dirichletbc(zero, fem.locate_dofs_topological(S.sub(i), 2, facets), S.sub(i))
        )
    tags = dolfinx.mesh.meshtags(
        mesh, 2, np.sort(top).astype(np.int32), np.ones(len(top), np.int32)
    )
    ds = ufl.Measure("ds", mesh, subdomain_data=tags, metadata={"quadrature_degree": 8})(1)
    X = ufl.SpatialCoordinate(mesh)
    x = X + u
    setup = comm.allreduce(MPI.Wtime() - start, op=MPI.MAX)
    pushes = _drive(
        Setting(
            E=E,
            depth=depth,
            radius=radius,
            height=height,
            h_near=h_near,
            U=U,
            mixed=mixed,
            elastic=elastic,
            bcs=bcs,
            tool=capsule(radius, height),
            x=x,
            rho=ufl.sqrt(X[0] ** 2 + X[1] ** 2),
            weight=1.0,
            ds=ds,
            top=top,
            share=share,
        ),
        kappas,
        comm,
    )
    for one in pushes:
        one.seconds += setup
    return pushes
