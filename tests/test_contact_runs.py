"""Our algorithms with the needle as penalty contact (SPEC 12): equilibrium, the penalty's
limit, the explicit schemes' critical step, and serial against mpiexec -n 2."""

import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

from tissuebench.meshes import get_benchmark
from tissuebench.meshes.contact import needle
from tissuebench.solvers import get_integrator
from tissuebench.solvers.contact import Measures
from tissuebench.solvers.stability import stability_limits
from tissuebench.solvers.system import System
from tissuebench.workflows.io.tables import read_rows


def push(kappa: float, algorithm: str = "quasi-static", steps: int = 15):
    """The contact block (N = 10, MP1) pushed to t = 2 s (the needle 0.16 m in) in `steps`
    steps: the system, its last state and (F_x, F_y, interpenetration) there."""
    system = System(get_benchmark("contact", mesh_size=10, kappa=kappa), "MP1")
    integrator = get_integrator(algorithm, system, 2.0 / steps)
    state = integrator.start()
    for _ in range(steps):
        state = integrator.step(state)
    measured = Measures(system)(state.u.array_r.copy(), state.t)
    integrator.destroy()
    return system, state, measured


def test_the_needle_force_balances_the_reactions():
    """Quasi-static equilibrium (no body force): the force the tissue exerts on the needle
    equals the x-reactions of the fixed edges, sum over the constrained dofs of (K u)_x, since
    K annihilates translations; the needle pushes on the tip only along x."""
    system, state, (Fx, Fy, depth) = push(10.0)
    assert state.t == pytest.approx(2.0)
    Ku = system.K.createVecLeft()
    system.K.mult(state.u, Ku)
    x_rows = system.constrained[system.component == 0]
    reaction = system.comm.allreduce(float(Ku.array_r[x_rows].sum()), op=MPI.SUM)
    assert Fx > 10.0  # N/m: the tissue pushes back
    assert Fx == pytest.approx(reaction, rel=1e-9)
    assert abs(Fy) < 1e-8 * Fx  # the block is symmetric about y = 0.5
    assert 0 < depth < 0.05


def test_the_needle_force_converges_with_the_penalty():
    """As kappa grows tenfold twice, the needle force converges (each change at most a third
    of the last) and the tissue passes less far into the needle."""
    forces, depths = [], []
    for kappa in (10.0, 100.0, 1000.0):
        _, _, (Fx, _, depth) = push(kappa)
        forces.append(Fx)
        depths.append(depth)
    assert abs(forces[2] - forces[1]) < abs(forces[1] - forces[0]) / 3
    assert depths[0] > depths[1] > depths[2]


def test_the_critical_step_counts_the_penalty():
    """SPEC 12: the explicit schemes' critical step (measured: SLEPc on K + the penalty's bound)
    falls as kappa grows, below the block's without contact."""
    limits = {}
    for name, options in (("block", {"needle_width": 0.2}), ("contact", {"kappa": 10.0})):
        system = System(get_benchmark(name, mesh_size=10, **options), "MP1")
        limits[name] = stability_limits(system, ["explicit-lumped"])["explicit-lumped"]
    stiff = System(get_benchmark("contact", mesh_size=10, kappa=100.0), "MP1")
    limits["stiff"] = stability_limits(stiff, ["explicit-lumped"])["explicit-lumped"]
    assert limits["stiff"].critical_dt < limits["contact"].critical_dt < limits["block"].critical_dt


def test_explicit_with_contact_follows_implicit():
    """explicit (consistent mass, beta K_0 damping) stepped below its critical step tracks
    implicit's needle force at t = 2 s within 2 %."""
    system = System(get_benchmark("contact", mesh_size=10), "MP1")
    critical = stability_limits(system, ["explicit"])["explicit"].critical_dt
    steps = int(np.ceil(2.0 / (0.9 * critical)))
    _, _, (explicit, _, _) = push(10.0, "explicit", steps)
    _, _, (implicit, _, _) = push(10.0, "implicit", 60)
    assert explicit == pytest.approx(implicit, rel=0.02)


