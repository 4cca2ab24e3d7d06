"""compare's numbers (issue 23, item 5): complex fields are refused; non-finite values, in any
component of any dimension, and displacements beyond 100 times the domain's extent (SPEC
section 3) are a divergence from that step, never "ok" with an inf metric; a series whose
steps move or renumber their nodes is refused.

The library tests are collective (files written by rank 0, a divergence seen on every rank)
and marked parallel: `make test` runs them also with `mpiexec -n 2 pytest -m parallel`; the
command-line tests run compare serially and under mpiexec -n 2."""

import shutil
from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from helpers import tissuebench
from test_compare import fields, make_space, mesh_data, shuffled, write_meshio_xdmf, write_pvd

from tissuebench.metrics import InputError, Metrics
from tissuebench.workflows.compare.grading import grade

COMM = MPI.COMM_WORLD
TIMES = [0.0, 0.1, 0.2, 0.3, 0.4]
TOPOLOGY = {"quad": "Quadrilateral", "hexahedron": "Hexahedron"}


def on_rank_0(write):
    """Run write() on rank 0 only (the files are shared), then let every rank go on."""
    if COMM.rank == 0:
        write()
    COMM.barrier()


def series(dim):
    """Points, VTK cells, cell type, reference and candidate histories over TIMES, and the
    domain's largest extent."""
    V = make_space(dim)
    ref, cand = fields(V, TIMES)
    points, cells, cell_type = mesh_data(V)
    return points, cells, cell_type, ref, cand, float(np.ptp(points, axis=0).max())


def write_xdmf(path, points, cells, cell_type, values, times=TIMES, step_points=None, dtype=None):
    """An XDMF time series with HDF5 data in which every step grid holds its own Geometry and
    Topology (as ParaView writes them), the points of step k being step_points[k] (default:
    `points`) and the field stored with `dtype` (default float64)."""
    path = Path(path)
    h5 = path.with_suffix(".h5")
    step_points = step_points or [points] * len(times)
    grids = []
    with h5py.File(h5, "w") as f:
        f["topology"] = cells
        for k, (t, u, x) in enumerate(zip(times, values, step_points, strict=False)):
            f[f"geometry{k}"] = x
            f[f"u{k}"] = np.asarray(u, dtype=dtype or np.float64)
            n, width = x.shape
            grids.append(
                f'<Grid Name="step{k}" GridType="Uniform"><Time Value="{t!r}"/>'
                f'<Topology TopologyType="{TOPOLOGY[cell_type]}" NumberOfElements="{len(cells)}">'
                f'<DataItem Dimensions="{len(cells)} {cells.shape[1]}" NumberType="Int" '
                f'Format="HDF">{h5.name}:/topology</DataItem></Topology>'
                f'<Geometry GeometryType="{"XYZ" if width == 3 else "XY"}">'
                f'<DataItem Dimensions="{n} {width}" Format="HDF">{h5.name}:/geometry{k}'
                f"</DataItem></Geometry>"
                f'<Attribute Name="displacement" AttributeType="Vector" Center="Node">'
                f'<DataItem Dimensions="{n} {np.shape(u)[1]}" Format="HDF">{h5.name}:/u{k}'
                f"</DataItem></Attribute></Grid>"
            )
    path.write_text(
        '<?xml version="1.0"?>\n<Xdmf Version="3.0"><Domain>'
        '<Grid Name="series" GridType="Collection" CollectionType="Temporal">'
        + "".join(grids)
        + "</Grid></Domain></Xdmf>\n"
    )


