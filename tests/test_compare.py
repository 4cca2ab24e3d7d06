"""compare(): two displacement series read from files give the curves of the in-memory path,
and bad input is refused with one line and nothing written."""

import contextlib
import csv
import json
from pathlib import Path

from mpi4py import MPI

import meshio
import numpy as np
import pytest
from dolfinx import fem, io
from dolfinx import mesh as dmesh
from dolfinx.io.utils import cell_perm_vtk
from helpers import run_script, tissuebench

from tissuebench.core.errors import UserError
from tissuebench.metrics import NAMES, InputError, Metrics
from tissuebench.metrics.compare import COLUMNS
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.io.series import read_series

TIMES = [0.0, 0.1, 0.2, 0.3]

# the series are written in serial by meshio and DOLFINx here; compare() under mpiexec -n 2 is
# checked against serial by test_compare_serial_and_two_ranks_agree and the command-line tests
pytestmark = pytest.mark.serial


def make_space(dim):
    if dim == 2:
        mesh = dmesh.create_unit_square(MPI.COMM_SELF, 4, 3, dmesh.CellType.quadrilateral)
    else:
        mesh = dmesh.create_box(
            MPI.COMM_SELF, [[0, 0, 0], [0.5, 0.25, 0.25]], [4, 2, 2], dmesh.CellType.hexahedron
        )
    return fem.functionspace(mesh, ("Lagrange", 1, (dim,)))


def fields(V, times=TIMES):
    """Reference and candidate histories as (n, d) nodal arrays of the serial space V."""
    dim = V.mesh.geometry.dim
    X = V.tabulate_dof_coordinates()
    ref = [
        t * np.c_[0.3 * X[:, 1] * X[:, 0], -0.2 * X[:, 0] ** 2, 0.1 * X[:, 2]][:, :dim]
        for t in times
    ]
    cand = [
        u * (1 + 0.3 * t) + t**2 * 0.01 * np.sin(3 * X[:, :dim])
        for t, u in zip(times, ref, strict=True)
    ]
    return ref, cand


def mesh_data(V):
    """Points (with a zero third coordinate in 2D) and VTK-ordered cells of serial V."""
    cell_type = V.mesh.topology.cell_type
    cells = V.dofmap.list[:, np.argsort(cell_perm_vtk(cell_type, V.dofmap.list.shape[1]))]
    return (
        V.tabulate_dof_coordinates(),
        cells,
        "quad" if cell_type == dmesh.CellType.quadrilateral else "hexahedron",
    )


def pad(u):
    return np.c_[u, np.zeros((len(u), 3 - u.shape[1]))]


def write_meshio_xdmf(path, points, cells, cell_type, values, times=TIMES, field="displacement"):
    # meshio's TimeSeriesWriter puts the .h5 in the working directory, not beside the .xdmf.
    with (
        contextlib.chdir(Path(path).parent),
        meshio.xdmf.TimeSeriesWriter(Path(path).name) as writer,
    ):
        writer.write_points_cells(points, [(cell_type, cells)])
        for t, u in zip(times, values, strict=False):
            writer.write_data(t, point_data={field: pad(u)})


def write_pvd(path, points, cells, cell_type, values, times=TIMES, field="displacement"):
    path = Path(path)
    entries = []
    for k, (t, u) in enumerate(zip(times, values, strict=False)):
        vtu = path.with_name(f"{path.stem}_{k:03d}.vtu")
        meshio.write(vtu, meshio.Mesh(points, [(cell_type, cells)], point_data={field: pad(u)}))
        entries.append(f'    <DataSet timestep="{t!r}" part="0" file="{vtu.name}"/>')
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )


def shuffled(points, cells, values, seed=1):
    """The same series with its nodes stored in a random order."""
    order = np.random.default_rng(seed).permutation(len(points))
    new_index = np.argsort(order)
    return points[order], new_index[cells], [u[order] for u in values]


def in_memory(V, ref, cand):
    owned = [u.ravel() for u in ref], [u.ravel() for u in cand]
    return Metrics(V).history(*owned)


