"""compare(): two displacement series read from files give the curves of the in-memory path,
and bad input is refused with one line and nothing written."""

import contextlib
import csv
from pathlib import Path

from mpi4py import MPI

import meshio
import numpy as np
import pytest
from dolfinx import fem, io, mesh as dmesh
from dolfinx.io.utils import cell_perm_vtk

from helpers import run_script
from tissuebench.metrics import InputError, Metrics, compare, read_series
from tissuebench.metrics.compare import COLUMNS

TIMES = [0.0, 0.1, 0.2, 0.3]


def make_space(dim):
    if dim == 2:
        mesh = dmesh.create_unit_square(MPI.COMM_SELF, 4, 3, dmesh.CellType.quadrilateral)
    else:
        mesh = dmesh.create_box(MPI.COMM_SELF, [[0, 0, 0], [0.5, 0.25, 0.25]], [4, 2, 2], dmesh.CellType.hexahedron)
    return fem.functionspace(mesh, ("Lagrange", 1, (dim,)))


def fields(V):
    """Reference and candidate histories as (n, d) nodal arrays of the serial space V."""
    dim = V.mesh.geometry.dim
    X = V.tabulate_dof_coordinates()
    ref = [t * np.c_[0.3 * X[:, 1] * X[:, 0], -0.2 * X[:, 0] ** 2, 0.1 * X[:, 2]][:, :dim] for t in TIMES]
    cand = [u * (1 + 0.3 * t) + t**2 * 0.01 * np.sin(3 * X[:, :dim]) for t, u in zip(TIMES, ref)]
    return ref, cand


def mesh_data(V):
    """Points (with a zero third coordinate in 2D) and VTK-ordered cells of serial V."""
    cell_type = V.mesh.topology.cell_type
    cells = V.dofmap.list[:, np.argsort(cell_perm_vtk(cell_type, V.dofmap.list.shape[1]))]
    return V.tabulate_dof_coordinates(), cells, "quad" if cell_type == dmesh.CellType.quadrilateral else "hexahedron"


def pad(u):
    return np.c_[u, np.zeros((len(u), 3 - u.shape[1]))]


def write_meshio_xdmf(path, points, cells, cell_type, values, times=TIMES, field="displacement"):
    # meshio's TimeSeriesWriter puts the .h5 in the working directory, not beside the .xdmf.
    with contextlib.chdir(Path(path).parent), meshio.xdmf.TimeSeriesWriter(Path(path).name) as writer:
        writer.write_points_cells(points, [(cell_type, cells)])
        for t, u in zip(times, values):
            writer.write_data(t, point_data={field: pad(u)})


def write_pvd(path, points, cells, cell_type, values, times=TIMES, field="displacement"):
    path = Path(path)
    entries = []
    for k, (t, u) in enumerate(zip(times, values)):
        vtu = path.with_name(f"{path.stem}_{k:03d}.vtu")
        meshio.write(vtu, meshio.Mesh(points, [(cell_type, cells)], point_data={field: pad(u)}))
        entries.append(f'    <DataSet timestep="{t!r}" part="0" file="{vtu.name}"/>')
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                    + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n")


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
    for j, name in enumerate(COLUMNS[3:], start=3):
        got = np.array([float(r[j]) for r in rows])
        np.testing.assert_allclose(got, expected[name], rtol=1e-12, atol=1e-15, err_msg=name)
    assert np.isnan(float(rows[0][3]))  # E_n at step 0: the reference is zero there
    assert (out / "metrics.png").stat().st_size > 0
    assert sorted(p.name for p in out.iterdir()) == ["metrics.csv", "metrics.png"]


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
    assert set(summary) == set(COLUMNS[3:])
    assert all("max" in line and "time-mean" in line and "\n" not in line for line in summary.values())


