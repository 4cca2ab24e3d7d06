"""The truth of SPEC 10 (solvers/truth.py): its element's orders in space on manufactured smooth
solutions (2D and 3D), the trapezoidal rule's order 2 in time, no volumetric locking where
Q1 locks, the rod's static and dynamic tip converging under refinement, the own-error
estimate, and serial against mpiexec -n 2."""

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from helpers import run_script

from tissuebench.solvers.truth import (
    Boundary,
    Problem,
    Truth,
    case_truth,
    estimate_error,
    interior_difference,
)

COMM = MPI.COMM_WORLD


def box(gdim: int, n: int) -> dolfinx.mesh.Mesh:
    if gdim == 2:
        return dolfinx.mesh.create_unit_square(COMM, n, n, dolfinx.mesh.CellType.quadrilateral)
    return dolfinx.mesh.create_unit_cube(COMM, n, n, n, dolfinx.mesh.CellType.hexahedron)


def whole_boundary(exact):
    """Boundaries(V): every boundary node follows exact(t, x) -> (u, v, a), arrays (n, gdim)."""

    def boundaries(V):
        mesh = V.mesh
        tdim = mesh.topology.dim
        mesh.topology.create_connectivity(tdim - 1, tdim)
        facets = dolfinx.mesh.exterior_facet_indices(mesh.topology)
        return [Boundary(fem.locate_dofs_topological(V, tdim - 1, facets), exact)]

    return boundaries


def lame(nu: float, E: float = 1.0) -> tuple[float, float]:
    return E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))


def sigma(u, mu, lmbda):
    eps = ufl.sym(ufl.grad(u))
    return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(len(u))


def l2_error(V, values, exact_ufl) -> float:
    """||u_h - u|| in L2 (m^2 in 2D), by a high-order quadrature. Collective."""
    uh = fem.Function(V)
    uh.x.array[: len(values)] = values
    uh.x.scatter_forward()
    x = ufl.SpatialCoordinate(V.mesh)
    e = uh - exact_ufl(x)
    local = fem.assemble_scalar(
        fem.form(ufl.inner(e, e) * ufl.dx(metadata={"quadrature_degree": 8}))
    )
    return float(np.sqrt(COMM.allreduce(local, op=MPI.SUM)))


def smooth(x, m):
    """A smooth displacement (m) in 2D or 3D, for the UFL (m = ufl) or NumPy (m = np) x."""
    if len(x) == 2:
        return [m.sin(1.5 * x[0] + x[1]), m.cos(x[0] - 2 * x[1]) * x[0]]
    return [m.sin(x[0] + x[1]) * x[2], m.cos(x[1] - x[2]), m.sin(x[0] * x[2] + x[1])]


def static_problem(mesh, exact, nu: float) -> Problem:
    """Static manufactured problem: body force -div sigma(exact), exact on the boundary."""
    mu, lmbda = lame(nu)

    def u_ufl(x):
        return ufl.as_vector(exact(x, ufl))

    def motion(t, x):
        u = np.array(exact(x.T[: mesh.geometry.dim], np)).T
        return u, 0.0, 0.0

    return Problem(
        mesh=mesh,
        mu=mu,
        lmbda=lmbda,
        rho=1.0,
        alpha=0.0,
        beta=0.0,
        model="linear",
        body_force=lambda x, t: -ufl.div(sigma(u_ufl(x), mu, lmbda)),
        boundaries=whole_boundary(motion),
    ), u_ufl


def static_error(gdim: int, n: int, exact, nu: float) -> tuple[float, str]:
    problem, u_ufl = static_problem(box(gdim, n), exact, nu)
    truth = Truth(problem)
    return l2_error(truth.V, truth.static(0.0), u_ufl), truth.kind


@pytest.mark.parametrize(
    "gdim, sizes, nu, kind",
    [
        (2, (4, 8, 16), 0.3, "displacement"),
        (2, (4, 8, 16), 0.49, "mixed"),
        (3, (2, 4), 0.3, "displacement"),
    ],
)
def test_space_order_is_three(gdim, sizes, nu, kind):
    errors = []
    for n in sizes:
        error, used = static_error(gdim, n, smooth, nu)
        assert used == kind
        errors.append(error)
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    # Q2's L2 order 3; Taylor-Hood at nu = 0.49 comes down to 3 from above (a lambda-weighted
    # higher-order term dominates on coarse meshes: 3.97, 3.87, 3.65 over n = 4..32)
    assert orders[-1] > 2.8, (errors, orders)
    if kind == "displacement":
        assert abs(orders[-1] - 3) < 0.25, (errors, orders)