def read_csv(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    return rows[0], rows[1:]


def assert_same_curves(out, expected, algorithm):
    header, rows = read_csv(out / "metrics.csv")
    assert tuple(header) == COLUMNS
    assert [r[0] for r in rows] == [algorithm] * len(TIMES)
    assert [int(r[1]) for r in rows] == list(range(len(TIMES)))
    assert np.allclose([float(r[2]) for r in rows], TIMES, rtol=1e-15)
    assert COLUMNS[3:-1] == NAMES and COLUMNS[-1] == "status"
    for j, name in enumerate(NAMES, start=3):
        got = np.array([float(r[j]) for r in rows])
        np.testing.assert_allclose(got, expected[name], rtol=1e-12, atol=1e-15, err_msg=name)
    assert [r[-1] for r in rows] == ["ok"] * len(TIMES)
    assert np.isnan(float(rows[0][3]))  # E_n at step 0: the reference is zero there
    assert (out / "metrics.png").stat().st_size > 0
    assert sorted(p.name for p in out.iterdir()) == [
        ".tissuebench.json",  # the manifest: the folder is ours (workflows/io/output.py)
        "metrics.csv",
        "metrics.png",
        "summary.json",
    ]


@pytest.mark.parametrize("dim", [2, 3])
def test_meshio_series_give_the_in_memory_curves(tmp_path, dim):
    V = make_space(dim)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref)
    p, c, values = shuffled(points, cells, cand)
    write_meshio_xdmf(tmp_path / "explicit.xdmf", p, c, cell_type, values)
    series = read_series(tmp_path / "explicit.xdmf")
    assert series.dim == dim and series.points.shape == (len(points), dim)

    summary = compare(tmp_path / "reference.xdmf", tmp_path / "explicit.xdmf", tmp_path / "out")
    assert_same_curves(tmp_path / "out", in_memory(V, ref, cand), "explicit")
    assert set(summary) == set(NAMES)  # no divergence line for finite series
    assert all(
        "max" in line and "time-mean" in line and "\n" not in line for line in summary.values()
    )


def test_dolfinx_xdmf_against_pvd(tmp_path):
    """The reference as DOLFINx's XDMFFile writes it (mesh once, one function per time), the
    candidate as a ParaView .pvd of .vtu files with shuffled nodes."""
    V = make_space(2)
    ref, cand = fields(V)
    u = fem.Function(V, name="displacement")
    with io.XDMFFile(MPI.COMM_SELF, tmp_path / "implicit.xdmf", "w") as f:
        f.write_mesh(V.mesh)
        for t, values in zip(TIMES, ref, strict=True):
            u.x.array[:] = values.ravel()
            f.write_function(u, t)
    points, cells, cell_type = mesh_data(V)
    p, c, values = shuffled(points, cells, cand)
    write_pvd(tmp_path / "sofa.pvd", p, c, cell_type, values)

    compare(tmp_path / "implicit.xdmf", tmp_path / "sofa.pvd", tmp_path / "out")
    assert_same_curves(tmp_path / "out", in_memory(V, ref, cand), "sofa")


def test_field_name_option(tmp_path):
    V = make_space(2)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "a.xdmf", points, cells, cell_type, ref, field="u")
    write_pvd(tmp_path / "b.pvd", points, cells, cell_type, cand, field="u")
    compare(tmp_path / "a.xdmf", tmp_path / "b.pvd", tmp_path / "out", field="u")
    assert_same_curves(tmp_path / "out", in_memory(V, ref, cand), "b")


@pytest.fixture
def reference(tmp_path):
    V = make_space(2)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref)
    return tmp_path / "reference.xdmf", (points, cells, cell_type, cand)


def refused(ref, cand, out, match, field="displacement"):
    with pytest.raises(InputError, match=match) as info:
        compare(ref, cand, out, field=field)
    message = str(info.value)
    assert "\n" not in message
    assert not (out / "metrics.csv").exists() and not (out / "metrics.png").exists()
    return message