def one_line_error(result, status=2):
    """The command failed with `status` and exactly one line on stderr, no traceback."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == status, (result.returncode, result.stderr[-2000:])
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr[-2000:]
    return lines[0]


def assert_never_ok_with_inf(g):
    """No metric of any step is +-inf, and every step graded "ok" has finite metrics (E_n
    aside at step 0, where the reference is zero)."""
    for name, curve in g.curves.items():
        assert not np.isinf(curve).any(), name
        ok = [i for i, s in enumerate(g.status) if s == "ok" and i > 0]
        assert np.isfinite(curve[ok]).all(), name


# --- complex fields ----------------------------------------------------------------------------


@pytest.mark.parallel
@pytest.mark.parametrize("imaginary", [1.0, 0.0])
def test_complex_field_is_refused(tmp_path, imaginary):
    """A complex-valued field is refused in one line, even with a zero imaginary part, never
    graded on its real part; the same series stored as real numbers is graded."""
    points, cells, cell_type, ref, cand, _ = series(2)
    complex_values = [u + 1j * imaginary * u for u in cand]

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_xdmf(tmp_path / "real.xdmf", points, cells, cell_type, cand)
        write_xdmf(tmp_path / "cx.xdmf", points, cells, cell_type, complex_values, dtype=complex)

    on_rank_0(write)
    assert grade(tmp_path / "ref.xdmf", tmp_path / "real.xdmf", comm=COMM).status == ["ok"] * 5
    for reference, candidate in [("ref", "cx"), ("cx", "ref")]:
        with pytest.raises(InputError) as info:
            grade(tmp_path / f"{reference}.xdmf", tmp_path / f"{candidate}.xdmf", comm=COMM)
        assert str(info.value) == (
            f"{tmp_path / 'cx.xdmf'}: field 'displacement' at time 0 is complex-valued "
            "(complex128); only real values can be graded"
        )


# --- values beyond the divergence bound --------------------------------------------------------


@pytest.mark.parallel
@pytest.mark.parametrize("dim", [2, 3])
def test_huge_values_are_a_divergence_from_their_step(tmp_path, dim):
    """A candidate at 1e300 from step 2 (its norms overflow to inf) has diverged there: status
    "diverged" from step 2, the reason in the summary and in Grading, the metrics NaN from step
    2 on and the clean candidate's before, never inf. The same for a reference."""
    points, cells, cell_type, ref, cand, extent = series(dim)
    huge = [u if k < 2 else np.full_like(u, 1e300) for k, u in enumerate(cand)]

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_pvd(tmp_path / "clean.pvd", points, cells, cell_type, cand, times=TIMES)
        write_pvd(tmp_path / "huge.pvd", points, cells, cell_type, huge, times=TIMES)

    on_rank_0(write)
    clean = grade(tmp_path / "ref.xdmf", tmp_path / "clean.pvd", comm=COMM)
    g = grade(tmp_path / "ref.xdmf", tmp_path / "huge.pvd", comm=COMM)
    assert clean.status == ["ok"] * 5 and clean.candidate_reason is None
    assert g.status == ["ok"] * 2 + ["diverged"] * 3 and g.candidate_diverged == 2
    magnitude = 1e300 * np.sqrt(dim)
    reason = (
        f"largest nodal displacement {magnitude:.3g} exceeds 100 x the domain's largest "
        f"extent ({extent:.3g})"
    )
    assert g.candidate_reason == reason and g.reference_reason is None
    assert g.summaries["candidate"] == f"candidate diverged at step 2 (t = 0.2 s): {reason}"
    assert_never_ok_with_inf(g)
    for name, curve in g.curves.items():
        np.testing.assert_allclose(curve[:2], clean.curves[name][:2], rtol=1e-12, atol=1e-15)
        assert np.isnan(curve[2:]).all()
        assert "inf" not in g.summaries[name]

    # the reference at 1e300: "reference diverged" from step 2, with the reason
    r = grade(tmp_path / "huge.pvd", tmp_path / "ref.xdmf", comm=COMM)
    assert r.status == ["ok"] * 2 + ["reference diverged"] * 3 and r.reference_reason == reason
    assert r.summaries["reference"] == f"reference diverged at step 2 (t = 0.2 s): {reason}"
    assert_never_ok_with_inf(r)


