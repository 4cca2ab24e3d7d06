"""Stability and convergence against answers found independently of the code under test: a dense
eigenvalue solve, Newmark's closed-form stability limit, real runs on either side of the
predicted limit, the trapezoidal rule's order 2, and exact interpolation between nested meshes."""

import argparse
import json
import math

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np
import pytest
from dolfinx import fem
from helpers import run_script

from tissuebench.core.errors import UserError
from tissuebench.meshes import get_benchmark
from tissuebench.solvers import get_integrator
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.stability import (
    critical_dt,
    explicit_schemes,
    mode_critical_h,
    newmark_schemes,
    omega_range,
    run_check,
    stability_limits,
)
from tissuebench.solvers.system import System
from tissuebench.workflows.commands import convergence, stability
from tissuebench.workflows.study.convergence import (
    METRICS,
    difference_orders,
    interpolate,
    orders,
    time_study,
)

serial_only = pytest.mark.skipif(
    MPI.COMM_WORLD.size > 1, reason="dense matrices and timings: serial"
)


def system(bench, size, material):
    return System(get_benchmark(bench, mesh_size=size), material)


def vector_space(bench, size):
    mesh = get_benchmark(bench, mesh_size=size).mesh
    return fem.functionspace(mesh, ("Lagrange", 1, (mesh.geometry.dim,)))


def dense(A):
    """A copy of A as a numpy array (convert() without `out` would change A itself)."""
    return A.convert("dense", PETSc.Mat()).getDenseArray().copy()


def dense_frequencies(K, M, free):
    """(omega_min, omega_max) of K x = omega^2 M x on the free dofs: with M = L L^T (Cholesky),
    the eigenvalues of L^-1 K L^-T (numpy)."""
    L = np.linalg.cholesky(M[np.ix_(free, free)])
    Linv = np.linalg.inv(L)
    lam = np.linalg.eigvalsh(Linv @ K[np.ix_(free, free)] @ Linv.T)
    return np.sqrt(lam[0]), np.sqrt(lam[-1])


@serial_only
@pytest.mark.parametrize("bench,size,material", [("block", 4, "MP2"), ("rod", 2, "MP3")])
@pytest.mark.parametrize("lumped", [False, True])
def test_extreme_frequencies_match_a_dense_eigensolve(bench, size, material, lumped):
    s = system(bench, size, material)
    K, M = dense(s.K), dense(s.M)
    if lumped:
        M = np.diag(M.sum(axis=1))  # row sums on the diagonal
    expected = dense_frequencies(K, M, s.free)
    assert omega_range(s, lumped) == pytest.approx(expected, rel=1e-8)


def hughes_limit(zeta, beta_N, gamma):
    """Newmark's critical Omega = h omega with damping ratio zeta, in the usual notation with
    beta = beta_N / 2 (Hughes, The Finite Element Method, section 9.1):
    [zeta (gamma - 1/2) + sqrt(gamma/2 - beta + zeta^2 (gamma - 1/2)^2)] / (gamma/2 - beta)."""
    beta = beta_N / 2
    return (zeta * (gamma - 0.5) + math.sqrt(gamma / 2 - beta + zeta**2 * (gamma - 0.5) ** 2)) / (
        gamma / 2 - beta
    )


@pytest.mark.parametrize("zeta", [0.0, 0.2, 1.0, 5.0, 150.0])
@pytest.mark.parametrize("beta_N,gamma", [(0.0, 0.5), (0.2, 0.6), (0.0, 0.7)])
def test_modal_limit_matches_newmark_closed_form(zeta, beta_N, gamma):
    omega = 37.0  # rad/s
    h = mode_critical_h(omega, 2 * zeta * omega, beta_N, gamma)
    assert h * omega == pytest.approx(hughes_limit(zeta, beta_N, gamma), rel=1e-8)


@pytest.mark.parametrize("zeta", [0.0, 0.01, 1.0, 1e4])
def test_trapezoidal_rule_is_unconditionally_stable(zeta):
    assert mode_critical_h(5.0, 10.0 * zeta, 0.5, 0.5) == math.inf


def test_central_difference_limit_is_two_over_omega_max():
    """gamma = 1/2: the limit does not depend on the damping, so it is set by omega_max alone."""
    for name in ("explicit", "explicit-lumped"):
        assert critical_dt(name, get_material("MP2"), 20.0, 3000.0) == pytest.approx(
            2 / 3000.0, rel=1e-8
        )
    assert critical_dt("implicit", get_material("MP2"), 20.0, 3000.0) == math.inf


# SPEC sections 2 and 3, written out here independently of the registry:
# (beta_N, gamma, mass, C has beta K)
SPEC_TABLE = {
    "implicit": (0.5, 0.5, "consistent", True),
    "implicit-lumped": (0.5, 0.5, "lumped", True),
    "explicit": (0.0, 0.5, "consistent", True),
    "explicit-lumped": (0.0, 0.5, "lumped", False),
}