def test_other_meshes_of_the_body_are_graded_others_refused(tmp_path, reference):
    """SPEC 9: a candidate on another mesh of the same body is graded (and says so); a
    candidate on a larger body, or whose own mesh is broken, is refused in one line."""
    ref, (points, cells, cell_type, cand) = reference
    larger = points * 1.1  # the same mesh of a body 10 % larger
    write_meshio_xdmf(tmp_path / "larger.xdmf", larger, cells, cell_type, cand)
    message = refused(ref, tmp_path / "larger.xdmf", tmp_path / "out", "not a mesh of the body")
    assert "larger.xdmf" in message and "candidate node" in message

    coarse = fem.functionspace(
        dmesh.create_unit_square(MPI.COMM_SELF, 2, 2, dmesh.CellType.quadrilateral),
        ("Lagrange", 1, (2,)),
    )
    p, c, t = mesh_data(coarse)  # the unit square, as the reference's 4 x 3 grid
    write_meshio_xdmf(tmp_path / "coarse.xdmf", p, c, t, [np.zeros((len(p), 2))] * len(TIMES))
    lines = compare(ref, tmp_path / "coarse.xdmf", tmp_path / "coarse")
    assert "candidate on its own mesh: 9 nodes" in lines["note 1"]

    rewired = cells.copy()
    rewired[0, 3] = cells[-1, 2]  # a node of another cell: the candidate's mesh is broken
    write_meshio_xdmf(tmp_path / "cells.xdmf", points, rewired, cell_type, cand)
    assert refused(ref, tmp_path / "cells.xdmf", tmp_path / "out", "touches itself").startswith(
        f"{tmp_path / 'cells.xdmf'}:"
    )