@pytest.mark.parallel
def test_the_bound_is_100_times_the_extent(tmp_path):
    """One node moved by 99 times the domain's largest extent is graded (finite metrics, "ok");
    by 101 times, the step has diverged (SPEC section 3), with the magnitude in the reason."""
    points, cells, cell_type, ref, cand, extent = series(3)

    def moved(factor):
        values = [u.copy() for u in cand]
        values[3][7] = [0.0, factor * extent, 0.0]
        return values

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        for factor in (99, 101):
            write_pvd(tmp_path / f"x{factor}.pvd", points, cells, cell_type, moved(factor), TIMES)

    on_rank_0(write)
    below = grade(tmp_path / "ref.xdmf", tmp_path / "x99.pvd", comm=COMM)
    beyond = grade(tmp_path / "ref.xdmf", tmp_path / "x101.pvd", comm=COMM)
    assert below.status == ["ok"] * 5 and below.candidate_reason is None
    assert_never_ok_with_inf(below)
    assert below.curves["relative_error"][3] > 10  # graded, far off
    assert beyond.status == ["ok"] * 3 + ["diverged"] * 2
    assert beyond.candidate_reason == (
        f"largest nodal displacement {101 * extent:.3g} exceeds 100 x the domain's largest "
        f"extent ({extent:.3g})"
    )
    for name in below.curves:
        np.testing.assert_array_equal(beyond.curves[name][:3], below.curves[name][:3])


@pytest.mark.parallel
def test_a_collapsed_reference_gives_no_infinite_surface_error():
    """A reference domain shrunk to a point (within the bound, so graded) has zero area or
    volume: E_s is NaN there, as E_n is where the reference is zero, never inf."""
    for dim in (2, 3):
        V = make_space(dim)
        X = V.tabulate_dof_coordinates()[:, :dim]
        values = Metrics(V).evaluate((-X).ravel(), (0.01 * X).ravel())
        assert np.isnan(values["surface_error"])
        assert all(np.isfinite(v) for k, v in values.items() if k != "surface_error")


@pytest.mark.parallel
def test_coordinates_the_metrics_cannot_hold_are_refused(tmp_path):
    """A mesh whose coordinates reach 1e60 (its volumes would overflow) is refused in one line."""
    points, cells, cell_type, ref, cand, _ = series(2)
    on_rank_0(lambda: write_pvd(tmp_path / "far.pvd", points * 1e60, cells, cell_type, ref, TIMES))
    with pytest.raises(InputError, match=r"far.pvd: point coordinates reach 1e\+60 and span"):
        grade(tmp_path / "far.pvd", tmp_path / "far.pvd", comm=COMM)


# --- NaN in any component ---------------------------------------------------------------------


@pytest.mark.parallel
@pytest.mark.parametrize("where", ["all", "third", "inf-third", "one-3d"])
def test_nan_in_any_component_is_a_divergence(tmp_path, where):
    """A candidate stored with three components per node: NaN in all of them at step 3 (a 2D
    run that blew up), NaN or inf in the third component of one 2D node, or NaN in one
    component of one 3D node: diverged from step 3, not refused."""
    dim = 3 if where == "one-3d" else 2
    points, cells, cell_type, ref, cand, _ = series(dim)
    stored = [np.c_[u, np.zeros((len(u), 3 - dim))] for u in cand]
    bad = stored[3]
    if where == "all":
        bad[:] = np.nan
    elif where == "third":
        bad[4, 2] = np.nan
    elif where == "inf-third":
        bad[4, 2] = -np.inf
    else:
        bad[4, 1] = np.nan

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_pvd(tmp_path / "cand.pvd", points, cells, cell_type, stored, times=TIMES)

    on_rank_0(write)
    g = grade(tmp_path / "ref.xdmf", tmp_path / "cand.pvd", comm=COMM)
    assert g.status == ["ok"] * 3 + ["diverged"] * 2
    assert g.summaries["candidate"] == (
        "candidate diverged at step 3 (t = 0.3 s): non-finite displacement"
    )
    assert g.candidate_reason == "non-finite displacement"
    assert_never_ok_with_inf(g)