def test_dolfinx_xdmf_against_pvd(tmp_path):
    """The reference as DOLFINx's XDMFFile writes it (mesh once, one function per time), the
    candidate as a ParaView .pvd of .vtu files with shuffled nodes."""
    V = make_space(2)
    ref, cand = fields(V)
    u = fem.Function(V, name="displacement")
    with io.XDMFFile(MPI.COMM_SELF, tmp_path / "implicit.xdmf", "w") as f:
        f.write_mesh(V.mesh)
        for t, values in zip(TIMES, ref):
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


def test_refuses_different_meshes(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    moved = points.copy()
    moved[7, 1] += 0.01
    write_meshio_xdmf(tmp_path / "moved.xdmf", moved, cells, cell_type, cand)
    message = refused(ref, tmp_path / "moved.xdmf", tmp_path / "out", "mesh differs")
    assert "moved.xdmf" in message and "no candidate node" in message

    coarse = fem.functionspace(dmesh.create_unit_square(MPI.COMM_SELF, 2, 2, dmesh.CellType.quadrilateral),
                               ("Lagrange", 1, (2,)))
    p, c, t = mesh_data(coarse)
    write_meshio_xdmf(tmp_path / "coarse.xdmf", p, c, t, [np.zeros((len(p), 2))] * len(TIMES))
    refused(ref, tmp_path / "coarse.xdmf", tmp_path / "out", "9 nodes")

    rewired = cells.copy()
    rewired[0, 3] = cells[-1, 2]  # a node of another cell
    write_meshio_xdmf(tmp_path / "cells.xdmf", points, rewired, cell_type, cand)
    refused(ref, tmp_path / "cells.xdmf", tmp_path / "out", "different cells")


def test_refuses_mismatched_times(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(tmp_path / "late.xdmf", points, cells, cell_type, cand, times=[0.0, 0.1, 0.25, 0.3])
    message = refused(ref, tmp_path / "late.xdmf", tmp_path / "out", "time stamps do not match")
    assert "step 2" in message
    write_meshio_xdmf(tmp_path / "long.xdmf", points, cells, cell_type, cand + cand[:1], times=TIMES + [0.4])
    refused(ref, tmp_path / "long.xdmf", tmp_path / "out", "more than")


def test_shorter_candidate_is_a_stopped_run(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(tmp_path / "stopped.xdmf", points, cells, cell_type, cand[:2], times=TIMES[:2])
    compare(ref, tmp_path / "stopped.xdmf", tmp_path / "out")
    _, rows = read_csv(tmp_path / "out" / "metrics.csv")
    assert len(rows) == len(TIMES) and all(np.isnan(float(x)) for r in rows[2:] for x in r[3:])


def test_refuses_missing_field(tmp_path, reference):
    ref, (points, cells, cell_type, cand) = reference
    write_meshio_xdmf(tmp_path / "named.xdmf", points, cells, cell_type, cand, field="u")
    message = refused(ref, tmp_path / "named.xdmf", tmp_path / "out", "no point field 'displacement'")
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
    with pytest.raises(InputError, match="not a directory"):
        compare(ref, ref, tmp_path / "taken")


def test_compare_serial_and_two_ranks_agree(tmp_path):
    """compare() under mpiexec -n 2 (mesh read on rank 0 and distributed, nodal values mapped
    through the input indices) writes the serial metrics.csv to 1e-12."""
    V = make_space(3)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref)
    p, c, values = shuffled(points, cells, cand)
    write_pvd(tmp_path / "cand.pvd", p, c, cell_type, values)
    compare(tmp_path / "reference.xdmf", tmp_path / "cand.pvd", tmp_path / "serial")
    serial = (tmp_path / "serial" / "metrics.csv").read_text()
    parallel = run_script("mpi_metrics.py", tmp_path / "reference.xdmf", tmp_path / "cand.pvd", tmp_path / "parallel",
                                 ranks=2)["compare"]
    tables = [np.array([row.split(",")[1:] for row in text.strip().splitlines()[1:]], dtype=float)
              for text in (serial, parallel)]
    np.testing.assert_allclose(tables[1], tables[0], rtol=1e-12, atol=1e-15)
    assert np.isfinite(tables[0][1:, 2:]).all()
