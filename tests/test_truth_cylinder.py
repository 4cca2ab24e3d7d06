"""SPEC 13's truth of the cylinder cases on the meridian (solvers/truth/solver.py's axisymmetric
Problem, cases.py's meridian levels): homogeneous deformations that the axisymmetric forms
must reproduce exactly (the hoop term and the 2 pi r weight), the quick cylinder-MP1 truth
and its axial force (N), the force at rest after the push against the static push of
solvers/truth/hertz3d.py (an independent code on its own meridian grid), and serial against
mpiexec -n 2."""

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from helpers import run_script

from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth import Boundary, Problem, Truth, case_truth, hertz3d
from tissuebench.solvers.truth import axisymmetric as axi
from tissuebench.solvers.truth.cases import benchmark_problem, meridian_benchmark

COMM = MPI.COMM_WORLD
STRETCH = (0.02, -0.03)  # u_r = a r, u_z = b z (m): a homogeneous deformation


def homogeneous(t, x):
    """u = (a r, b z) m, at rest."""
    u = np.column_stack([STRETCH[0] * x[:, 0], STRETCH[1] * x[:, 1]])
    return u, 0.0 * u, 0.0 * u


def homogeneous_problem(nu: float, model: str) -> Problem:
    """The meridian n = 4 with u_r = 0 on the axis (its u_z free) and the homogeneous
    deformation prescribed on the bottom, side and top: no body force."""
    meridian = axi.meridian_mesh(4, comm=COMM)
    mu, lmbda = axi.lame(1000.0, nu)

    def boundaries(V):
        axis = meridian.edges.find(axi.TAGS["axis"])
        others = np.concatenate(
            [meridian.edges.find(axi.TAGS[name]) for name in ("bottom", "side", "top")]
        )
        return [
            Boundary(fem.locate_dofs_topological(V, 1, axis), lambda t, x: (0.0, 0.0, 0.0), (0,)),
            Boundary(fem.locate_dofs_topological(V, 1, others), homogeneous),
        ]

    return Problem(
        mesh=meridian.mesh,
        mu=mu,
        lmbda=lmbda,
        rho=1000.0,
        alpha=1.0,
        beta=0.1,
        model=model,
        body_force=lambda x, t: ufl.as_vector([0.0, 0.0]),
        boundaries=boundaries,
        axisymmetric=True,
    )


@pytest.mark.parametrize(
    "nu, model, kind",
    [
        (0.3, "linear", "displacement"),
        (0.47, "linear", "mixed"),
        (0.47, "neo-hookean-barrier", "mixed-nh"),
    ],
)
def test_a_homogeneous_deformation_is_reproduced_exactly(nu, model, kind):
    """u = (a r, b z) has a constant strain (the hoop strain u_r / r = a included) and, for the
    neo-Hookean law, a constant F = diag(1 + a, 1 + a, 1 + b): its stress is divergence-free in
    the axisymmetric sense, so it is the static solution with no body force, in the Q2 space.
    A form without the hoop term or the 2 pi r weight would not reproduce it (a constant stress
    weighted by r is not in equilibrium in the plane). The axis's u_z is free: it comes out."""
    truth = Truth(homogeneous_problem(nu, model))
    assert truth.kind == kind
    values = truth.static(1.0).reshape(-1, 2)
    X = truth.V.tabulate_dof_coordinates()[: len(values), :2]
    exact = homogeneous(1.0, X)[0]
    error = COMM.allreduce(float(np.abs(values - exact).max()), op=MPI.MAX)
    assert error < 1e-10


def test_the_quick_truth_runs_and_pushes_along_the_axis():
    """cylinder-MP1 on the quick level n = 4, 30 steps (t = 1 s, the capsule 0.08 m deep):
    the axial force (N) is never negative (the tool pushes, it never pulls), is positive after
    its first steps, and x, y are 0 (the revolved body's: exact by symmetry); u_r = 0 on the
    axis, and the top face's centre follows the capsule's bottom."""
    truth, bench = case_truth("cylinder-MP1", 4)
    assert truth.problem.axisymmetric and bench.mesh.geometry.dim == 2
    run = truth.run(bench.dt, 30)
    assert run.axisymmetric and run.force.shape == (31, 3)
    assert np.all(run.force[:, :2] == 0.0)
    assert np.all(run.force[:, 2] >= 0.0) and run.force[:, 2].max() > 0.5
    assert run.force[-1, 2] > 0
    X = truth.V.tabulate_dof_coordinates()[: run.u.shape[1] // 2]
    u = run.u[-1].reshape(-1, 2)
    on_axis = np.abs(X[:, 0]) < 1e-12
    assert np.all(u[on_axis, 0] == 0.0)
    top = on_axis & np.isclose(X[:, 1], axi.H)  # the top face's centre, under the capsule
    lowest = COMM.allreduce(float(u[top, 1].min(initial=np.inf)), op=MPI.MIN)
    # the capsule's bottom is 0.08 m deep at t = 1 s; on this coarse level (cells of 0.075 m at
    # the contact, k = 2.7e6 Pa/m) the penalty lets it in by 2.8 mm (measured)
    assert lowest == pytest.approx(-0.08, abs=0.005)


def test_the_force_at_rest_after_the_push_is_the_static_push():
    """s = 0.25 (the capsule 0.04 m deep from t = 2 s, shallower than R: no shaft contact; the
    static push at s = 1, 0.16 m, does not converge, SPEC 13), the meridian level n = 8 to
    t = 10 s: the damped body settles (the force within 1.5 % over t = 8 to 10 s), and its
    force at t = 10 s is the static push of hertz3d.py at 0.04 m (its own graded meridian,
    n = 20, P = 0.75667 N; n = 40 gives the same to 1e-5) within 1.5 %: the level's
    discretisation (cells of 0.0375 m at the contact, whose radius is about 0.06 m) and the
    creep left at t = 10 s (measured: +0.48 % on n = 8, +0.26 % on n = 16)."""
    mat = get_material("MP1")
    bench = meridian_benchmark("cylinder", 8, 0.25)
    truth = Truth(benchmark_problem(bench, mat, "linear", axisymmetric=True))
    run = truth.run(bench.dt, 300, keep=0)
    # the penalty's force alternates from step to step (the trapezoidal rule does not damp it:
    # 1 % at t = 6 s, 0.03 % at t = 10 s): the mean of consecutive steps
    force = run.force[:, 2]
    paired = (force[1:] + force[:-1]) / 2
    late = paired[240:]  # t = 8 to 10 s
    assert late.max() - late.min() < 0.015 * paired[-1]
    static = hertz3d.push(mat.E, mat.nu, 20, depth=0.04, kappas=(1e3,), comm=COMM)[-1].P
    assert paired[-1] == pytest.approx(static, rel=0.015)


@pytest.mark.serial
def test_cylinder_truth_serial_equals_two_ranks():
    serial_run = run_script("mpi_truth_cylinder.py", ranks=1)
    parallel_run = run_script("mpi_truth_cylinder.py", ranks=2)
    assert serial_run.keys() == parallel_run.keys()
    for key, a in serial_run.items():
        a, b = np.array(a), np.array(parallel_run[key])
        assert a.shape == b.shape, key
        assert np.allclose(a, b, rtol=1e-9, atol=1e-11), (key, np.abs(a - b).max())