@pytest.mark.parallel
def test_a_finite_non_zero_third_component_of_2d_data_is_still_refused(tmp_path):
    points, cells, cell_type, ref, cand, _ = series(2)
    stored = [np.c_[u, np.zeros(len(u))] for u in cand]
    stored[2][4, 2] = 1e-3
    on_rank_0(lambda: write_pvd(tmp_path / "cand.pvd", points, cells, cell_type, stored, TIMES))
    with pytest.raises(InputError, match="at time 0.2 has a non-zero third component$"):
        grade(tmp_path / "cand.pvd", tmp_path / "cand.pvd", comm=COMM)


# --- node order --------------------------------------------------------------------------------


@pytest.mark.parallel
def test_a_pvd_series_that_renumbers_its_nodes_is_refused(tmp_path):
    """Steps 2..4 of a PVD series written with the nodes in another order (the same mesh): the
    series is refused in one line naming the step's file and a node that moved; a series
    renumbered the same way at every step is graded as the one in order."""
    points, cells, cell_type, ref, cand, _ = series(2)
    p, c, renumbered = shuffled(points, cells, cand)

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_pvd(tmp_path / "inorder.pvd", points, cells, cell_type, cand, times=TIMES)
        write_pvd(tmp_path / "renumbered.pvd", p, c, cell_type, renumbered, times=TIMES)
        mixed = tmp_path / "mixed"
        mixed.mkdir()
        for k in range(len(TIMES)):
            source = "inorder" if k < 2 else "renumbered"
            shutil.copy(tmp_path / f"{source}_{k:03d}.vtu", mixed / f"mixed_{k:03d}.vtu")
        shutil.copy(tmp_path / "inorder.pvd", mixed / "mixed.pvd")
        text = (mixed / "mixed.pvd").read_text().replace("inorder_", "mixed_")
        (mixed / "mixed.pvd").write_text(text)

    on_rank_0(write)
    in_order = grade(tmp_path / "ref.xdmf", tmp_path / "inorder.pvd", comm=COMM)
    consistent = grade(tmp_path / "ref.xdmf", tmp_path / "renumbered.pvd", comm=COMM)
    for name, curve in in_order.curves.items():
        np.testing.assert_allclose(consistent.curves[name], curve, rtol=1e-12, atol=1e-15)
    mixed = tmp_path / "mixed" / "mixed.pvd"
    with pytest.raises(InputError) as info:
        grade(tmp_path / "ref.xdmf", mixed, comm=COMM)
    message = str(info.value)
    assert message.startswith(f"{tmp_path / 'mixed' / 'mixed_002.vtu'} (step 2 of mixed.pvd): ")
    assert "moved or numbered otherwise" in message and "\n" not in message


@pytest.mark.parallel
def test_an_xdmf_series_whose_steps_change_their_nodes_is_refused(tmp_path):
    """XDMF steps that each hold their own geometry: the same points at every step are graded
    as meshio's series (one mesh for all steps); renumbered or moved points (the deformed
    coordinates) at a later step are refused in one line."""
    points, cells, cell_type, ref, cand, _ = series(2)
    order = np.r_[1, 0, 2 : len(points)]  # nodes 0 and 1 swapped
    renumbered = [points] * 3 + [points[order]] * 2
    deformed = [points + np.c_[u, np.zeros(len(u))] for u in cand]

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_meshio_xdmf(tmp_path / "meshio.xdmf", points, cells, cell_type, cand, times=TIMES)
        write_xdmf(tmp_path / "own.xdmf", points, cells, cell_type, cand)
        write_xdmf(tmp_path / "ren.xdmf", points, cells, cell_type, cand, step_points=renumbered)
        write_xdmf(tmp_path / "def.xdmf", points, cells, cell_type, cand, step_points=deformed)

    on_rank_0(write)
    expected = grade(tmp_path / "ref.xdmf", tmp_path / "meshio.xdmf", comm=COMM)
    own = grade(tmp_path / "ref.xdmf", tmp_path / "own.xdmf", comm=COMM)
    for name, curve in expected.curves.items():
        np.testing.assert_array_equal(own.curves[name], curve)
    for name, step in (("ren", 3), ("def", 1)):
        with pytest.raises(InputError) as info:
            grade(tmp_path / "ref.xdmf", tmp_path / f"{name}.xdmf", comm=COMM)
        message = str(info.value)
        assert message.startswith(
            f"{tmp_path / name}.xdmf (step {step}, t = {TIMES[step]:g}): node"
        )
        assert "moved or numbered otherwise" in message


