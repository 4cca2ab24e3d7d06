"""Issue 3: the five integrators against closed forms, conservation, convergence and MPI."""

from mpi4py import MPI

import numpy as np
import pytest
from helpers import run_script

from tissuebench.meshes import get_benchmark
from tissuebench.solvers import ALGORITHMS, get_integrator
from tissuebench.solvers.materials import Material
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System

comm = MPI.COMM_WORLD
serial = pytest.mark.skipif(comm.size > 1, reason="dense checks run in serial")

# per dynamic scheme: (consistent mass?, stiffness damping in C?)
SCHEMES = {
    "implicit": (True, True),
    "implicit-lumped": (False, True),
    "explicit": (True, True),
    "explicit-lumped": (False, False),
}


def dense(A):
    return A.copy().convert("dense").getDenseArray().copy()


def modal_solution(system, consistent, stiffness_damping, times):
    """The exact solution of M u'' + C u' + K u = f on the free dofs from rest, mode by mode:
    each mode is a damped oscillator q'' + c q' + w^2 q = F with c = alpha + beta w^2,
    q(t) = F/w^2 [1 + (r2 e^{r1 t} - r1 e^{r2 t}) / (r1 - r2)], r1,2 roots of r^2 + c r + w^2."""
    free = system.free
    M = dense(system.M) if consistent else np.diag(system.ML.array)
    M, K, f = M[np.ix_(free, free)], dense(system.K)[np.ix_(free, free)], system.f.array[free]
    L = np.linalg.cholesky(M)
    Linv = np.linalg.inv(L)
    w2, Y = np.linalg.eigh(Linv @ K @ Linv.T)
    Phi = Linv.T @ Y  # M-orthonormal modes
    F = Phi.T @ f
    c = system.material.alpha + (system.material.beta * w2 if stiffness_damping else 0.0)
    disc = np.sqrt((c**2 / 4 - w2).astype(complex))
    r1, r2 = -c / 2 + disc, -c / 2 - disc
    out = []
    for t in times:
        q = F / w2 * (1 + (r2 * np.exp(r1 * t) - r1 * np.exp(r2 * t)) / (r1 - r2))
        out.append(Phi @ q.real)
    return np.array(out), np.sqrt(w2.max())


@serial
@pytest.mark.parametrize("name", list(SCHEMES))
def test_rod_modes_match_damped_oscillators_at_second_order(name):
    """The rod (n = 1) under gravity: every dynamic scheme converges to the exact modal
    solution of its own semi-discrete system at second order in h."""
    system = System(get_benchmark("rod", mesh_size=1), "MP3")
    T = 1.0
    exact, w_max = modal_solution(system, *SCHEMES[name], [T])
    errors = []
    for n_steps in (40, 80, 160):
        h = T / n_steps
        assert h * w_max < 2  # inside every scheme's stability limit
        run = simulate(get_integrator(name, system, h), n_steps, 0.5, name)
        errors.append(np.linalg.norm(run.u[-1][system.free] - exact[0]) / np.linalg.norm(exact[0]))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 1e-3
    assert np.all((rates > 1.9) & (rates < 2.1)), (errors, rates)


@serial
@pytest.mark.parametrize("name", ["implicit", "implicit-lumped"])
def test_trapezoidal_rule_conserves_energy(name):
    """alpha = beta = 0, constant gravity: 1/2 v.Mv + 1/2 u.Ku - f.u stays at its value 0."""
    material = Material("undamped", E=7000.0, nu=0.2, rho=10_000.0, alpha=0.0, beta=0.0)
    system = System(get_benchmark("rod", mesh_size=2), material)
    run = simulate(get_integrator(name, system, 1 / 30), 300, 0.5, name)
    M = dense(system.M) if SCHEMES[name][0] else np.diag(system.ML.array)
    K, f = dense(system.K), system.f.array
    energy = np.array(
        [0.5 * v @ M @ v + 0.5 * u @ K @ u - f @ u for u, v in zip(run.u, run.v, strict=True)]
    )
    strain = max(0.5 * u @ K @ u for u in run.u)
    assert strain > 0
    assert np.abs(energy).max() < 1e-11 * strain


def test_block_stability_as_the_paper_reports():
    """Block at h = 1/30: the explicit schemes run for MP1 and diverge for MP2."""
    bench = get_benchmark("block")
    for material, explicit_status in [("MP1", "ok"), ("MP2", "diverged")]:
        system = System(bench, material)
        for name in ALGORITHMS:
            run = simulate(get_integrator(name, system, bench.dt), 300, bench.extent, name)
            expected = explicit_status if name.startswith("explicit") else "ok"
            assert run.status == expected, (material, name)
            if run.status == "diverged":
                assert 0 < run.diverged_step <= 300
                assert len(run.u) == run.diverged_step  # the steps before divergence are kept
                assert np.isclose(run.diverged_time, run.diverged_step / 30)
            else:
                assert len(run.u) == 301 and np.all(np.isfinite(run.u[-1]))


def test_constrained_dofs_follow_the_needle_exactly():
    bench = get_benchmark("block", mesh_size=8)
    system = System(bench, "MP1")
    h = 1 / 30
    for name in ALGORITHMS:
        run = simulate(get_integrator(name, system, h), 90, bench.extent, name)
        for i in (0, 1, 59, 60, 61, 90):
            u, v, _ = system.prescribed(i * h)
            assert np.array_equal(run.u[i][system.constrained], u), (name, i)
            if name != "quasi-static":
                assert np.array_equal(run.v[i][system.constrained], v), (name, i)
        assert np.allclose(run.u[90][system.constrained][system.prescribed(0)[1] != 0], -0.16)


