"""The Hertz check of SPEC 12: the rigid needle pushed statically into the linear MP1 block, its
contact pressure against Hertz's line-contact law.

The block [0, 1]^2 m (fixed left, bottom and top edges, plane strain, the right edge free but
for contact) is pushed by the half-stadium needle (the contact benchmark's tool, meshes/tools/)
moved a depth d (m) into it: c = (1 + R - d, 0.5). Discretisation as the truth's (SPEC 10):
Taylor-Hood P2-P1 for nu >= 0.45 (the linear law 2 mu eps(u):eps(w) - p div w
- q (div u + p / lambda) = 0), on gmsh triangles graded toward the contact zone; contact by
the penalty (solvers/contact.py) driven to its limit: solved with k = kappa E / h_near for
kappa and 10 kappa, the depth applied in load steps, Newton (PETSc SNES, line search, MUMPS)
with the penalty's tangent.

Measured from the solution: P (N/m), the force per unit thickness on the needle along x; p0
(Pa), the largest pressure over the P2 nodes of the right edge; a (m), the contact
half-width from the pressure's second moment, a = 2 (int (y - 0.5)^2 p ds / int p ds)^(1/2),
y of the deformed point. Hertz (a cylinder of radius R on an elastic half-plane, plane
strain): p0 = (P E* / (pi R))^(1/2), a = (4 P R / (pi E*))^(1/2), E* = E / (1 - nu^2).
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
from tissuebench.meshes import get_entry
from tissuebench.solvers import contact
from tissuebench.solvers.truth.cases import HERTZ

DEPTH = 0.005  # m, SPEC 12's small push
KAPPA = 1e3  # the penalty's kappa (k = kappa E / h_near); the check also solves with 10 kappa
LOAD_STEPS = 4  # the depth in this many equal steps
CONTINUATION = (1.0,)  # the soft penalty kappa of the load steps
LU = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}


@dataclass
class Push:
    """One static push: depth (m), the tool's radius (m), h_near (m, the cell size at the
    contact), kappa, k (Pa/m), dofs, the measures P (N/m), p0 (Pa), a (m), the
    interpenetration (m, the largest -g_n at the right edge's P2 nodes), and the pressure
    profile: y (m, deformed) and p (Pa) at the right edge's P2 nodes with p > 0, sorted by
    y."""

    depth: float
    radius: float
    h_near: float
    kappa: float
    k: float
    dofs: int
    P: float
    p0: float
    a: float
    interpenetration: float
    y: np.ndarray
    p: np.ndarray


def hertz(P: float, E: float, nu: float, radius: float) -> tuple[float, float]:
    """Hertz's line contact: (p0 in Pa, a in m) for a load P (N/m) of a rigid cylinder of
    radius `radius` (m) on an elastic half-plane of Young's modulus E (Pa) and Poisson ratio
    nu in plane strain."""
    E_star = E / (1 - nu * nu)
    return float(np.sqrt(P * E_star / (np.pi * radius))), float(
        np.sqrt(4 * P * radius / (np.pi * E_star))
    )


def push(
    E: float,
    nu: float,
    h_near: float,
    depth: float = DEPTH,
    kappas: tuple[float, ...] = (KAPPA, 10 * KAPPA),
    band: float = 0.05,
    h_far: float = 0.05,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> list[Push]:
    """Push the needle `depth` (m) into the block of Young's modulus E (Pa) and Poisson ratio
    nu, on the mesh graded to h_near (m) over |y - 0.5| <= band (m) of the right edge; one Push
    per penalty kappa, each from the last's solution. Collective."""
    entry = get_entry(HERTZ)
    assert entry.tool is not None and entry.graded is not None  # the Hertz case's benchmark
    tool = entry.tool()
    if not (E > 0 and -1 < nu < 0.5 and 0 < depth < tool.radius):
        raise UserError(
            f"a Hertz push needs E > 0, -1 < nu < 0.5, 0 < depth < R, got {E}, {nu}, {depth}"
        )
    tagged = entry.graded(h_near, h_far=h_far, band=band, comm=comm)
    mesh = tagged.mesh
    mu = E / (2 * (1 + nu))
    lmbda = E * nu / ((1 + nu) * (1 - 2 * nu))
    cell = mesh.basix_cell()
    W = fem.functionspace(
        mesh,
        basix.ufl.mixed_element(
            [
                basix.ufl.element("Lagrange", cell, 2, shape=(2,)),
                basix.ufl.element("Lagrange", cell, 1),
            ]
        ),
    )
    V, to_W = W.sub(0).collapse()
    U = fem.Function(W)
    u, p = ufl.split(U)
    w, q = ufl.TestFunctions(W)
    eps = lambda z: ufl.sym(ufl.grad(z))  # noqa: E731
    dim, facets = tagged.entities(entry.contact_surface)
    right = dolfinx.mesh.meshtags(mesh, 1, np.sort(facets), np.ones(len(facets), np.int32))
    ds = ufl.Measure("ds", mesh, subdomain_data=right, metadata={"quadrature_degree": 8})(1)
    c0 = np.asarray(tool.c0, dtype=float)  # m, the tool touching the surface at one point
    axis, across = tool.axis, 1 - tool.axis  # pushed along -axis; the contact spreads across
    c = fem.Constant(mesh, c0.copy())
    k = fem.Constant(mesh, 0.0)
    elastic = (
        2 * mu * ufl.inner(eps(u), eps(w)) - p * ufl.div(w) - q * (ufl.div(u) + p / lmbda)
    ) * ufl.dx
    residual = elastic + ufl.derivative(contact.energy(u, c, tool, k, ds), U, ufl.TestFunction(W))
    assert entry.posing is not None  # a posed benchmark: its fixed regions are physical groups
    regions = [r.name for r in entry.posing().regions]
    fixed = np.unique(np.concatenate([tagged.entities(e)[1] for e in regions]))
    dofs = fem.locate_dofs_topological((W.sub(0), V), 1, fixed)
    bc = fem.dirichletbc(fem.Function(V), dofs, W.sub(0))
    problem = dolfinx.fem.petsc.NonlinearProblem(
        residual,
        U,
        bcs=[bc],
        petsc_options={
            "snes_type": "newtonls",
            "snes_linesearch_type": "basic",
            "snes_rtol": 1e-10,
            # the residual (N/m) settles at round-off, about 1e-10 at kappa 1e4: stop at 1e-8 of
            # the load's scale E d
            "snes_atol": 1e-8 * E * depth,
            "snes_stol": 0.0,
            "snes_max_it": 50,
            **LU,
        },
        petsc_options_prefix="hertz_",
    )
    edge_dofs = fem.locate_dofs_topological(V, 1, facets)
    X_edge = V.tabulate_dof_coordinates()[edge_dofs, :2]
    force = [fem.form(f) for f in contact.needle_force(u, c, tool, k, ds)]
    pressure = contact.pressure(u, c, tool, k)
    y = contact.deformed(u)[across] - c0[across]
    moments = [fem.form(pressure * ds), fem.form(y * y * pressure * ds)]
    size = W.dofmap.index_map.size_global * W.dofmap.index_map_bs

    def total(form) -> float:
        return comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    def solve(what: str) -> None:
        problem.solve()
        reason = problem.solver.getConvergedReason()
        if reason <= 0:  # type: ignore[operator]  # petsc4py's stubs: a ConvergedReason is an int
            raise RuntimeError(f"Hertz push: Newton failed at {what} (SNES reason {reason})")

    # the depth in load steps with a soft penalty, then the penalty stiffened tenfold at a time
    # (each solve starts from the last, whose active set is close)
    k.value = CONTINUATION[0] * E / h_near  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
    for i in range(1, LOAD_STEPS + 1):
        c.value[axis] = c0[axis] - depth * i / LOAD_STEPS
        solve(f"depth {depth * i / LOAD_STEPS:g} m, kappa {CONTINUATION[0]:g}")
    results = []
    kappa = CONTINUATION[0]
    for target in sorted(kappas):
        while kappa < target:
            kappa = min(10 * kappa, target)
            k.value = kappa * E / h_near  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
            solve(f"depth {depth:g} m, kappa {kappa:g}")
        values = U.x.array[to_W].reshape(-1, 2)[edge_dofs]
        x_edge = X_edge + values
        g = tool.signed_distance(x_edge, c.value)
        mine = np.concatenate(
            [x_edge[:, across, None] - c0[across], (k.value * np.maximum(-g, 0))[:, None]], axis=1
        )
        owned = edge_dofs < V.dofmap.index_map.size_local
        gathered = np.concatenate(comm.allgather(mine[owned]))
        gathered = gathered[np.argsort(gathered[:, 0])]
        contacting = gathered[gathered[:, 1] > 0]
        m0, m2 = (total(f) for f in moments)
        results.append(
            Push(
                depth=depth,
                radius=tool.radius,
                h_near=h_near,
                kappa=kappa,
                k=float(k.value),
                dofs=size,
                P=total(force[axis]),
                p0=float(gathered[:, 1].max()),
                a=float(2 * np.sqrt(m2 / m0)),
                interpenetration=float(gathered[:, 1].max() / k.value),
                y=contacting[:, 0] + c0[across],
                p=contacting[:, 1],
            )
        )
    return results
