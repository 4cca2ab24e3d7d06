"""MuJoCo on the needle in 3D (workflows/simulators/contact/mujoco_capsule.py): cylinder-MP1 of
mesh size 3 for 2.5 s (75 steps of h = 1/30 s; the capsule 0.16 m deep at t = 2 s, then still),
exported by the command line with our implicit beside it, the flex pushed by the mocap capsule
with MuJoCo's default contact (`discrete-10`), its files read back and graded by `tissuebench
compare`, and `euler-10` beside it. Serial; about 40 s (the export 12 s, MuJoCo 7 + 2 s,
compare 10 s)."""

import json

import numpy as np
import pytest
from helpers import tissuebench

# an outside simulator (make external-tests); serial: the export is made by the command line
pytestmark = [pytest.mark.outside, pytest.mark.serial]

pytest.importorskip("mujoco")

from tissuebench.workflows.io.exported import read_json  # noqa: E402
from tissuebench.workflows.io.series import read_series  # noqa: E402
from tissuebench.workflows.io.tables import read_force_csv  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.contact import mujoco_capsule as mc  # noqa: E402

STEPS = 75  # 2.5 s
PUSHED = 60  # t = 2 s: the capsule 0.16 m deep, where it stops
EARLY = 15  # t = 0.5 s


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """(the export's folder, its Exported): cylinder-MP1 of mesh size 3 to 2.5 s with our
    implicit's cylinder.reference.xdmf beside cylinder.json."""
    folder = tmp_path_factory.mktemp("cylinder")
    r = tissuebench(
        "export", "cylinder", "--mesh-size", 3, "--end-time", 2.5, "--out", folder / "cylinder.json"
    )
    assert r.returncode == 0, r.stderr[-3000:]
    return folder, read_json(folder / "cylinder.json")


def test_what_the_capsule_adapter_poses(export):
    _, data = export
    assert adapter("mujoco", "capsule") is mc
    offered = mc.variants(data)
    assert set(offered) == {"discrete-10", "discrete-30-stiff", "euler-10"}
    # each variant states its contact; the stiff one takes 2 substeps as its time constant
    assert "solref 0.02 s, 1 and solimp 0.9 0.95 0.001" in offered["discrete-10"]
    assert f"solref {2 * data.h / 30:.4g} s" in offered["discrete-30-stiff"]
    assert "E = 200 Pa, nu = 0.47" in offered["discrete-10"]
    assert "St Venant-Kirchhoff" in mc.skipped(data)["model"]  # linear: SVK stands in
    static = type(data)(**{**data.__dict__, "procedure": "static"})
    assert "dynamics only" in mc.skipped(static)["all"] and mc.variants(static) == {}
    # the compiled stiff contact is what it says (MuJoCo keeps a time constant of 2 substeps)
    tets, _ = mc.tetrahedra(data)
    model, address = mc.compile_model(data, tets, "discrete-30-stiff")
    assert np.allclose(model.geom_solref[0], [2 * data.h / 30, 1.0])
    assert np.allclose(model.flex_solref[0], [2 * data.h / 30, 1.0])
    # the bottom's nodes are pinned (no freedom), every other node free
    bottom = np.isclose(data.nodes[:, 2], 0.0)
    assert np.all(address[bottom] < 0) and np.all(address[~bottom] >= 0)


def test_the_capsule_pushes_the_top_face(export, tmp_path):
    folder, data = export
    result = mc.run(data, "discrete-10", tmp_path)
    assert result.status == "ok", result.reason
    assert result.wall_time_s > 0 and result.dofs == data.nodes.size and result.version
    series = read_series(tmp_path / "mujoco.xdmf")
    assert len(series.times) == STEPS + 1 and np.allclose(series.times, data.times)
    assert series.cell_type == "tetrahedron" and np.allclose(series.points, data.nodes)
    U = np.asarray(series.displacements)
    assert U.shape == (STEPS + 1, len(data.nodes), 3) and np.isfinite(U).all()
    # the top face's centre is pushed down. Measured u_z = -0.189 m at t = 2 s, 0.029 m below
    # the capsule's tip (0.16 m deep): a coarse faceted face cannot wrap the ball and sits on
    # it as a pyramid whose apex, outside the capsule, passes below the tip (ours: -0.136 m,
    # its penalty 0.024 m inside). So the bound below the tip is one top cell (the export's
    # h_e), not the tip; the tool passing through would leave the face near 0.
    top = int(np.argmin(np.linalg.norm(data.nodes - [0.0, 0.0, 1.0], axis=1)))
    radius = data.contact["shape"]["radius"]
    depth = 1.0 - (data.contact["motion"]["c"][PUSHED][2] - radius)  # the tip below the top
    assert np.isclose(depth, 0.16)
    h_e = data.contact["penalty"]["h_e"]
    assert -(depth + h_e) < U[PUSHED, top, 2] < -0.05, U[PUSHED, top]
    # the force on the capsule: one row a step, up (+z), growing with the push; measured
    # 4.59 N at t = 0.5 s and 10.0 N at t = 2 s
    times, force = read_force_csv(result.force)
    assert force.shape == (STEPS + 1, 3) and np.allclose(times, data.times)
    assert 0 < force[EARLY, 2] < force[PUSHED, 2]
    # the sideways force, zero for the axisymmetric answer, a symmetry error (measured 0.09 of
    # the axial force at t = 2 s, from the split's asymmetry): finite and below the axial one
    sideways = np.hypot(force[:, 0], force[:, 1])
    assert np.isfinite(sideways).all() and np.all(sideways <= force[:, 2])
    assert sideways[PUSHED] < force[PUSHED, 2]
    # against our reference's force at t = 2 s: reported, not held near 1 (the simulators
    # disagree: that is what the benchmark measures; measured 10.0 N against ours 4.90, 2.04)
    ours = np.asarray(data.reference["contact"]["force"])
    ratio = force[PUSHED, 2] / ours[PUSHED, 2]
    assert np.isfinite(ratio) and ratio > 0
    # compare grades the displacement on MuJoCo's own tetrahedra, and its interpenetration
    # (measured 3e-3 m; the capsule passing through would be R = 0.1 m) and force error
    graded = tmp_path / "graded"
    r = tissuebench(
        "compare", folder / "cylinder.reference.xdmf", tmp_path / "mujoco.xdmf",
        "--out", graded, "--needle-force", result.force,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((graded / "summary.json").read_text())
    run = summary["runs"]["mujoco"]
    assert run["status"] == "ok" and run["graded_steps"] == STEPS
    assert np.isfinite(run["interior_error_max"]) and run["interior_error_max"] > 0
    assert 0 <= summary["contact"]["interpenetration_max"] < 0.01
    assert np.isfinite(summary["contact"]["force_error"])
    # MuJoCo's explicit integrator at the same substep poses the same contact: measured 9.97 N
    # at t = 2 s against discrete-10's 10.00, in a sixth of the wall time; the contact and the
    # faceted face, not the scheme, set the force
    explicit = mc.integrate(data, "euler-10", PUSHED)
    assert explicit["diverged"] is None, explicit["reason"]
    assert abs(explicit["force"][PUSHED, 2] - force[PUSHED, 2]) < 0.05 * force[PUSHED, 2]