def test_schemes_are_the_spec_and_the_integrators():
    """The registry's scheme data is SPEC section 2's table, and the integrators that run use it."""
    schemes = newmark_schemes()
    assert {
        name: (a.beta_N, a.gamma, a.mass, a.stiffness_damping) for name, a in schemes.items()
    } == SPEC_TABLE
    s = system("block", 4, "MP1")
    for name, scheme in schemes.items():
        integrator = get_integrator(name, s, 0.01)
        assert (integrator.beta_N, integrator.gamma, integrator.lumped) == (
            scheme.beta_N,
            scheme.gamma,
            scheme.lumped,
        )
        assert integrator.alpha == s.material.alpha
        assert integrator.beta == (s.material.beta if scheme.stiffness_damping else 0.0)


@pytest.mark.parametrize("bench,size,material", [("block", 4, "MP1"), ("rod", 2, "MP3")])
def test_real_runs_diverge_just_above_the_limit_and_not_below(bench, size, material):
    s = system(bench, size, material)
    rows = run_check(s, stability_limits(s, explicit_schemes()), margin=0.05, max_steps=20_000)
    for row in rows:
        expected = "diverged" if row["ratio"] > 1 else "ok"
        assert row["status"] == expected, row


@serial_only
def test_time_orders():
    """Against implicit with h/64: implicit converges with order 2; explicit-lumped converges to
    the lumped-mass solution (its error stops falling) while its own successive differences
    still fall with order 2."""
    s = system("block", 4, "MP1")
    results = time_study(s, 1 / 30, 1.0, algorithms=("implicit", "explicit-lumped"))
    steps = [1, 2, 4, 8]
    for name in METRICS:
        implicit = [e[name] for e in results["implicit"]["errors"]]
        assert orders(steps, implicit) == pytest.approx([2, 2, 2], abs=0.15)
        lumped = results["explicit-lumped"]
        errors = [e[name] for e in lumped["errors"]]
        assert errors[-1] > 0.9 * errors[0]
        differences = [d[name] for d in lumped["differences"]]
        assert difference_orders(steps, differences) == pytest.approx([2, 2], abs=0.15)


def test_order_formulas():
    sizes = [2, 3, 6, 12]
    p, C = 1.4, 0.3
    errors = [C * s**-p for s in sizes]
    assert orders(sizes, errors) == pytest.approx([p] * 3, rel=1e-12)
    differences = [abs(errors[k] - errors[k + 1]) for k in range(3)]
    assert difference_orders(sizes, differences) == pytest.approx([p, p], rel=1e-8)


@pytest.mark.parametrize("bench,coarse,fine", [("block", 4, 8), ("rod", 2, 6)])
def test_interpolation_between_nested_meshes_is_exact_for_a_multilinear_field(bench, coarse, fine):
    """x y (1 + z) lies in Q1 on every mesh, so coarse-to-fine interpolation must reproduce it."""
    V_from, V_to = vector_space(bench, coarse), vector_space(bench, fine)
    d = V_from.mesh.geometry.dim

    def field(x):
        return np.array([x[0] * x[1] * (1 + x[2]), 1 + x[0] - 2 * x[1], x[0] * x[2]])[:d]

    u_from, u_to = fem.Function(V_from), fem.Function(V_to)
    u_from.interpolate(field)
    u_to.interpolate(field)
    n = V_from.dofmap.index_map.size_local * V_from.dofmap.bs
    values = interpolate(V_to, V_from, u_from.x.array[:n])
    assert values == pytest.approx(u_to.x.array[: len(values)], abs=1e-12)


@serial_only
@pytest.mark.serial
def test_serial_and_two_ranks_agree():
    serial, parallel = run_script("mpi_stability.py"), run_script("mpi_stability.py", ranks=2)
    for bench in ("block", "rod"):
        for name, values in serial[bench].items():
            assert parallel[bench][name] == pytest.approx(values, rel=1e-8), (bench, name)
    for name, value in serial["space"].items():
        assert parallel["space"][name] == pytest.approx(value, rel=1e-8), name


def test_stability_command_writes_json(tmp_path):
    args = argparse.Namespace(
        benchmark="block",
        material="MP1",
        mesh_size=4,
        out=str(tmp_path),
        margin=0.05,
        max_steps=20_000,
        no_sweep=True,
    )
    assert stability.main(args) == 0
    record = json.loads((tmp_path / "stability.json").read_text())
    assert (record["benchmark"], record["material"], record["mesh_size"]) == ("block", "MP1", 4)
    for name in ("explicit", "explicit-lumped"):
        r = record["algorithms"][name]
        assert r["critical_dt"] == pytest.approx(2 / r["omega_max"], rel=1e-8)
    assert record["algorithms"]["implicit"]["critical_dt"] is None
    assert record["algorithms"]["implicit"]["unconditionally_stable"]
    assert "## Stability" in (tmp_path / "stability.md").read_text()


def test_bad_options_are_usage_errors(tmp_path):
    args = argparse.Namespace(
        benchmark="block",
        material="MP1",
        mesh_size=4,
        out=str(tmp_path),
        margin=1.5,
        max_steps=10,
        no_sweep=True,
    )
    with pytest.raises(UserError, match="margin"):
        stability.main(args)
    with pytest.raises(UserError, match="end-time"):
        convergence.main(argparse.Namespace(out=str(tmp_path), end_time=0.01))