def test_refuses_mismatched_times(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(
        tmp_path / "late.xdmf", points, cells, cell_type, cand, times=[0.0, 0.1, 0.25, 0.3]
    )
    message = refused(ref, tmp_path / "late.xdmf", tmp_path / "out", "time stamps do not match")
    assert "step 2" in message
    write_meshio_xdmf(
        tmp_path / "long.xdmf", points, cells, cell_type, cand + cand[:1], times=TIMES + [0.4]
    )
    refused(ref, tmp_path / "long.xdmf", tmp_path / "out", "more than")


def test_shorter_candidate_is_a_stopped_run(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(
        tmp_path / "stopped.xdmf", points, cells, cell_type, cand[:2], times=TIMES[:2]
    )
    compare(ref, tmp_path / "stopped.xdmf", tmp_path / "out")
    _, rows = read_csv(tmp_path / "out" / "metrics.csv")
    assert len(rows) == len(TIMES) and all(np.isnan(float(x)) for r in rows[2:] for x in r[3:-1])
    assert [r[-1] for r in rows] == ["ok", "ok", "missing", "missing"]


def test_refuses_missing_field(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(tmp_path / "named.xdmf", points, cells, cell_type, cand, field="u")
    message = refused(
        ref, tmp_path / "named.xdmf", tmp_path / "out", "no point field 'displacement'"
    )
    assert "named.xdmf" in message and "fields: u" in message
    write_pvd(tmp_path / "named.pvd", points, cells, cell_type, cand, field="U")
    refused(ref, tmp_path / "named.pvd", tmp_path / "out", "fields: U")


def test_refuses_truncated_and_missing_files(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(tmp_path / "cut.xdmf", points, cells, cell_type, cand)
    h5 = tmp_path / "cut.h5"
    h5.write_bytes(h5.read_bytes()[: h5.stat().st_size // 2])
    assert "cut.h5" in refused(ref, tmp_path / "cut.xdmf", tmp_path / "out", "cut.h5")

    xdmf = tmp_path / "cut2.xdmf"
    write_meshio_xdmf(xdmf, points, cells, cell_type, cand)
    xdmf.write_text(xdmf.read_text()[:200])
    refused(ref, xdmf, tmp_path / "out", "not valid XML")

    write_pvd(tmp_path / "cut.pvd", points, cells, cell_type, cand)
    vtu = tmp_path / "cut_002.vtu"
    vtu.write_bytes(vtu.read_bytes()[:300])
    refused(ref, tmp_path / "cut.pvd", tmp_path / "out", "cut_002.vtu")

    refused(ref, tmp_path / "absent.xdmf", tmp_path / "out", "absent.xdmf: no such file")
    refused(tmp_path / "absent.pvd", ref, tmp_path / "out", "absent.pvd: no such file")
    assert not (tmp_path / "out").exists()


def test_refuses_an_output_path_that_is_a_file(tmp_path, reference):
    ref, _ = reference
    (tmp_path / "taken").write_text("")
    with pytest.raises(UserError, match="not a folder"):
        compare(ref, ref, tmp_path / "taken")


def serial_and_two_ranks(reference: Path, candidate: Path) -> tuple[np.ndarray, str]:
    """compare() in serial and under mpiexec -n 2 (tests/mpi_metrics.py), into folders beside
    the candidate; asserts that the two metrics.csv agree to 1e-12 and returns the serial
    values (step, time, metrics) and the parallel metrics.csv."""
    out = candidate.parent
    compare(reference, candidate, out / "serial")
    serial = (out / "serial" / "metrics.csv").read_text()
    parallel = run_script("mpi_metrics.py", reference, candidate, out / "parallel", ranks=2)
    parallel = parallel["compare"]
    tables = [
        np.array([row.split(",")[1:-1] for row in text.strip().splitlines()[1:]], dtype=float)
        for text in (serial, parallel)
    ]
    np.testing.assert_allclose(tables[1], tables[0], rtol=1e-12, atol=1e-15)
    return tables[0], parallel


@pytest.mark.serial
def test_compare_serial_and_two_ranks_agree(tmp_path):
    """compare() under mpiexec -n 2 (mesh read on rank 0 and distributed, nodal values mapped
    through the input indices) writes the serial metrics.csv to 1e-12."""
    V = make_space(3)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref)
    p, c, values = shuffled(points, cells, cand)
    write_pvd(tmp_path / "cand.pvd", p, c, cell_type, values)
    table, parallel = serial_and_two_ranks(tmp_path / "reference.xdmf", tmp_path / "cand.pvd")
    assert all(row.endswith(",ok") for row in parallel.strip().splitlines()[1:])
    assert np.isfinite(table[1:, 2:]).all()


# --- diverged series --------------------------------------------------------------------------

LONG = [0.1 * k for k in range(7)]  # steps 0..6


def table(path):
    """(the numbers of metrics.csv: step, time and the metrics per row; its status column)."""
    _, rows = read_csv(path)
    return np.array([r[1:-1] for r in rows], dtype=float), [r[-1] for r in rows]


@pytest.fixture
def diverging(tmp_path):
    """A 3D reference over LONG, a clean candidate, and the same candidate non-finite from step
    3 on: a NaN in one component of one node at step 3, NaN everywhere at 4, +-inf at 5 and 6."""
    V = make_space(3)
    ref, cand = fields(V, LONG)
    points, cells, cell_type = mesh_data(V)
    bad = [u.copy() for u in cand]
    bad[3][5, 1] = np.nan
    bad[4][:] = np.nan
    bad[5][:] = np.inf
    bad[6][::2] = -np.inf
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref, times=LONG)
    write_meshio_xdmf(tmp_path / "clean.xdmf", points, cells, cell_type, cand, times=LONG)
    p, c, values = shuffled(points, cells, bad)
    write_pvd(tmp_path / "blowup.pvd", p, c, cell_type, values, times=LONG)
    return tmp_path


def test_non_finite_candidate_is_diverged_from_its_first_bad_step(diverging, monkeypatch):
    """Metrics NaN from step 3 on and never evaluated there, the clean candidate's values on
    steps 0..2, status "diverged" from step 3, and a summary line that says so."""
    d = diverging
    clean = compare(d / "reference.xdmf", d / "clean.xdmf", d / "clean")
    evaluated = []
    evaluate = Metrics.evaluate

    def counting(self, u_ref, u_cand):
        evaluated.append(bool(np.isfinite(u_cand).all()))
        return evaluate(self, u_ref, u_cand)

    monkeypatch.setattr(Metrics, "evaluate", counting)
    summary = compare(d / "reference.xdmf", d / "blowup.pvd", d / "blowup")
    assert evaluated == [True] * 3  # steps 0, 1, 2 only

    good, good_status = table(d / "clean" / "metrics.csv")
    bad, status = table(d / "blowup" / "metrics.csv")
    assert good_status == ["ok"] * 7 and status == ["ok"] * 3 + ["diverged"] * 4
    np.testing.assert_array_equal(bad[:, :2], good[:, :2])  # steps and times
    np.testing.assert_allclose(
        bad[:3, 2:], good[:3, 2:], rtol=1e-12, atol=1e-15
    )  # E_n is NaN at step 0 in both
    assert np.isnan(bad[3:, 2:]).all()
    assert np.isfinite(good[1:, 2:]).all() and np.all(np.diff(good[1:, 2]) > 0)  # E_n grows with t

    assert (
        summary["candidate"] == "candidate diverged at step 3 (t = 0.3 s): non-finite displacement"
    )
    assert (
        list(summary)[0] == "candidate" and "reference" not in summary and "candidate" not in clean
    )
    # the summaries grade steps 1..2 only: E_n's max is the clean run's at step 2, below its max
    # at step 6
    peak = float(summary["relative_error"].split("max ")[1].split(",")[0])
    assert peak == pytest.approx(good[2, 2], rel=1e-3) and peak < 0.5 * good[6, 2]
    assert "steps 1..2 of 1..6" in summary["relative_error"]


def test_non_finite_reference_is_diverged(diverging):
    """A reference that goes non-finite at step 3: metrics NaN from 3 on, the clean reference's
    values before, status "reference diverged", one line saying so, no crash."""
    d = diverging
    clean = compare(d / "clean.xdmf", d / "reference.xdmf", d / "clean")
    summary = compare(d / "blowup.pvd", d / "reference.xdmf", d / "blowup")
    good, good_status = table(d / "clean" / "metrics.csv")
    got, status = table(d / "blowup" / "metrics.csv")
    assert good_status == ["ok"] * 7 and status == ["ok"] * 3 + ["reference diverged"] * 4
    np.testing.assert_allclose(got[:3], good[:3], rtol=1e-12, atol=1e-15)
    assert (
        np.isnan(got[3:, 2:]).all() and np.isfinite(got[1:3, 2:]).all() and np.all(got[1:3, 2:] > 0)
    )
    assert (
        summary["reference"] == "reference diverged at step 3 (t = 0.3 s): non-finite displacement"
    )
    assert "candidate" not in summary and "reference" not in clean
    # both diverged: "diverged" (the candidate's) wins from its step on
    summary = compare(d / "blowup.pvd", d / "blowup.pvd", d / "both")
    assert table(d / "both" / "metrics.csv")[1] == ["ok"] * 3 + ["diverged"] * 4
    assert summary["reference"].startswith("reference diverged at step 3")
    assert summary["candidate"].startswith("candidate diverged at step 3")


def test_diverged_candidate_on_the_command_line_serial_and_two_ranks(diverging):
    """The CLI prints the divergence line once and writes the same metrics.csv under
    mpiexec -n 2 as in serial."""
    d = diverging
    runs = {
        n: tissuebench(
            "compare", d / "reference.xdmf", d / "blowup.pvd", "--out", d / f"cli{n}", ranks=n
        )
        for n in (1, 2)
    }
    for n, r in runs.items():
        assert r.returncode == 0, r.stderr[-3000:]
        assert (
            r.stdout.count("candidate diverged at step 3 (t = 0.3 s): non-finite displacement") == 1
        )
        assert r.stdout.splitlines()[0].startswith("candidate diverged")
    (serial, serial_status), (parallel, parallel_status) = (
        table(d / f"cli{n}" / "metrics.csv") for n in (1, 2)
    )
    assert serial_status == parallel_status == ["ok"] * 3 + ["diverged"] * 4
    np.testing.assert_allclose(parallel, serial, rtol=1e-12, atol=1e-15)
    assert np.isnan(serial[3:, 2:]).all() and np.isfinite(serial[1:3, 2:]).all()


# --- meshes that cannot be graded -------------------------------------------------------------

ZERO = [np.zeros((7, 2))] * len(TIMES)


def bowtie(path):
    """Two unit squares that share only the corner (1, 1)."""
    points = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 1], [2, 2], [1, 2]], dtype=float)
    write_meshio_xdmf(path, points, np.array([[0, 1, 2, 3], [2, 4, 5, 6]]), "quad", ZERO)


def flat_strip(path):
    """Three quadrilaterals in a row; the middle one has zero width (its nodes are collinear)."""
    x = np.array([0.0, 1.0, 1.0, 2.0])
    points = np.r_[np.c_[x, 0 * x], np.c_[x, 0 * x + 1]]
    cells = np.array([[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6]])
    write_meshio_xdmf(path, points, cells, "quad", [np.zeros((8, 2))] * len(TIMES))


def repeated_node(path):
    """Two quadrilaterals, the second with a repeated node (a triangle)."""
    points = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [2, 0], [2, 1]], dtype=float)
    write_meshio_xdmf(
        path,
        points,
        np.array([[0, 1, 2, 3], [1, 4, 5, 5]]),
        "quad",
        [np.zeros((6, 2))] * len(TIMES),
    )