@pytest.mark.serial
@pytest.mark.usefixtures("empty_truth_cache")  # numbers only: no grading against a cached truth
def test_contact_run_serial_equals_parallel(tmp_path: Path):
    """`tissuebench run contact` gives the same needle force, interpenetration and metrics in
    serial and on 2 ranks."""
    exe = Path(sys.executable).parent
    args = ["run", "contact", "--mesh-size", "10", "--end-time", "1"]
    args += ["--algorithms", "implicit,quasi-static,explicit-lumped"]
    tables = {}
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        command = [str(exe / "tissuebench"), *args, "--out", str(out)]
        if ranks > 1:
            command = [str(exe / "mpiexec"), "-n", str(ranks), *command]
        subprocess.run(command, check=True, capture_output=True, text=True, timeout=600)
        tables[ranks] = read_rows(out / "contact.csv")
    assert len(tables[1]) == len(tables[2]) == 3 * 31
    for a, b in zip(tables[1], tables[2], strict=True):
        assert a["algorithm"] == b["algorithm"]
        for key in ("force_x", "force_y", "interpenetration"):
            assert float(a[key]) == pytest.approx(float(b[key]), rel=1e-8, abs=1e-12)


@pytest.mark.parallel
def test_the_edge_loop_equals_the_ufl_penalty():
    """The explicit schemes' contact force, facet by facet in numpy (solvers/edge_penalty.py),
    equals the UFL penalty residual assembled by DOLFINx, with the edge inside the needle's tip
    and flank, serial and on 2 ranks."""
    from petsc4py import PETSc

    import dolfinx.fem.petsc
    import ufl
    from dolfinx import fem

    from tissuebench.solvers import contact
    from tissuebench.solvers.edge_penalty import EdgePenalty

    system = System(get_benchmark("contact", mesh_size=10), "MP1")
    u = system.function()
    u.interpolate(
        lambda x: np.stack([-0.1 * x[0] ** 4 * (1 - 4 * (x[1] - 0.5) ** 2), 0.02 * x[0] * x[1]])
    )
    t = 1.5
    c = fem.Constant(system.mesh, np.asarray(needle().centre(t)))
    ds = contact.edge_measure(system.mesh, system.benchmark.contact.facets)
    k = contact.penalty_stiffness(system)
    w = ufl.TestFunction(system.V)
    form = fem.form(ufl.derivative(contact.energy(u, c, needle(), k, ds), u, w))
    b = dolfinx.fem.petsc.assemble_vector(form)
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    n = system.V.dofmap.index_map.size_local * 2
    expected = b.array_r[:n]
    got = EdgePenalty(system)(u.x.array[:n].copy(), t)
    largest = system.comm.allreduce(float(np.abs(expected).max(initial=0.0)), op=MPI.MAX)
    assert largest > 1.0  # N/m: the edge is well inside the needle
    difference = system.comm.allreduce(float(np.abs(got - expected).max(initial=0.0)), op=MPI.MAX)
    assert difference < 1e-12 * largest


@pytest.mark.parametrize("model", ["linear", "neo-hookean"])
def test_the_fast_explicit_step_equals_the_ufl_one(model):
    """explicit-lumped with contact through the fast path (K u or the compiled loop, and the
    edge loop) gives the UFL-assembled path's states to round-off over 40 steps."""
    from tissuebench.solvers import ALGORITHMS
    from tissuebench.solvers.models import get_model
    from tissuebench.solvers.nonlinear import ExplicitModel, integrator

    system = System(get_benchmark("contact", mesh_size=10), "MP1")
    h = 0.9 * stability_limits(system, ["explicit-lumped"])["explicit-lumped"].critical_dt
    scheme, elastic = ALGORITHMS["explicit-lumped"], get_model(model)
    fast = integrator(scheme, system, h, elastic, "fast_")
    slow = ExplicitModel(system, h, scheme, elastic, "slow_", compiled=False)
    assert fast.forces.edge is not None and slow.forces.edge is None
    a, b = fast.start(), slow.start()
    for _ in range(40):
        a, b = fast.step(a), slow.step(b)
    scale = system.comm.allreduce(float(np.abs(b.u.array_r).max(initial=0.0)), op=MPI.MAX)
    assert scale > 1e-3
    difference = system.comm.allreduce(
        float(np.abs(a.u.array_r - b.u.array_r).max(initial=0.0)), op=MPI.MAX
    )
    assert difference < 1e-10 * scale