def test_trapezoidal_rule_is_second_order_in_time():
    """u = phi(x) (1 - cos(w t)) with phi in the Q2 space: no space error, u = v = 0 at
    t = 0, a(0) = phi w^2 from the equation of motion; only the time error is left."""
    mesh = box(2, 2)
    mu, lmbda = lame(0.3)
    rho, alpha, beta, w = 2.0, 0.7, 0.05, 3.0

    def phi(x, m=None):
        return [x[0] * x[1], x[0] ** 2 - 0.5 * x[1] ** 2]

    def force(x, t):
        p = ufl.as_vector(phi(x))
        s, ds, dds = 1 - ufl.cos(w * t), w * ufl.sin(w * t), w**2 * ufl.cos(w * t)
        return rho * p * (dds + alpha * ds) - ufl.div(sigma(p, mu, lmbda)) * (s + beta * ds)

    def motion(t, x):
        p = np.array(phi(x.T)).T
        return p * (1 - np.cos(w * t)), p * w * np.sin(w * t), p * w**2 * np.cos(w * t)

    end = 1.0
    errors = []
    for steps in (10, 20, 40):
        problem = Problem(
            mesh, mu, lmbda, rho, alpha, beta, "linear", force, whole_boundary(motion)
        )
        truth = Truth(problem)
        run = truth.run(end / steps, steps, keep=steps)
        exact = lambda x: ufl.as_vector(phi(x)) * (1 - np.cos(w * end))  # noqa: E731
        errors.append(l2_error(truth.V, run.u[-1], exact))
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2) < 0.15), (errors, orders)


def locking_solution(mu, lmbda):
    """A displacement that vanishes on the unit square's boundary with div u = (mu/lambda)
    Delta phi: the pressure -lambda div u stays bounded as lambda -> infinity."""

    def exact(x, m):
        s, pi = m.sin, np.pi
        r = mu / lmbda * pi
        return [
            s(pi * x[0]) ** 2 * s(2 * pi * x[1]) + r * s(2 * pi * x[0]) * s(pi * x[1]) ** 2,
            -s(2 * pi * x[0]) * s(pi * x[1]) ** 2 + r * s(pi * x[0]) ** 2 * s(2 * pi * x[1]),
        ]

    return exact


def q1_error(n: int, exact, nu: float) -> float:
    """Plain DOLFINx Q1 displacement-only solution of the same problem; its L2 error."""
    mesh = box(2, n)
    mu, lmbda = lame(nu)
    V = fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    x = ufl.SpatialCoordinate(mesh)
    u_ex = ufl.as_vector(exact(x, ufl))
    a = ufl.inner(sigma(u, mu, lmbda), ufl.sym(ufl.grad(v))) * ufl.dx
    L = ufl.inner(-ufl.div(sigma(u_ex, mu, lmbda)), v) * ufl.dx
    mesh.topology.create_connectivity(1, 2)
    facets = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    bc = fem.dirichletbc(np.zeros(2), fem.locate_dofs_topological(V, 1, facets), V)
    problem = dolfinx.fem.petsc.LinearProblem(
        a,
        L,
        bcs=[bc],
        petsc_options_prefix="q1_locking_",
        petsc_options={
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": "mumps",
        },
    )
    uh = problem.solve()
    n_owned = V.dofmap.index_map.size_local * 2
    return l2_error(V, uh.x.array[:n_owned], lambda x: u_ex)


def test_no_volumetric_locking():
    n = 16  # 8 cells per wavelength: Q1 resolves the nu = 0.3 solution to about 2 %
    truth, q1 = {}, {}
    for nu in (0.3, 0.4999):
        exact = locking_solution(*lame(nu))
        truth[nu], kind = static_error(2, n, exact, nu)
        assert kind == ("mixed" if nu > 0.45 else "displacement")
        q1[nu] = q1_error(n, exact, nu)
    assert truth[0.4999] < 2 * truth[0.3], truth
    assert q1[0.4999] > 10 * q1[0.3], q1
    assert truth[0.4999] < q1[0.3]  # and Q2-Q1 beats even the unlocked Q1


