"""Newton on the needle in 3D (SPEC 13; workflows/simulators/contact/newton_capsule.py): the
cylinder MP1 of mesh size 3 exported to 2.5 s (75 steps of h = 1/30 s, the capsule 0.16 m deep
from t = 2 s on), its hexahedra as VBD tetrahedra pushed by the kinematic capsule with Newton's
vertex contact, graded by `tissuebench compare` against our implicit reference beside the
export. Serial; about 2 minutes with Warp's kernels cached (3 to 4 more compiling them)."""

import json

import numpy as np
import pytest
from helpers import tissuebench

pytestmark = pytest.mark.outside  # an outside simulator: make external-tests

pytest.importorskip("newton")

from tissuebench.workflows.io.exported import read_json  # noqa: E402
from tissuebench.workflows.io.series import read_series  # noqa: E402
from tissuebench.workflows.io.tables import read_force_csv  # noqa: E402
from tissuebench.workflows.simulators import newton as nw  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.contact import newton_capsule as nc  # noqa: E402
from tissuebench.workflows.simulators.newton import conforming  # noqa: E402

if nw.available() is not None:
    pytest.skip(nw.available(), allow_module_level=True)

END = 2.5  # s
STEPS = 75
PUSHED = 60  # t = 2 s: the capsule 0.16 m deep, and stopping


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """(the export's folder, the Exported): cylinder MP1, n = 3, T = 2.5 s, with our reference."""
    folder = tmp_path_factory.mktemp("cylinder")
    out = folder / "cylinder.json"
    r = tissuebench("export", "cylinder", "--mesh-size", 3, "--end-time", END, "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    return folder, read_json(out)


@pytest.fixture(scope="module")
def vertex(export, tmp_path_factory):
    """(the run's folder, its ExternalRun) of `vbd-vertex` on the export."""
    _, data = export
    folder = tmp_path_factory.mktemp("newton")
    return folder, nc.run(data, "vbd-vertex", folder)


def test_the_variants_say_their_contact_and_the_split_conforms(export):
    _, data = export
    assert adapter("newton", "capsule") is nc and nc.skipped(data) == {}
    lines = nc.variants(data)
    assert {"vbd-vertex", "vbd-vertex-stiff", "vbd-surface"} <= set(lines)
    assert "vertex contact" in lines["vbd-vertex"] and "full-surface" in lines["vbd-surface"]
    assert all("k_lambda = lambda" in line and "N/m" in line for line in lines.values())
    assert nc.stiffness(data, "vbd-vertex-stiff") == pytest.approx(
        100 * nc.stiffness(data, "vbd-vertex")
    )
    # the O-grid's turned blocks: the split cuts each face alike from both of its cells
    tets = nc.tetrahedra(data)
    assert len(tets) == 6 * len(data.cells) and conforming(tets, data.cells)


@pytest.mark.serial
def test_the_capsule_pushes_the_top_face_and_feels_it(export, vertex):
    _, data = export
    workdir, result = vertex
    assert result.status == "ok", result.reason
    assert result.force == workdir / "newton_force.csv" and result.dofs == 3 * len(data.nodes)
    series = read_series(workdir / "newton.xdmf")
    assert len(series.times) == STEPS + 1 and np.allclose(series.times, data.times)
    assert series.cell_type == "tetrahedron" and len(series.points) == len(data.nodes)
    U = np.asarray(series.displacements)
    assert U.shape == (STEPS + 1, len(data.nodes), 3) and np.all(np.isfinite(U))
    times, force = read_force_csv(result.force)
    assert len(times) == STEPS + 1 and force.shape == (STEPS + 1, 3)
    assert np.allclose(times, data.times)
    # the top centre node goes down with the capsule (measured: u_z = -0.112 m at t = 2 s,
    # ours -0.136 m; the node slides sideways off the ball's apex, u_x = u_y = -0.044 m)
    centre = int(np.argmin(np.sum((data.nodes - [0.0, 0.0, 1.0]) ** 2, axis=1)))
    assert -0.16 < U[PUSHED, centre, 2] < -0.05, U[PUSHED, centre]
    # the tissue pushes the capsule up, harder as it goes deeper (measured F_z 2.30 N at
    # t = 0.5 s, 4.02 N at 2 s)
    half = int(round(0.5 / data.h))
    assert force[PUSHED, 2] > 0 and force[PUSHED, 2] > force[half, 2] > 0
    # sideways: a symmetry error, reported, not bounded (measured 3.4 N in x and y at 2 s)
    assert np.all(np.isfinite(force[:, :2]))
    ours = np.asarray(data.reference["contact"]["force"], dtype=float)
    ratio = force[PUSHED, 2] / ours[PUSHED, 2]
    print(
        f"Newton vbd-vertex at t = 2 s: F = {force[PUSHED]} N, ours F_z = {ours[PUSHED, 2]:.4g} "
        f"N, ratio {ratio:.3g}; largest sideways |F_xy| "
        f"{np.linalg.norm(force[:, :2], axis=1).max():.3g} N; wall {result.wall_time_s:.1f} s"
    )


@pytest.mark.serial
def test_compare_grades_the_displacement_and_the_force(export, vertex):
    folder, _ = export
    workdir, _ = vertex
    graded = workdir / "graded"
    r = tissuebench(
        "compare", folder / "cylinder.reference.xdmf", workdir / "newton.xdmf",
        "--needle-force", workdir / "newton_force.csv", "--out", graded,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    summary = json.loads((graded / "summary.json").read_text())
    text = json.dumps(summary)
    assert "interpenetration_max" in text and "force_error" in text
    print(r.stdout)
