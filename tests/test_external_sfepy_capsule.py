"""SfePy on the needle in 3D (SPEC 13; workflows/simulators/contact/sfepy_capsule.py): the
cylinder exported at n = 3 to T = 2.5 s (75 steps; the capsule stops 0.16 m down at t = 2 s),
posed with SfePy's dw_contact_sphere whose body is the capsule, stepped by ts.newmark.

Checks against something independent of the adapter: the body's distance and normal against
the capsule's own closed form (meshes/tools/capsule.py); the contact term's tangent against
the finite difference of its residual, on the shaft and on the ball; the O-grid's quarter-turn
symmetry (no sideways force beyond round-off); the push itself (the top face goes down, the
tissue pushes the capsule up, harder as it goes deeper); and `tissuebench compare` grading
the series against our reference beside the export. SfePy's force at t = 2 s over our
implicit's is printed (measured 0.9999988 with the export's k), not asserted."""

import dataclasses
import json

import numpy as np
import pytest
from helpers import tissuebench

pytest.importorskip("sfepy")

from tissuebench.meshes import get_entry  # noqa: E402
from tissuebench.workflows.io.exported import read_json  # noqa: E402
from tissuebench.workflows.io.series import read_series  # noqa: E402
from tissuebench.workflows.io.tables import read_force_csv  # noqa: E402
from tissuebench.workflows.simulators import sfepy as base  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.contact import sfepy_capsule as sc  # noqa: E402

pytestmark = [pytest.mark.serial, pytest.mark.outside]  # an outside simulator: make external-tests

END = 2.5  # s
STEPS = 75  # h = 1/30 s
# the sideways force over the largest F_z: the O-grid maps onto itself under a quarter turn,
# so only round-off is left (measured 6e-13)
SIDEWAYS_TOL = 1e-9


def step_at(t: float) -> int:
    return int(round(t * STEPS / END))


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """(Exported cylinder-MP1 at n = 3 to END, its folder with cylinder.reference.xdmf)."""
    folder = tmp_path_factory.mktemp("sfepy-capsule")
    out = folder / "cylinder.json"
    r = tissuebench("export", "cylinder", "--mesh-size", 3, "--end-time", END, "--out", out)
    assert r.returncode == 0, r.stderr[-3000:]
    return read_json(out), folder


@pytest.fixture(scope="module")
def pushed(export):
    """(Exported, its folder, SfePy's run in folder/sfepy)."""
    data, folder = export
    work = folder / "sfepy"
    work.mkdir()
    run = sc.run(data, "newmark", work)
    assert run.status == "ok", run.reason
    return data, folder, run


@pytest.fixture(scope="module")
def posed(export, tmp_path_factory):
    """(SfePy's problem for the export, its contact term, the variable u), materials set."""
    base.sfepy_modules()
    with base.quiet():
        problem, touch, _ = sc.build_problem(export[0], tmp_path_factory.mktemp("posed"))
        problem.time_update()
        problem.update_materials()
    return problem, touch, problem.get_variables()["u"]


def test_variants_and_refusals(export):
    data, _ = export
    assert adapter("sfepy", "capsule") is sc
    offered = sc.variants(data)
    assert list(offered) == ["newmark"]
    assert "k = kappa E / h_e = 10 x 200 / 0.1667 = 18003.2 Pa/m" in offered["newmark"]
    assert sc.skipped(data) and {"central-difference", "bathe"} <= set(sc.skipped(data))
    stadium = {**data.contact, "shape": {**data.contact["shape"], "kind": "half-stadium"}}
    for other in (
        dataclasses.replace(data, model="neo-hookean-barrier"),
        dataclasses.replace(data, procedure="static"),
        dataclasses.replace(data, contact=stadium),
    ):
        assert sc.variants(other) == {} and "all" in sc.skipped(other)
        with pytest.raises(ValueError, match="SfePy cannot pose this capsule export"):
            sc.run(other, "newmark", None)
    with pytest.raises(ValueError, match="unknown SfePy capsule variant"):
        sc.run(data, "bathe", None)


def test_the_body_is_the_capsule():
    """SfePy's sphere seeing points above the centre at its height: its penetration, normal and
    contact mask are the capsule's -g, -n and g <= 0 (meshes/tools/capsule.py)."""
    base.sfepy_modules()
    capsule = get_entry("cylinder").tool(load_scale=1.0)
    rng = np.random.default_rng(3)
    points = rng.uniform([-0.2, -0.2, 0.7], [0.2, 0.2, 1.3], (2000, 3))
    for t in (0.0, 1.0, 2.0):
        c = capsule.centre(t)
        body = sc.capsule_body(c, 0.1)
        g = capsule.signed_distance(points, c)
        d, normals = body.get_distance(points)
        assert np.allclose(d, -g, rtol=0, atol=1e-14)
        assert np.allclose(normals, -capsule.outward_normal(points, c), atol=1e-12)
        assert np.array_equal(body.mask_points(points, 0.0), g <= 0)
        assert np.array_equal(body.shaft, points[:, 2] > c[2])