@pytest.mark.parametrize(
    "make, problem",
    [
        (bowtie, "touches itself at node 2 at (1, 1)"),
        (flat_strip, "cell 1 (nodes 1 2 6 5) has zero area"),
        (repeated_node, "cell 1 (nodes 1 4 5 5) repeats node 5"),
    ],
)
@pytest.mark.parametrize("ranks", [1, 2])
def test_ungradable_reference_is_refused_on_one_line(tmp_path, make, problem, ranks):
    """Exit 2, one line on stderr naming the file and the problem, no traceback, no --out."""
    make(tmp_path / "ref.xdmf")
    make(tmp_path / "cand.xdmf")
    r = tissuebench(
        "compare",
        tmp_path / "ref.xdmf",
        tmp_path / "cand.xdmf",
        "--out",
        tmp_path / "out",
        ranks=ranks,
    )
    assert r.returncode == 2, r.stderr[-3000:]
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert (
        lines[0].startswith(f"tissuebench compare: error: {tmp_path / 'ref.xdmf'}: ")
        and problem in lines[0]
    )
    assert not (tmp_path / "out").exists() and r.stdout == ""


def hexahedra(path, points, cells):
    write_meshio_xdmf(
        path,
        np.asarray(points, dtype=float),
        np.asarray(cells),
        "hexahedron",
        [np.zeros((len(points), 3))] * len(TIMES),
    )