def test_rod_tip_converges_under_refinement():
    """The rod's static tip (gravity, t = 1 s) and its dynamic tip over 15 steps: monotone
    over n = 1, 2, 4, the differences shrinking at a positive observed order."""
    statics, dynamics = [], []
    for n in (1, 2, 4):
        truth, bench = case_truth("rod", n)
        statics.append(truth.tip(truth.static(1.0))[1])
        run = truth.run(bench.dt, 15, keep=0)
        dynamics.append(run.tip[:, 1])
    statics = np.array(statics)
    assert np.all(statics < 0)
    steps = np.diff(statics)
    assert np.all(steps < 0), statics  # ever more flexible: more downward
    estimate = estimate_error(steps)
    assert 1.5 < estimate.order < 4, estimate
    # the finest level's estimated error is below its distance to the previous level
    assert 0 < estimate.space < abs(steps[-1])
    d1, d2 = (np.abs(dynamics[1] - dynamics[0]), np.abs(dynamics[2] - dynamics[1]))
    assert d2.max() < d1.max() / 2, (d1.max(), d2.max())


def test_error_estimate_recovers_a_known_expansion():
    exact, C, p = -0.13, 0.02, 2.5
    q = np.array([exact + C * 2.0 ** (-p * k) for k in range(3)])
    est = estimate_error(np.diff(q), time_difference=3e-6)
    assert est.order == pytest.approx(p, rel=1e-12)
    assert est.space == pytest.approx(abs(q[-1] - exact), rel=1e-12)
    assert est.time == pytest.approx(4e-6, rel=1e-12)
    assert est.total == pytest.approx(est.space + est.time)
    arrays = estimate_error([np.array([1.0, 1.0, 0.0]), np.array([0.25, 2.0, 0.0])])
    assert arrays.order[0] == pytest.approx(2.0) and np.isnan(arrays.order[1])
    assert np.isnan(arrays.space[1]) and arrays.space[2] == 0.0


def _static_level_differences(graded: bool) -> np.ndarray:
    """E_i (m^2) between the static blocks (MP1, w = 0.2 m, t = 2 s) of N = 10, 20 and 20, 40."""
    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers.truth import TruthRun, benchmark_problem

    runs = []
    for N in (10, 20, 40):
        if graded:
            truth, _ = case_truth("block-MP1-w0.2", N)
        else:
            bench = get_benchmark("block", mesh_size=N, needle_width=0.2)
            truth = Truth(benchmark_problem(bench, "MP1"))
        runs.append(TruthRun(truth.V, np.array([2.0]), truth.static(2.0)[None], None, 0, 0.0))
    return np.array([interior_difference(a, b)[0] for a, b in zip(runs, runs[1:])])  # noqa: B905


def test_the_graded_block_converges_at_second_order_where_the_uniform_does_not():
    """The needle's segment ends are singular: on uniform grids the block's level differences
    fall with order 1.4 (measured: 1.36, then 1.13 from N = 40 to 80); on the grids graded
    toward the segment's ends with order 2 (measured 2.00, 1.95)."""
    uniform, graded = _static_level_differences(False), _static_level_differences(True)
    assert np.log2(uniform[0] / uniform[1]) < 1.5
    assert np.log2(graded[0] / graded[1]) > 1.9
    assert graded[1] < 0.6 * uniform[1]


def test_graded_levels_nest_and_keep_the_needle():
    """Each graded level's vertices are the last level's plus new ones (the levels nest), the
    needle's ends, 0.5 and the domain's corners stay, and the cells shrink toward the ends."""
    from tissuebench.solvers.truth.cases import graded_block

    def grid(N):
        xi = np.linspace(0.0, 1.0, N + 1)
        x = np.array([(a, b, 0.0) for a in xi for b in xi])
        graded_block(x, 0.2)
        return x[:, :2]

    coarse, fine = grid(20), grid(40)
    on_fine = {tuple(p) for p in np.round(fine, 12)}
    assert all(tuple(p) in on_fine for p in np.round(coarse, 12))
    ys = np.unique(np.round(coarse[:, 1], 12))
    assert {0.0, 0.4, 0.5, 0.6, 1.0} <= set(ys)
    gaps = np.diff(ys)
    near_end = gaps[np.searchsorted(ys, 0.4) - 1]  # the cell just below y = 0.4
    assert near_end < 0.2 / 20 and gaps[0] > 1 / 20  # finer at the end, coarser at y = 0


