"""Drake on the needle in 3D (workflows/simulators/contact/drake_capsule.py): the cylinder of
mesh size 3 (SPEC 13, MP1, linear) exported for 2.5 s (75 steps of h = 1/30 s, the capsule
0.16 m deep from t = 2 s), its O-grid split into conforming tetrahedra and pushed by Drake's
rigid capsule on a prismatic joint, against our own implicit run written beside the export.
Serial; about a minute on 2 shared cores (the export and its reference 10 to 20 s, each Drake
run 5 to 25 s, compare 10 s)."""

import json

import numpy as np
import pytest
from helpers import tissuebench

from tissuebench.workflows.simulators import drake as dk

pytestmark = [pytest.mark.outside, pytest.mark.usefixtures("empty_truth_cache")]

pytest.importorskip("pydrake")
if dk.available() is not None:
    pytest.skip(dk.available(), allow_module_level=True)

from tissuebench.workflows.io.exported import read_json  # noqa: E402
from tissuebench.workflows.io.series import read_series  # noqa: E402
from tissuebench.workflows.io.tables import read_force_csv  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.contact import drake_capsule as dc  # noqa: E402
from tissuebench.workflows.simulators.newton import conforming, tet_volumes  # noqa: E402

END = 2.5  # s: 75 steps; the capsule stops at t = 2 s, 0.16 m deep


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """(the folder, the Exported cylinder of mesh size 3 to END with our implicit beside it)."""
    folder = tmp_path_factory.mktemp("cylinder")
    out = folder / "cylinder.json"
    r = tissuebench("export", "cylinder", "--mesh-size", 3, "--end-time", END, "--out", out)
    assert r.returncode == 0, r.stderr[-3000:]
    return folder, read_json(out)


@pytest.fixture(scope="module")
def compliant(export, tmp_path_factory):
    """The `linear-compliant` run (the capsule as soft as our penalty) and its folder."""
    _, data = export
    work = tmp_path_factory.mktemp("drake")
    return dc.run(data, "linear-compliant", work), work


def step(data, t):
    return int(round(t / data.h))


def test_the_o_grid_is_split_into_conforming_tetrahedra(export):
    _, data = export
    tets, mesh = dc.tetrahedra(data)
    nodes = np.asarray(data.nodes)
    # the rod's split cracks the O-grid (its blocks are turned): the cone split conforms
    assert "cone_split" in mesh and conforming(tets, data.cells)
    assert tet_volumes(nodes, tets).min() > 0
    assert tet_volumes(nodes, tets).sum() == pytest.approx(
        tet_volumes(nodes, dc.cone_split(nodes, data.cells)).sum()
    )


@pytest.mark.serial
def test_the_capsule_pushes_the_top_face(export, compliant):
    folder, data = export
    result, work = compliant
    assert adapter("drake", "capsule") is dc and dc.skipped(data) == {}
    assert set(dc.variants(data)) == {"linear", "linear-compliant", "linear-compliant-x100"}
    assert result.status == "ok", result.reason
    assert result.force == work / "drake_force.csv" and result.series == work / "drake.xdmf"
    series = read_series(result.series)
    assert len(series.times) == data.steps + 1 and np.allclose(series.times, data.times)
    U = np.asarray(series.displacements)
    top = int(np.argmin(np.linalg.norm(np.asarray(data.nodes) - [0.0, 0.0, 1.0], axis=1)))
    # measured -0.147 m (the capsule 0.16 m deep; our implicit -0.136 m)
    assert -0.16 < U[step(data, 2.0)][top, 2] < -0.05
    bottom = np.asarray(data.nodes)[:, 2] < 1e-9
    assert np.abs(U[:, bottom]).max() < 1e-12
    times, force = read_force_csv(result.force)
    assert force.shape == (data.steps + 1, 3) and np.allclose(times, data.times)
    early, pushed = force[step(data, 0.5)], force[step(data, 2.0)]
    # the tissue pushes the capsule up, harder as it goes deeper: measured 2.9 N and 10.6 N
    assert 0 < early[2] < pushed[2]
    # sideways: Drake's symmetry error (the split is not symmetric), reported, measured 0.53 N
    sideways = np.hypot(force[:, 0], force[:, 1])
    assert np.isfinite(sideways).all()
    reference = np.asarray(data.reference["contact"]["force"])[step(data, 2.0), 2]
    print(
        f"\nDrake linear-compliant: F_z(2 s) = {pushed[2]:.4g} N, ours {reference:.4g} N, "
        f"ratio {pushed[2] / reference:.3g}; largest sideways force {sideways.max():.3g} N"
    )
    graded = folder / "graded"
    r = tissuebench(
        "compare", folder / "cylinder.reference.xdmf", result.series, "--out", graded,
        "--needle-force", result.force,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    summary = json.loads((graded / "summary.json").read_text())
    text = json.dumps(summary)
    assert "relative_error" in text and "interpenetration_max" in text
    print(r.stdout[-1500:])


@pytest.mark.serial
def test_the_rigid_capsule_chatters_but_pushes(export, tmp_path):
    """Drake's near-rigid default: the tissue's force comes in blows (measured: no contact at
    about half the steps, 0 to 48 N), so only its mean over each second is checked."""
    _, data = export
    result = dc.run(data, "linear", tmp_path)
    assert result.status == "ok", result.reason
    _, force = read_force_csv(result.force)
    first, second = (force[step(data, a) + 1 : step(data, b) + 1, 2] for a, b in ((0, 1), (1, 2)))
    assert 0 < first.mean() < second.mean()
    assert np.isfinite(force).all()


def test_what_is_not_posed(export, tmp_path):
    _, data = export
    static = type(data)(**{**data.__dict__, "procedure": "static"})
    assert "time only" in dc.skipped(static)["all"] and dc.variants(static) == {}
    barrier = type(data)(**{**data.__dict__, "model": "neo-hookean-barrier"})
    assert "neo-hookean" in dc.variants(barrier) and "barrier" in dc.skipped(barrier)
    svk = type(data)(**{**data.__dict__, "model": "svk"})
    assert dc.variants(svk) == {} and "svk" in dc.skipped(svk)["all"]
    no_tool = type(data)(**{**data.__dict__, "contact": None})
    assert dc.skipped(no_tool) == {"all": "not a contact benchmark"}
    result = dc.run(data, "corotated", tmp_path)
    assert result.status == "failed" and "does not pose" in result.reason