CUBE = np.array(
    [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
    dtype=float,
)


def test_hexahedral_meshes_that_cannot_be_graded(tmp_path):
    """3D: cubes touching at a corner or along an edge, a flat hexahedron, a repeated node; two
    cubes sharing a face are fine."""
    hexahedra(tmp_path / "corner.xdmf", np.r_[CUBE, CUBE[1:] + 1], [range(8), [6, *range(8, 15)]])
    with pytest.raises(
        InputError, match=r"corner.xdmf: the mesh boundary touches itself at node 6 at \(1, 1, 1\)"
    ):
        read_series(tmp_path / "corner.xdmf")
    edge = np.arange(8, 16)
    edge[[0, 4]] = [2, 6]  # the second cube, moved by (1, 1, 0), shares the edge 2-6 only
    hexahedra(tmp_path / "edge.xdmf", np.r_[CUBE, CUBE + [1, 1, 0]], [range(8), edge])
    with pytest.raises(InputError, match="touches itself at the edge from node 2 at .* to node 6"):
        read_series(tmp_path / "edge.xdmf")
    hexahedra(tmp_path / "flat.xdmf", np.r_[CUBE[:4], CUBE[:4] + [0, 0, 1e-13]], [range(8)])
    with pytest.raises(InputError, match="flat.xdmf: 1 degenerate cell.*has zero volume"):
        read_series(tmp_path / "flat.xdmf")
    hexahedra(tmp_path / "repeat.xdmf", CUBE, [[0, 1, 2, 3, 4, 5, 6, 6]])
    with pytest.raises(InputError, match="repeats node 6"):
        read_series(tmp_path / "repeat.xdmf")
    hexahedra(tmp_path / "pair.xdmf", np.r_[CUBE, CUBE[4:] + [0, 0, 1]], [range(8), range(4, 12)])
    assert read_series(tmp_path / "pair.xdmf").cells.shape == (2, 8)
    hexahedra(
        tmp_path / "thin.xdmf", np.r_[CUBE[:4], CUBE[:4] + [0, 0, 1e-9]], [range(8)]
    )  # thin, not flat
    assert read_series(tmp_path / "thin.xdmf").dim == 3


def test_ungradable_candidate_is_refused_in_the_library(tmp_path, reference):
    """compare() raises one InputError naming the candidate file, nothing written."""
    ref, _ = reference
    bowtie(tmp_path / "bow.xdmf")
    message = refused(ref, tmp_path / "bow.xdmf", tmp_path / "out", "touches itself")
    assert message.startswith(f"{tmp_path / 'bow.xdmf'}:")
    assert not (tmp_path / "out").exists()


# --- other simulators' conventions: fields, time stamps, initial state, label -------------------


def test_fields_per_side_and_common_names(tmp_path):
    """Each side's field by name, or found among displacement, U, DISP, Displacement."""
    V = make_space(2)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "a.xdmf", points, cells, cell_type, ref, field="disp_ref")
    write_pvd(tmp_path / "b.pvd", points, cells, cell_type, cand, field="U")
    expected = in_memory(V, ref, cand)
    compare(tmp_path / "a.xdmf", tmp_path / "b.pvd", tmp_path / "named", reference_field="disp_ref")
    assert_same_curves(tmp_path / "named", expected, "b")
    summary = json.loads((tmp_path / "named" / "summary.json").read_text())
    assert summary["reference"]["field"] == "disp_ref" and summary["candidate"]["field"] == "U"
    write_meshio_xdmf(tmp_path / "c.xdmf", points, cells, cell_type, ref, field="Displacement")
    compare(tmp_path / "c.xdmf", tmp_path / "b.pvd", tmp_path / "common")
    assert_same_curves(tmp_path / "common", expected, "b")

    with pytest.raises(
        InputError,
        match=r"a.xdmf: no point field 'displacement' \(nor U, DISP, Displacement\); fields: "
        r"disp_ref; name the displacement field",
    ):
        compare(tmp_path / "a.xdmf", tmp_path / "b.pvd", tmp_path / "out")
    with pytest.raises(InputError, match="b_000.vtu: no point field 'displacement'; fields: U"):
        compare(
            tmp_path / "c.xdmf",
            tmp_path / "b.pvd",
            tmp_path / "out",
            candidate_field="displacement",
        )


