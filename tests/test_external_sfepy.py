"""The SfePy runner of `tissuebench external` (workflows/simulators/sfepy.py) against our own,
independent implementation: SfePy's ts.newmark with beta = 1/4, gamma = 1/2 is the trapezoidal
rule of our `implicit` reference, on the same mesh and step, so the two agree to round-off;
its ts.central_difference is our `explicit`. Small meshes and 40 steps (h = 1/30 s); serial
(the runner is, and the tests write files)."""

import dataclasses
import json

from mpi4py import MPI

import h5py
import numpy as np
import pytest

pytest.importorskip("sfepy")

from tissuebench.solvers.materials import get_material  # noqa: E402
from tissuebench.workflows.compare.grading import compare  # noqa: E402
from tissuebench.workflows.compare.posing import build, run_reference  # noqa: E402
from tissuebench.workflows.simulators import sfepy as sf  # noqa: E402

pytestmark = [pytest.mark.serial, pytest.mark.outside]  # an outside simulator: make external-tests

H = 1 / 30  # s
STEPS = 40
# ts.newmark against our implicit, E_n over every step from step 1: measured 4e-15 (rod MP3,
# n = 2) and 8e-16 (block MP1, N = 6), initial acceleration included (both solve
# M a_0 = f - K u_0 - C v_0). A wrong posing is far above it: without SfePy's Rayleigh damping
# 0.5 (rod; alpha = 0 alone 0.5, beta = 0 alone 0.09), without the needle's prescribed
# velocity 0.18, plane stress instead of strain 0.36 (block).
NEWMARK_TOL = 1e-9
# second-order schemes other than the trapezoidal rule against it: ts.bathe and
# ts.generalized_alpha (rho_inf = 0.5) measured E_n max 2e-3 on the block (9e-3 on the rod)
OTHER_SCHEME_TOL = 3e-2


def export(folder, benchmark, mesh_size, material, options=None):
    """(Exported, reference .xdmf) of a small dynamic linear export with our implicit run."""
    m = get_material(material)
    data, bench, _ = build(
        benchmark,
        mesh_size,
        options or {},
        m,
        "linear",
        H,
        STEPS,
        "strain",
        "dynamic",
        MPI.COMM_WORLD,
    )
    ref = folder / "reference.xdmf"
    info = run_reference(data, bench, m, ref, log=lambda *a: None)
    assert info["status"] == "ok"
    return data, ref


@pytest.fixture(scope="module")
def rod(tmp_path_factory):
    return export(tmp_path_factory.mktemp("sfepy-rod"), "rod", 2, "MP3")


@pytest.fixture(scope="module")
def block(tmp_path_factory):
    return export(tmp_path_factory.mktemp("sfepy-block"), "block", 6, "MP1")


def grade(reference, run, out, label="sfepy") -> dict:
    """compare's summary entry of the run's series against the reference."""
    compare(
        reference,
        run.series,
        out,
        reference_field="displacement",
        candidate_field=run.field,
        label=label,
        wall_time=run.wall_time_s,
    )
    return json.loads((out / "summary.json").read_text())["runs"][label]


def displacements(series) -> np.ndarray:
    """The (steps + 1, N, 3) displacement history of an XDMF series written by the runner."""
    with h5py.File(series.with_suffix(".h5"), "r") as h5:
        group = h5["Function/displacement"]
        return np.array([group[str(i)][()] for i in range(len(group))])


def test_available_variants_and_refusals(rod):
    data, _ = rod
    assert sf.NAME == "sfepy" and sf.available() is None
    offered = sf.variants(data)
    assert {"newmark", "bathe", "generalized-alpha", "central-difference"} <= set(offered)
    assert "beta = 1/4, gamma = 1/2" in offered["newmark"] and sf.skipped(data) == {}
    for other in (  # (neo-hookean and svk: tests/test_external_sfepy_nonlinear.py)
        dataclasses.replace(data, model="neo-hookean-barrier"),
        dataclasses.replace(data, model="corotational"),
        dataclasses.replace(data, procedure="static"),
    ):
        assert sf.variants(other) == {} and "all" in sf.skipped(other)
        with pytest.raises(ValueError, match="SfePy cannot run this export: "):
            sf.run(other, "newmark", None)
    with pytest.raises(ValueError, match="unknown SfePy variant"):
        sf.run(data, "houbolt", None)