@pytest.mark.parametrize("c_z, shaft", [(0.95, True), (1.05, False)])
def test_the_tangent_is_the_residual_derivative(posed, c_z, shaft):
    """At a state where the top face is inside the shaft (c_z = 0.95 m, below the face) or the
    ball (1.05 m), the term's matrix times a direction equals the central difference of its
    residual; on the shaft SfePy's sphere kernel alone is far off (its normal turns with z)."""
    from sfepy.terms.terms_surface import ContactSphereTerm

    problem, touch, u = posed
    v = problem.get_variables()["v"]
    dofs = v.get_dof_conn(touch.region.name, touch.get_dof_conn_type("v"))
    rng = np.random.default_rng(5)
    U, W, eps = 0.002 * rng.standard_normal(u.n_dof), rng.standard_normal(u.n_dof), 1e-7
    touch.cs.centre = np.array([0.0, 0.0, c_z])

    def residual(x):
        u.set_data(x)
        return touch.evaluate(mode="weak", diff_var=None, standalone=False)[0][:, 0, :, 0]

    def mismatch():
        difference = (residual(U + eps * W) - residual(U - eps * W)) / (2 * eps)
        u.set_data(U)
        K = touch.evaluate(mode="weak", diff_var="u", standalone=False)[0][:, 0]
        scale = np.abs(difference).max()
        return np.abs(difference - np.einsum("eij,ej->ei", K, W[dofs])).max() / scale, scale

    with base.quiet():  # SfePy's terms' NumPy deprecation warnings
        error, scale = mismatch()
        assert scale > 1.0 and error < 1e-6
        assert bool(touch.cs.shaft.any()) is shaft
        if shaft:
            kernel = touch.function
            touch.function = ContactSphereTerm.function
            try:
                assert mismatch()[0] > 0.1
            finally:
                touch.function = kernel


def test_the_capsule_pushes_the_top_face(pushed):
    data, _, run = pushed
    series = read_series(run.series, run.field)
    assert len(series.times) == STEPS + 1 and np.allclose(series.times, data.times)
    assert np.array_equal(series.points, data.nodes) and run.mesh == "reference"
    centre = int(np.argmin(np.linalg.norm(data.nodes - [0.0, 0.0, 1.0], axis=1)))
    u_z = series.displacements[step_at(2.0)][centre, 2]
    assert -0.16 < u_z < -0.05, u_z  # m: 0.16 m down, less the penalty's interpenetration
    times, force = read_force_csv(run.force)
    assert force.shape == (STEPS + 1, 3) and np.allclose(times, data.times)
    F_z = force[:, 2]
    assert 0 < F_z[step_at(0.5)] < F_z[step_at(2.0)]  # N: the tissue pushes the capsule up
    sideways = np.abs(force[:, :2]).max()
    assert np.isfinite(sideways) and sideways < SIDEWAYS_TOL * F_z.max()
    ours = np.asarray(data.reference["contact"]["force"])[step_at(2.0), 2]
    print(
        f"\nSfePy F_z(2 s) = {F_z[step_at(2.0)]:.7g} N, ours (implicit) {ours:.7g} N, ratio "
        f"{F_z[step_at(2.0)] / ours:.7f}; F_z(end) {F_z[-1]:.7g} N; largest sideways "
        f"{sideways:.3g} N; u_z(top centre, 2 s) = {u_z:.5g} m; wall {run.wall_time_s:.1f} s"
    )


def test_compare_grades_it(pushed):
    _, folder, run = pushed
    out = folder / "graded"
    r = tissuebench(
        "compare",
        folder / "cylinder.reference.xdmf",
        run.series,
        "--needle-force",
        run.force,
        "--out",
        out,
    )
    assert r.returncode == 0, r.stderr[-3000:]
    (entry,) = json.loads((out / "summary.json").read_text())["runs"].values()
    assert entry["status"] == "ok" and entry["graded_steps"] == STEPS
    graded = ("relative_error_max", "interior_error_max", "force_error", "interpenetration_max")
    assert all(np.isfinite(entry[key]) for key in graded)
    assert entry["interpenetration_max"] > 0  # m: a penalty lets the tissue in a little
    print("\n" + ", ".join(f"{key} {entry[key]:.4g}" for key in graded))


def test_the_shaft_pushes_as_ours_at_twice_the_depth(tmp_path):
    """s = 2 (0.16 m down at t = 1 s, 0.224 m at 1.4 s): from about t = 1 s the top face rises
    above c_z around the capsule and the shaft pushes it sideways; SfePy's force is then our
    implicit's (measured within 7e-5 of its largest; SfePy's ball alone, without the shaft,
    is 95 % off by t = 1.4 s, where the tissue closes over the ball)."""
    out = tmp_path / "cylinder.json"
    r = tissuebench(
        "export", "cylinder", "--mesh-size", 3, "--end-time", 1.4, "--load-scale", 2,
        "--out", out,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    data = read_json(out)
    run = sc.run(data, "newmark", tmp_path)
    assert run.status == "ok", run.reason
    _, force = read_force_csv(run.force)
    ours = np.asarray(data.reference["contact"]["force"])
    error = np.abs(force[:, 2] - ours[:, 2]).max() / np.abs(ours[:, 2]).max()
    print(f"\ns = 2: SfePy's F_z against ours, largest difference {error:.3g} of the largest")
    assert error < 1e-3