@pytest.mark.parallel
def test_a_nameless_xdmf_attribute_is_left_out(tmp_path):
    """An Attribute without a Name beside the named field is left out (no name asked for can
    match it), not a failure to read the file (sorting the names with None among them was a
    TypeError)."""
    points, cells, cell_type, ref, cand, _ = series(2)

    def write():
        write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
        write_xdmf(tmp_path / "own.xdmf", points, cells, cell_type, cand)
        text = (tmp_path / "own.xdmf").read_text()
        nameless = '<Attribute AttributeType="Scalar" Center="Node"></Attribute></Grid>'
        (tmp_path / "nameless.xdmf").write_text(text.replace("</Grid>", nameless, 1))  # own.h5

    on_rank_0(write)
    assert "<Attribute AttributeType" in (tmp_path / "nameless.xdmf").read_text()
    own = grade(tmp_path / "ref.xdmf", tmp_path / "own.xdmf", comm=COMM)
    nameless = grade(tmp_path / "ref.xdmf", tmp_path / "nameless.xdmf", comm=COMM)
    for name, curve in own.curves.items():
        np.testing.assert_array_equal(nameless.curves[name], curve)


# --- the command line, serial and under mpiexec -n 2 -------------------------------------------


@pytest.mark.serial
def test_command_line_serial_and_two_ranks(tmp_path):
    """Serial and under mpiexec -n 2: a 2D candidate that turns NaN at step 3 (all three stored
    components) is graded as diverged from there with the same metrics.csv and one divergence
    line; a complex candidate and a renumbered series exit 2 with one line."""
    points, cells, cell_type, ref, cand, _ = series(2)
    stored = [np.c_[u, np.zeros(len(u))] for u in cand]
    stored[3][:] = stored[4][:] = np.nan
    write_meshio_xdmf(tmp_path / "ref.xdmf", points, cells, cell_type, ref, times=TIMES)
    write_pvd(tmp_path / "nan.pvd", points, cells, cell_type, stored, times=TIMES)
    write_xdmf(tmp_path / "cx.xdmf", points, cells, cell_type, cand, dtype=complex)
    write_xdmf(
        tmp_path / "ren.xdmf",
        points,
        cells,
        cell_type,
        cand,
        step_points=[points] * 3 + [points[::-1]] * 2,
    )
    tables = []
    for ranks in (1, 2):
        out = tmp_path / f"out{ranks}"
        r = tissuebench(
            "compare", tmp_path / "ref.xdmf", tmp_path / "nan.pvd", "--out", out, ranks=ranks
        )
        assert r.returncode == 0, r.stderr[-3000:]
        line = "candidate diverged at step 3 (t = 0.3 s): non-finite displacement"
        assert r.stdout.count(line) == 1 and "inf" not in r.stdout, r.stdout
        rows = (out / "metrics.csv").read_text().splitlines()[1:]
        assert [row.split(",")[-1] for row in rows] == ["ok"] * 3 + ["diverged"] * 2
        tables.append(np.array([row.split(",")[1:-1] for row in rows], dtype=float))
    np.testing.assert_allclose(tables[1], tables[0], rtol=1e-12, atol=1e-15)
    assert np.isfinite(tables[0][1:3, 2:]).all() and np.isnan(tables[0][3:, 2:]).all()

    for ranks in (1, 2):
        for name, expected in [("cx", "is complex-valued"), ("ren", "moved or numbered otherwise")]:
            out = tmp_path / f"refused-{name}-{ranks}"
            r = tissuebench(
                "compare",
                tmp_path / "ref.xdmf",
                tmp_path / f"{name}.xdmf",
                "--out",
                out,
                ranks=ranks,
            )
            assert expected in one_line_error(r, 2)
            assert not out.exists()