def test_needle_moves_every_q2_node_of_its_segment():
    """Block, w = 0.2 m, N = 10: the needle's Q2 nodes are the vertices and the edge midpoints
    of x = 1, 0.4 <= y <= 0.6 (five), and each follows g(t) exactly (SPEC 4)."""
    truth, bench = case_truth("block-MP2-w0.2", 10)
    needle = truth.boundaries[[c.name for c in bench.constraints].index("needle")].nodes
    owned = needle[needle < truth.V.dofmap.index_map.size_local]
    y = np.concatenate(COMM.allgather(truth.xnodes[owned, 1]))
    assert np.allclose(np.sort(y), [0.4, 0.45, 0.5, 0.55, 0.6])
    run = truth.run(bench.dt, 3)
    u = run.u[-1].reshape(-1, 2)[owned]
    assert np.allclose(u, [-0.08 * 3 * bench.dt, 0.0], rtol=0, atol=1e-14)


@pytest.mark.parametrize("case, n", [("block-MP2-w0.2", 10), ("rod-MP2", 1), ("rod", 1)])
def test_step_matrix_is_symmetric_and_its_ldlt_solves_as_lu(case, n, monkeypatch):
    """The linear truth's step matrix is symmetric (the Taylor-Hood constraint row divided by
    d div z / d div u = 1 + beta 2/h), and its L D L^T factorisation (PETSc's own in 2D on
    one rank, MUMPS's otherwise) gives MUMPS's LU solution to round-off, step by step."""
    truth, bench = case_truth(case, n)
    run = truth.run(bench.dt / 4, 6)
    A = truth._step_solver.A
    scale = A.norm(PETSc.NormType.INFINITY)
    assert A.isSymmetric(tol=1e-13 * scale)
    assert truth._step_solver.ksp.getPC().getType() == "cholesky"
    build = Truth._linear_solver
    monkeypatch.setattr(
        Truth, "_linear_solver", lambda self, r, U, symmetric=False: build(self, r, U, False)
    )
    lu_truth, _ = case_truth(case, n)
    lu = lu_truth.run(bench.dt / 4, 6)
    assert lu_truth._step_solver.ksp.getPC().getType() == "lu"
    assert np.abs(run.u - lu.u).max() <= 1e-10 * np.abs(lu.u).max()
    assert np.abs(lu.u[-1]).max() > 0


@pytest.mark.parametrize("case", ["rod", "rod-nhb-s3"])
def test_one_truth_runs_again_with_another_step(case):
    """A Truth run at h and then at h/2 gives the h/2 run of a fresh Truth (the factorised
    tangent holds h), and the level difference does not depend on how steps are batched."""
    truth, bench = case_truth(case, 1)
    first = truth.run(bench.dt, 4)
    again = truth.run(bench.dt / 2, 8, keep=2)
    fresh, _ = case_truth(case, 1)
    half = fresh.run(bench.dt / 2, 8, keep=2)
    assert np.allclose(again.u, half.u, rtol=0, atol=1e-11)  # Newton's 1e-10 (of ~1e-2 m)
    assert not np.allclose(again.u[-1], first.u[-1], rtol=0, atol=1e-9)  # h matters
    if case != "rod":
        return
    fine, _ = case_truth("rod", 2)
    finer = fine.run(bench.dt, 4)
    whole = interior_difference(first, finer)
    assert np.allclose(interior_difference(first, finer, batch=2), whole, rtol=1e-12, atol=0)
    assert whole[0] == 0 and np.all(whole[1:] > 0)
    # the same space: no interpolation, h against h/2 at the steps of h
    assert np.allclose(interior_difference(first, again), interior_difference(first, half))


