"""Sub-steps of the explicit schemes (SPEC 11, solvers/substeps.py): k sub-steps per step are
the same arithmetic as the scheme run with h/k, `auto` takes the fewest below 0.9 times the
critical step, and that critical step, measured for a remedy, is where real runs turn
unstable."""

from mpi4py import MPI

import numpy as np
import pytest

from tissuebench.meshes import get_benchmark
from tissuebench.solvers import get_integrator
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.stability import (
    check_run,
    growth_per_step,
    stability_limits,
    steps_to_diverge,
)
from tissuebench.solvers.substeps import SAFETY, parse_substeps, sub_stepped
from tissuebench.solvers.system import System

COMM = MPI.COMM_WORLD
H = 1 / 30


def block(material: str, n: int = 8, scheme: str = "standard") -> System:
    bench = get_benchmark("block", mesh_size=n, needle_width=0.2, comm=COMM)
    return System(bench, material, scheme=scheme)


@pytest.mark.parametrize("algorithm", ["explicit-lumped", "explicit"])
def test_k_substeps_are_the_scheme_at_h_over_k(algorithm):
    """Steps of h with 3 sub-steps equal every third step of the same scheme run at h/3 (the
    needle moving in both), to round-off."""
    system = block("MP1")
    sub, k, _ = sub_stepped(algorithm, system, H, 3)
    assert k == 3
    coarse = simulate(sub, 20, system.benchmark.extent)
    fine = simulate(get_integrator(algorithm, system, H / 3), 60, system.benchmark.extent)
    assert coarse.status == fine.status == "ok"
    for i in range(21):
        scale = max(np.abs(fine.u[3 * i]).max(), 1e-30)
        assert np.abs(coarse.u[i] - fine.u[3 * i]).max() <= 1e-12 * scale, i
        assert np.abs(coarse.v[i] - fine.v[3 * i]).max() <= 1e-10 * max(
            np.abs(fine.v[3 * i]).max(), 1e-30
        ), i


def test_auto_substeps_run_mp2_explicitly_where_one_step_diverges():
    """MP2, the block with the 0.2 m needle: explicit-lumped at h = 1/30 s diverges; with auto
    it takes the fewest k with h/k <= 0.9 x the measured critical step and finishes."""
    system = block("MP2", n=10)
    critical = stability_limits(system, ["explicit-lumped"])["explicit-lumped"].critical_dt
    plain = simulate(get_integrator("explicit-lumped", system, H), 300, system.benchmark.extent)
    assert plain.status == "diverged"
    integrator, k, measured = sub_stepped("explicit-lumped", system, H, "auto")
    assert measured == pytest.approx(critical, rel=1e-9)
    assert H / k <= SAFETY * critical < H / (k - 1)
    run = simulate(integrator, 300, system.benchmark.extent)
    assert run.status == "ok", run.reason
    assert np.isfinite(run.u[-1]).all()


def test_implicit_schemes_take_no_substeps():
    system = block("MP1")
    _, k, critical = sub_stepped("implicit", system, H, "auto")
    assert (k, critical) == (1, None)


@pytest.mark.parametrize("scheme", ["mean-dilatation", "hourglass"])
def test_a_remedys_measured_critical_step_is_where_real_runs_turn_unstable(scheme):
    """explicit-lumped with the remedy's K: 5 % above its measured critical step a run
    diverges within the steps its fastest mode needs to grow 1e20-fold; 5 % below, the same
    number of steps stays bounded."""
    system = block("MP1", scheme=scheme)
    limit = stability_limits(system, ["explicit-lumped"])["explicit-lumped"]
    above = 1.05 * limit.critical_dt
    growth = growth_per_step("explicit-lumped", system.material, limit.omega_max, above)
    steps = steps_to_diverge(growth, 20_000)
    status, step, _, _ = check_run(system, "explicit-lumped", above, steps)
    assert status == "diverged"
    status, _, peak, _ = check_run(system, "explicit-lumped", 0.95 * limit.critical_dt, step)
    assert status == "ok" and peak < 1.0


def test_substeps_text_is_checked():
    assert parse_substeps("auto") == "auto"
    assert parse_substeps("4") == 4
    for bad in ("0", "-2", "1.5", "two", ""):
        with pytest.raises(ValueError):
            parse_substeps(bad)
