"""A second 2D tool defined in the test folder alone (tests/toy_tool.py: a flat punch, issue 57
item 5) is posed in the block, run by `run`, graded by `compare` and exported as the needle is,
through the command line's main() in this process, with no monkeypatch and no edit outside the
tests: a tool is one Tool and a benchmark entry that holds it.

Physics, independent of our code's needle: the flat punch's contact width is its face's, so the
linear static response is linear in the depth (the force at two depths in the ratio of the
depths, to Newton's tolerance), where the round needle's contact widens with the depth (Hertz:
the force grows faster than the depth)."""

import csv
import json

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl
from toy_tool import NAME, closed_form_points, punch, registered

from tissuebench.meshes import BENCHMARKS
from tissuebench.workflows.cli import main

SIZE = "8"  # N: the block's cells a side
END = "2.5"  # s: past the push's end at t = 2 s, the last steps static


@pytest.fixture(scope="module")
def tool():
    with registered() as entry:
        yield entry
    assert NAME not in BENCHMARKS


def test_the_punch_in_closed_form_and_in_ufl(tool):
    """Its signed distance and normal by hand at points in front, beside, behind and inside;
    the UFL forms equal the numpy ones at quadrature points of a displaced mesh."""
    shape = punch(1.0)
    points, distance, normal = closed_form_points()
    c = shape.centre(0.0)
    assert np.allclose(c, [1.0, 0.5])
    assert np.allclose(shape.signed_distance(points, c), distance, atol=1e-15)
    assert np.allclose(shape.outward_normal(points, c), normal, atol=1e-15)
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 6, 6)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: np.stack([0.25 * x[0] ** 2, 0.2 * (x[1] - 0.5) * x[0]]))
    centre = dolfinx.fem.Constant(mesh, np.array([1.05, 0.5]))
    x = ufl.SpatialCoordinate(mesh) + u
    reference = np.array([[1 / 3, 1 / 3], [0.1, 0.8]])
    expr = dolfinx.fem.Expression(
        ufl.as_vector([shape.ufl_signed_distance(x, centre), *shape.ufl_outward_normal(x, centre)]),
        reference,
    )
    cells = np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32)
    values = expr.eval(mesh, cells).reshape(-1, 3)
    weights = np.column_stack([1 - reference.sum(axis=1), reference])
    X = mesh.geometry.x[:, :2][mesh.geometry.dofmaps[0][cells]]
    u_h = u.x.array.reshape(-1, 2)[V.dofmap.list[cells]]
    deformed = np.einsum("pv,cvd->cpd", weights, X + u_h).reshape(-1, 2)
    g = shape.signed_distance(deformed, centre.value)
    assert (g < 0).any() and (g > 0).any()  # points inside and outside the punch
    assert np.allclose(values[:, 0], g, atol=1e-12)
    assert np.allclose(values[:, 1:], shape.outward_normal(deformed, centre.value), atol=1e-12)


def final_force(folder, label: str) -> tuple[float, float]:
    """(F_x at the last step in N/m, the largest interpenetration in m) of a run's contact.csv."""
    with open(folder / "contact.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["algorithm"] == label]
    return float(rows[-1]["force_x"]), max(float(r["interpenetration"]) for r in rows)


def quasi_static(out, benchmark: str, scale: float) -> float:
    args = ["run", benchmark, "--out", str(out), "--mesh-size", SIZE, "--end-time", END]
    args += ["--algorithms", "quasi-static", "--load-scale", str(scale), "--no-figures"]
    assert main(args) == 0
    return final_force(out, "quasi-static")[0]


@pytest.mark.slow
def test_run_compare_and_export(tool, tmp_path):
    # run: the static push at two depths (0.04 and 0.08 m at t >= 2 s)
    shallow = quasi_static(tmp_path / "s0.25", NAME, 0.25)
    deep = quasi_static(tmp_path / "s0.5", NAME, 0.5)
    assert shallow > 0  # N/m: the tissue pushes the punch back along +x
    assert deep / shallow == pytest.approx(2.0, rel=1e-6)  # a flat face: linear in the depth
    needle = [quasi_static(tmp_path / f"needle{s}", "contact", s) for s in (0.25, 0.5)]
    assert needle[1] / needle[0] > 2.2  # the round needle's contact widens (Hertz: 2^1.5)

    # compare: our implicit against our quasi-static; the interpenetration compare measures
    # from the series with the punch's geometry is the one the run measured itself
    run = tmp_path / "run"
    args = ["run", NAME, "--out", str(run), "--mesh-size", SIZE, "--end-time", END]
    args += ["--algorithms", "implicit,quasi-static", "--load-scale", "0.5", "--no-figures"]
    assert main(args) == 0
    graded = tmp_path / "graded"
    MPI.COMM_WORLD.barrier()
    args = ["compare", str(run / "implicit.xdmf"), str(run / "quasi-static.xdmf")]
    assert main([*args, "--out", str(graded)]) == 0
    summary = json.loads((graded / "summary.json").read_text())
    (entry,) = summary["runs"].values()
    _, depth = final_force(run, "quasi-static")
    assert depth > 0
    assert entry["interpenetration_max"] == pytest.approx(depth, rel=1e-9)

    # export: the JSON states the punch, its shape as the tool writes it
    export = tmp_path / "punch.json"
    MPI.COMM_WORLD.barrier()
    assert main(["export", NAME, "--out", str(export), "--mesh-size", SIZE]) == 0
    shape = json.loads(export.read_text())["contact"]["shape"]
    assert shape["kind"] == "flat-punch" and shape["radius"] == 0.1 and shape["dimension"] == 2