@pytest.mark.parametrize("name, material, T", [("rod", "MP3", 30.0), ("block", "MP1", 40.0)])
def test_dynamic_schemes_settle_on_the_quasi_static_solution(name, material, T):
    """Constant load (rod) or a needle at rest after t = 2 s (block): with Rayleigh damping the
    motion dies out, at least as e^{-alpha t / 2}, and every scheme reaches K u = f."""
    bench = get_benchmark(name, mesh_size=8 if name == "block" else 3)
    system = System(bench, material)
    n = round(T * 30)
    static = simulate(get_integrator("quasi-static", system, 1 / 30), n, bench.extent).u[-1]
    norm = np.sqrt(comm.allreduce(float(static @ static)))
    for scheme in SCHEMES:
        u = simulate(get_integrator(scheme, system, 1 / 30), n, bench.extent, scheme).u[-1]
        diff = np.sqrt(comm.allreduce(float((u - static) @ (u - static))))
        assert diff < 1e-5 * norm, scheme


def test_bad_time_step_and_algorithm():
    system = System(get_benchmark("block", mesh_size=4), "MP1")
    for h in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="time step"):
            get_integrator("implicit", system, h)
    with pytest.raises(ValueError, match="unknown algorithm"):
        get_integrator("leapfrog", system, 0.1)


@pytest.mark.parametrize("solver", ["cg", "gamg", "gauss-seidel"])
def test_iterative_options_agree_with_direct(solver):
    bench = get_benchmark("rod", mesh_size=2)
    system = System(bench, "MP3")
    direct = simulate(get_integrator("implicit", system, 1 / 30), 30, bench.extent).u[-1]
    iterative = get_integrator("implicit", system, 1 / 30, solver=solver)
    other = simulate(iterative, 30, bench.extent).u[-1]
    err = np.sqrt(comm.allreduce(float((other - direct) @ (other - direct))))
    assert err < 1e-8 * np.sqrt(comm.allreduce(float(direct @ direct)))
    # it stopped at its tolerance (CONVERGED_RTOL or ATOL), not after ksp_max_it sweeps
    ksp = iterative.solve.ksp
    assert ksp.getConvergedReason() in (2, 3) and ksp.getIterationNumber() < 1000


@pytest.mark.serial
def test_histories_serial_equal_parallel():
    serial_run = run_script("mpi_integrators.py", ranks=1)
    parallel_run = run_script("mpi_integrators.py", ranks=2)
    assert serial_run.keys() == parallel_run.keys()
    for key, a in serial_run.items():
        a, b = np.array(a), np.array(parallel_run[key])
        if key.endswith("status"):
            assert a.tolist() == b.tolist(), key
            continue
        assert a.shape == b.shape, key
        assert np.linalg.norm(a - b) <= 1e-10 * np.linalg.norm(a), key


def relative_difference(a, b):
    """|a - b| / |b| over all ranks (owned dofs)."""
    difference = comm.allreduce(float((a - b) @ (a - b)))
    return np.sqrt(difference / max(comm.allreduce(float(b @ b)), 1e-60))


@pytest.mark.parallel
@pytest.mark.parametrize("name, size, material", [("block", 8, "MP1"), ("rod", 2, "MP3")])
def test_explicit_lumped_loop_equals_the_general_newmark_step(name, size, material):
    """The custom explicit-lumped loop (one fused pass a step, the next predictor written into
    a second buffer) against the general Newmark step with the same parameters (beta_N = 0,
    gamma = 1/2, M_L, C = alpha M_L), u and v over 300 steps to 1e-12: on the moving needle
    (2D, constrained dofs that move) and the rod (3D); under mpiexec -n 2 with the ghosts of
    ubar scattered."""
    from tissuebench.solvers.algorithm import Algorithm
    from tissuebench.solvers.newmark import Newmark

    bench = get_benchmark(name, mesh_size=size)
    system = System(bench, material)
    h = 1 / 30
    scheme = Algorithm(None, mass="lumped", stiffness_damping=False, beta_N=0.0, gamma=0.5)
    fast = simulate(get_integrator("explicit-lumped", system, h), 300, bench.extent)
    slow = simulate(Newmark(system, h, scheme, "general_"), 300, bench.extent)
    assert fast.status == slow.status == "ok" and len(fast.u) == 301
    for x, y in ((fast.u, slow.u), (fast.v, slow.v)):
        for a, b in zip(x, y, strict=True):
            assert relative_difference(a, b) <= 1e-12
    assert comm.allreduce(float(slow.u[-1] @ slow.u[-1])) > 0
    assert comm.allreduce(float(slow.v[-1] @ slow.v[-1])) > 0


@pytest.mark.parallel
def test_explicit_lumped_takes_a_new_state():
    """The fused step keeps the next predictor between steps for the state it left; a new state
    (start() again, after a run or mid-run) takes its own predictor and the same steps."""
    bench = get_benchmark("block", mesh_size=6)
    system = System(bench, "MP1")
    integrator = get_integrator("explicit-lumped", system, 1 / 30)
    first = simulate(integrator, 40, bench.extent).u
    again = simulate(integrator, 40, bench.extent).u
    for a, b in zip(first, again, strict=True):
        assert relative_difference(a, b) <= 1e-15
    state = integrator.start()
    for i in range(40):
        if i == 20:
            state = integrator.start()
            for _ in range(20):
                state = integrator.step(state)
        state = integrator.step(state)
        assert relative_difference(state.u.array_r, first[i + 1]) <= 1e-15