def test_where_modified_newton_fails_full_newton_takes_the_step(monkeypatch):
    """A modified Newton allowed one iteration (too few for 1e-10 on a step of the barrier law
    at s = 3) hands its steps to full Newton from the step's start: the history is full
    Newton's alone, to Newton's tolerance."""
    from tissuebench.solvers.truth import solver

    built = []
    original = solver.Truth._newton_solver

    def one_iteration(self, full):
        problem = original(self, full=full)
        built.append(full)
        if not full:
            problem.solver.setTolerances(max_it=1)
        return problem

    monkeypatch.setattr(solver.Truth, "_newton_solver", one_iteration)
    truth, bench = case_truth("rod-nhb-s3", 1)
    fallen = truth.run(bench.dt, 4)
    # every step: the modified Newton fails, is built again for the next, and hands the step to
    # the full Newton, built once
    assert built == [False, True, False, False, False]
    monkeypatch.setattr(solver.Truth, "_newton_solver", original)
    monkeypatch.setattr(solver, "KEEP", 1)  # a new tangent at every iteration: full Newton
    full, _ = case_truth("rod-nhb-s3", 1)
    assert np.allclose(fallen.u, full.run(bench.dt, 4).u, rtol=0, atol=1e-11)


def test_a_static_solve_that_fails_from_rest_starts_from_the_state_at_hand(monkeypatch):
    """Where Newton from rest fails (here made to), the static solve starts from the state at
    hand (a run's last) and reaches the same equilibrium, to Newton's tolerance."""
    truth, bench = case_truth("rod-nhb-s3", 1)
    at_rest = truth.static(1.0)
    truth.run(bench.dt, 5)  # the state at hand: 5 steps in
    solve, calls = dolfinx.fem.petsc.NonlinearProblem.solve, []

    def fails_first(problem):
        calls.append(problem.solver.getOptionsPrefix())
        if len(calls) == 1:  # the attempt from rest
            problem.solver.setConvergedReason(PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT)
            return problem.u
        return solve(problem)

    monkeypatch.setattr(dolfinx.fem.petsc.NonlinearProblem, "solve", fails_first)
    again = truth.static(1.0)
    assert len(calls) == 2  # from rest (failed), then from the state at hand
    assert np.allclose(again, at_rest, rtol=0, atol=1e-10)


@pytest.mark.parametrize("gdim", [2, 3])
def test_smallest_jacobian_of_a_homogeneous_stretch(gdim):
    """J = det(I + grad u) of u = (a x, b y[, c z]) is (1 + a)(1 + b)(1 + c) at every point;
    of a simple shear it is 1; a neo-Hookean run's record starts at rest, J = 1, and the rod
    under gravity is compressed somewhere after."""
    from tissuebench.solvers.truth.solver import _Jacobian

    mesh = box(gdim, 3)
    V = fem.functionspace(mesh, ("Lagrange", 2, (gdim,)))
    u = fem.Function(V)
    stretch = [0.2, -0.5, 0.1][:gdim]
    u.interpolate(lambda x: np.array([s * x[i] for i, s in enumerate(stretch)]))
    smallest, where = _Jacobian(u, 4)()
    assert smallest == pytest.approx(np.prod(1 + np.array(stretch)), rel=1e-12)
    assert where.shape == (gdim,) and np.all((where > 0) & (where < 1))
    u.interpolate(lambda x: np.array([2 * x[1]] + [0 * x[0]] * (gdim - 1)))  # simple shear
    assert _Jacobian(u, 4)()[0] == pytest.approx(1.0, rel=1e-12)
    truth, bench = case_truth("rod-nhb-s3", 1)
    run = truth.run(bench.dt, 3)
    assert run.min_jacobian.values[0] == pytest.approx(1.0, abs=1e-14)
    assert len(run.min_jacobian.values) == 4 and np.all(run.min_jacobian.values[1:] < 1)
    assert case_truth("rod", 1)[0].run(bench.dt, 1).min_jacobian is None  # linear: not used


@pytest.mark.serial
def test_truth_serial_equals_two_ranks():
    serial_run = run_script("mpi_truth.py", ranks=1)
    parallel_run = run_script("mpi_truth.py", ranks=2)
    assert serial_run.keys() == parallel_run.keys()
    for key, a in serial_run.items():
        a, b = np.array(a), np.array(parallel_run[key])
        assert a.shape == b.shape, key
        assert np.allclose(a, b, rtol=1e-9, atol=1e-11), (key, np.abs(a - b).max())