def test_newmark_rod_matches_our_implicit(rod, tmp_path):
    data, ref = rod
    run = sf.run(data, "newmark", tmp_path)
    assert run.status == "ok" and run.reason is None, run.reason
    assert run.series == tmp_path / "sfepy.xdmf" and run.field == "displacement"
    assert run.dofs == data.nodes.size and run.mesh == "reference" and run.wall_time_s > 0
    assert run.version and run.timing
    s = grade(ref, run, tmp_path / "grade")
    assert s["status"] == "ok" and s["diverged_step"] is None and s["steps"] == STEPS
    assert s["relative_error_max"] < NEWMARK_TOL
    assert s["interior_error_max"] < NEWMARK_TOL * 1e-3  # m; the rod sags by about 1e-3 m
    # the tolerance catches a wrong damping: the same run without SfePy's Rayleigh damping
    m = data.material
    undamped = dataclasses.replace(data, material=dataclasses.replace(m, alpha=0.0, beta=0.0))
    (tmp_path / "undamped").mkdir()
    wrong = sf.run(undamped, "newmark", tmp_path / "undamped")
    assert wrong.status == "ok"
    assert grade(ref, wrong, tmp_path / "undamped" / "grade")["relative_error_max"] > 1e-2


def test_newmark_block_matches_our_implicit(block, tmp_path):
    data, ref = block
    run = sf.run(data, "newmark", tmp_path)
    assert run.status == "ok", run.reason
    s = grade(ref, run, tmp_path / "grade")
    assert s["relative_error_max"] < NEWMARK_TOL
    # the needle and the fixed edges follow their motion exactly at every t_i
    U = displacements(run.series)
    assert U.shape == (STEPS + 1, len(data.nodes), 3) and np.all(U[:, :, 2] == 0)
    for name, nodes in data.effective_sets().items():
        u = data.motions[name][0]
        np.testing.assert_array_equal(U[:, nodes, :2], np.repeat(u[:, None, :], len(nodes), 1))
    # the tolerance catches a wrong boundary condition: the needle's prescribed velocity
    # dropped (it enters the free equations through the damping C v)
    u, v, a = data.motions["needle"]
    wrong_bc = dataclasses.replace(data, motions={**data.motions, "needle": (u, 0 * v, a)})
    (tmp_path / "wrong").mkdir()
    wrong = sf.run(wrong_bc, "newmark", tmp_path / "wrong")
    assert grade(ref, wrong, tmp_path / "wrong" / "grade")["relative_error_max"] > 1e-2


def test_other_steppers_on_the_block(block, tmp_path):
    """ts.bathe and ts.generalized_alpha (boundary values at their sub-step times) keep the
    needle on its motion at every t_i and stay near the trapezoidal rule; ts.central_difference
    is our `explicit` (consistent mass, C = alpha M + beta K, (M + h C/2) a = ...)."""
    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.simulate import simulate
    from tissuebench.solvers.system import System
    from tissuebench.workflows.io.xdmf import gather_series, write_series

    data, ref = block
    needle = data.effective_sets()["needle"]
    for variant in ("bathe", "generalized-alpha"):
        (tmp_path / variant).mkdir()
        run = sf.run(data, variant, tmp_path / variant)
        assert run.status == "ok", run.reason
        U = displacements(run.series)
        np.testing.assert_array_equal(U[:, needle[0], :2], data.motions["needle"][0])
        s = grade(ref, run, tmp_path / variant / "grade")
        assert NEWMARK_TOL < s["relative_error_max"] < OTHER_SCHEME_TOL, (variant, s)

    bench = get_benchmark("block", mesh_size=data.mesh_size, comm=MPI.COMM_WORLD)
    system = System(bench, data.material, plane="strain")
    integrator = get_integrator("explicit", system, H)
    try:
        ours = simulate(integrator, STEPS, bench.extent, "explicit")
    finally:
        integrator.destroy()
    explicit = tmp_path / "explicit.xdmf"
    write_series(explicit, gather_series(system.V, {"displacement": ours.u}), data.times)
    (tmp_path / "cd").mkdir()
    run = sf.run(data, "central-difference", tmp_path / "cd")
    assert run.status == "ok", run.reason
    assert grade(explicit, run, tmp_path / "cd" / "grade")["relative_error_max"] < NEWMARK_TOL


def test_a_blow_up_is_a_result(rod, tmp_path):
    """ts.velocity_verlet takes the damping C v explicitly (half-step velocity): beta K = 0.1 K
    makes it unstable at h = 1/30 s on the rod. The run comes back failed, its series stops at
    the divergence with NaN there, and compare marks that step."""
    data, ref = rod
    run = sf.run(data, "velocity-verlet", tmp_path)
    assert run.status == "failed" and run.reason.startswith("diverged at step")
    step = int(run.reason.split()[3])
    assert 0 < step < STEPS
    U = displacements(run.series)
    assert len(U) == step + 1 and np.all(np.isnan(U[-1, :, :3])) and np.isfinite(U[:-1]).all()
    s = grade(ref, run, tmp_path / "grade")
    assert s["diverged_step"] == step