def test_times_match_to_six_printed_digits(tmp_path):
    """300 steps of h = 1/30 s stamped with six significant digits (as CalculiX's .frd) match
    the reference's; a stamp beyond 1e-5 max(t, h) does not: 0.01 h off at t = 5 s, 1e-4 h
    off at t = h."""
    V = make_space(2)
    times = np.arange(301) / 30
    printed = [float(f"{t:.5e}") for t in times]
    relative = np.abs(np.array(printed) - times)[1:] / times[1:]
    assert 1e-6 < relative.max() <= 5e-6  # six digits: beyond 1e-6 relative, within 5e-6
    u = [np.zeros((V.dofmap.index_map.size_local, 2)) + t for t in times]
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, u, times=times)
    write_meshio_xdmf(tmp_path / "six.xdmf", points, cells, cell_type, u, times=printed)
    compare(tmp_path / "ref.xdmf", tmp_path / "six.xdmf", tmp_path / "six")
    for step, offset, tolerance in [(150, 0.01 / 30, "5e-05"), (1, 1e-4 / 30, "3.33e-07")]:
        off = list(times)
        off[step] += offset
        write_meshio_xdmf(tmp_path / "off.xdmf", points, cells, cell_type, u, times=off)
        message = refused(
            tmp_path / "ref.xdmf", tmp_path / "off.xdmf", tmp_path / "out", f"step {step} "
        )
        assert f"(tolerance {tolerance} s)" in message  # 1e-5 max(t, h)


def test_series_from_t_equals_h_starts_from_zero(tmp_path):
    """A candidate without step 0 (it starts at t = h) is graded as if u = 0 at t = 0; a note
    says so; its label and wall time go to summary.json."""
    V = make_space(3)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref)
    write_pvd(tmp_path / "sim.pvd", points, cells, cell_type, cand[1:], times=TIMES[1:])
    lines = compare(
        tmp_path / "ref.xdmf",
        tmp_path / "sim.pvd",
        tmp_path / "out",
        label="my sim",
        wall_time="1.5",
    )
    assert list(lines)[0] == "note 1" and lines["note 1"].startswith(
        "candidate sim.pvd starts at t = 0.1 s = h: taken to start from the SPEC's zero"
    )
    zero = [np.zeros_like(cand[0])] + cand[1:]
    assert_same_curves(tmp_path / "out", in_memory(V, ref, zero), "my sim")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    run = summary["runs"]["my sim"]
    assert run["wall_time_s"] == 1.5 and run["status"] == "ok" and run["steps"] == 3
    assert summary["kind"] == "compare" and summary["notes"] == [lines["note 1"]]
    for name in NAMES:
        assert run[f"{name}_max"] == pytest.approx(np.nanmax(in_memory(V, ref, zero)[name][1:]))
    for bad, message in [({"label": ""}, "--label"), ({"wall_time": "inf"}, "--wall-time")]:
        with pytest.raises(UserError, match=message):
            compare(tmp_path / "ref.xdmf", tmp_path / "sim.pvd", tmp_path / "bad", **bad)
    assert not (tmp_path / "bad").exists()
