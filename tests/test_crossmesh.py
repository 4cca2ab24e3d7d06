"""Grading a candidate on its own mesh (SPEC section 9): the checks that hold on any mesh of
the reference's body, the refusal of another body, simplices read from files, and the
reference's own mesh graded exactly as before.

The in-memory tests (grade_series) are collective; those about the ranks (the farthest node
named, the nodes in another order) are marked parallel and run again under mpiexec -n 2; the
tests that write files run in serial only, one of them checking serial against 2 ranks."""

import json
import subprocess
from pathlib import Path

from mpi4py import MPI

import meshio
import numpy as np
import pytest
from helpers import HERE, job
from test_compare import (
    fields,
    make_space,
    mesh_data,
    serial_and_two_ranks,
    shuffled,
    write_meshio_xdmf,
)

from tissuebench.metrics import InputError, Metrics
from tissuebench.metrics.compare import function_space, grade_series
from tissuebench.metrics.series import Series
from tissuebench.workflows.compare.grading import compare, grade
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.io.xdmf import write_series

TIMES = np.array([0.0, 0.1, 0.2])
SQUARE = (1.0, 0.5)  # m, the 2D body
ROD = (0.5, 0.25, 0.25)  # m, the 3D body (the rod of SPEC 5)
# VTK corner offsets of a quadrilateral and a hexahedron in a structured grid
CORNERS = {
    2: [(0, 0), (1, 0), (1, 1), (0, 1)],
    3: [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)],
}
TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])  # a VTK quadrilateral as two triangles
TETRAHEDRA = np.array(  # a VTK hexahedron as six tetrahedra around its diagonal 0-6
    [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
)
# The last commit before the cross-mesh grading that changed metrics/: the old code path.
BEFORE = "2b580caf997870012b026f6f67ac1d07c95206d9"


def grid(counts, lengths):
    """A structured Q1 mesh of the box [0, lengths]: (points (N, d), cells in VTK order,
    cell type)."""
    d = len(counts)
    axes = [np.linspace(0.0, L, n + 1) for n, L in zip(counts, lengths, strict=True)]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, d)
    index = np.arange(len(points)).reshape([n + 1 for n in counts])
    first = np.stack(np.meshgrid(*[np.arange(n) for n in counts], indexing="ij"), -1)
    first = first.reshape(-1, d)
    cells = np.stack([index[tuple((first + c).T)] for c in CORNERS[d]], axis=1)
    return points, cells, "quadrilateral" if d == 2 else "hexahedron"


def simplices(mesh):
    """The mesh with every cell split into triangles or tetrahedra on its own nodes."""
    points, cells, cell_type = mesh
    if cell_type == "quadrilateral":
        return points, cells[:, TRIANGLES].reshape(-1, 3), "triangle"
    return points, cells[:, TETRAHEDRA].reshape(-1, 4), "tetrahedron"


def moved(mesh, seed=3):
    """The mesh with each interior node moved by up to 1/4 of the spacing in each coordinate
    (the boundary, so the body, unchanged)."""
    points, cells, cell_type = mesh
    low, high = points.min(axis=0), points.max(axis=0)
    spacing = np.min([np.diff(np.unique(points[:, j])).min() for j in range(points.shape[1])])
    inside = np.all((points > low + 1e-9) & (points < high - 1e-9), axis=1)
    shift = np.random.default_rng(seed).uniform(-0.25, 0.25, points.shape) * spacing
    return points + inside[:, None] * shift, cells, cell_type


def affine(A, b):
    return lambda X: X @ np.asarray(A).T + np.asarray(b)


def series(name, mesh, field, times=TIMES):
    """A Series on mesh with u(X, t) = t field(X)."""
    points, cells, cell_type = mesh
    return Series(Path(name), points, cells, cell_type, times, [t * field(points) for t in times])


def curves(grading):
    return np.array([grading.curves[name] for name in grading.curves])


AFFINE = {
    2: (
        affine([[0.1, 0.05], [-0.03, 0.02]], [0.01, -0.02]),
        affine([[0.12, 0.04], [-0.01, 0.03]], [0.02, -0.01]),
    ),
    3: (
        affine([[0.1, 0.05, 0.0], [-0.03, 0.02, 0.01], [0.0, 0.04, -0.02]], [0.01, -0.02, 0.0]),
        affine([[0.12, 0.04, 0.01], [-0.01, 0.03, 0.0], [0.02, 0.05, -0.01]], [0.02, -0.01, 0.003]),
    ),
}
MESHES = {
    2: {
        "reference": grid((6, 3), SQUARE),
        "coarser quadrilaterals": grid((4, 2), SQUARE),
        "finer quadrilaterals": grid((9, 5), SQUARE),
        "triangles": simplices(grid((5, 3), SQUARE)),
        "reference split into triangles": simplices(grid((6, 3), SQUARE)),
        "moved interior nodes": moved(grid((6, 3), SQUARE)),
        "moved triangles": simplices(moved(grid((7, 4), SQUARE))),
    },
    3: {
        "reference": grid((4, 2, 2), ROD),
        "coarser hexahedra": grid((2, 1, 1), ROD),
        "finer hexahedra": grid((6, 3, 3), ROD),
        "tetrahedra": simplices(grid((2, 1, 1), ROD)),
        "reference split into tetrahedra": simplices(grid((4, 2, 2), ROD)),
        "moved interior nodes": moved(grid((6, 3, 3), ROD)),
        "moved tetrahedra": simplices(moved(grid((4, 2, 2), ROD))),
    },
}


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("cells", ["Q1", "simplices"])
def test_affine_field_gives_the_same_metrics_on_every_mesh(dim, cells):
    """u′(X) = A′X + b′ against u(X) = AX + b: P1 and Q1 reproduce affine fields, so the
    candidate's metrics are the same on every mesh of the body as on the reference's own
    (section 6, node for node), to round-off; all non-zero. The reference on quadrilaterals
    or hexahedra, or on them split into simplices."""
    reference_field, candidate_field = AFFINE[dim]
    meshes = MESHES[dim]
    own = "reference"
    if cells == "simplices":
        own = "reference split into " + ("triangles" if dim == 2 else "tetrahedra")
    ref = series("reference.xdmf", meshes[own], reference_field)
    baseline = grade_series(ref, series("same.xdmf", meshes[own], candidate_field))
    expected = curves(baseline)
    assert baseline.notes == [] and np.all(expected[:, 1:] > 1e-4)
    for name, mesh in meshes.items():
        if name == own:
            continue
        g = grade_series(ref, series(f"{name}.xdmf", mesh, candidate_field))
        # atol: E_s at t = 0 (two undeformed polygons or solids) is round-off, not exactly 0
        np.testing.assert_allclose(curves(g), expected, rtol=1e-11, atol=1e-15, err_msg=name)
        assert len(g.notes) == 1 and g.notes[0].startswith(
            f"candidate on its own mesh: {len(mesh[0]):,} nodes, "
        ), name


@pytest.mark.parametrize("dim", [2, 3])
def test_reference_split_into_simplices_on_its_own_nodes(dim):
    """The reference's nodal values on its own nodes, every cell split into simplices: Π u′ = u
    node for node, so E_n = 0 and the nodal E_i = 0 exactly; in 2D the boundary is the same
    polygon, so E_s = 0 (to round-off: the loops start at other nodes). E_i itself compares P1
    with Q1 inside the cells and is small but not 0 for this non-affine field."""

    def smooth(X):
        return np.stack(
            [
                0.05 * X[:, 1] * np.sin(3 * X[:, 0]),
                -0.03 * X[:, 0] ** 2,
                *([0.02 * X[:, 0] * X[:, 2]] if dim == 3 else []),
            ],
            axis=1,
        )

    mesh = MESHES[dim]["reference"]
    g = grade_series(
        series("ref.xdmf", mesh, smooth), series("split.xdmf", simplices(mesh), smooth)
    )
    c = g.curves
    assert np.all(c["relative_error"][1:] == 0) and np.all(c["interior_error_nodal"] == 0)
    assert np.all((c["interior_error"][1:] > 0) & (c["interior_error"][1:] < 1e-3))
    if dim == 2:
        assert np.all(np.abs(c["surface_error"]) <= 1e-15)


@pytest.mark.parallel
@pytest.mark.parametrize("dim", [2, 3])
def test_a_larger_body_is_refused_naming_the_farthest_node(dim):
    """The body 10 % larger: its far corner (node N - 1) is farthest from the reference's
    domain, at |0.1 L| over the corner's coordinates; one line says so, on every rank."""
    lengths = SQUARE if dim == 2 else ROD
    ref_mesh = MESHES[dim]["reference"]
    big = grid((5, 3) if dim == 2 else (3, 2, 2), tuple(1.1 * L for L in lengths))
    ref = series("ref.xdmf", ref_mesh, AFFINE[dim][0])
    with pytest.raises(InputError) as info:
        grade_series(ref, series("big.xdmf", big, AFFINE[dim][1]))
    message = str(info.value)
    corner = ", ".join(f"{1.1 * L:.9g}" for L in lengths)
    distance = np.linalg.norm(0.1 * np.array(lengths))
    assert "\n" not in message
    assert message.startswith("big.xdmf: not a mesh of the body of ref.xdmf: ")
    assert f"candidate node {len(big[0]) - 1} at ({corner}) is {distance:.3g} from the " in message
    assert (
        f"reference's undeformed domain, beyond {1e-6 * max(lengths):.3g} (1e-6 of the "
        f"reference's extent {max(lengths):.6g})"
    ) in message


def test_a_mesh_of_another_dimension_is_refused():
    ref = series("rod.xdmf", MESHES[3]["reference"], AFFINE[3][0])
    with pytest.raises(InputError, match=r"^square.xdmf: 2D triangles cannot be graded against "):
        grade_series(ref, series("square.xdmf", MESHES[2]["triangles"], AFFINE[2][1]))


def test_a_hole_without_nodes_is_refused_by_the_volumes():
    """A candidate on the reference's nodes with one interior cell left out: every node lies
    in both domains, but the areas differ by that cell's (1/18 of the body)."""
    points, cells, cell_type = MESHES[2]["reference"]
    holed = (points, np.delete(cells, 7, axis=0), cell_type)
    ref = series("ref.xdmf", (points, cells, cell_type), AFFINE[2][0])
    with pytest.raises(
        InputError,
        match=r"its area 0\.472222222 differs from the reference's 0\.5 by 0\.0556 relative",
    ):
        grade_series(ref, series("holed.xdmf", holed, AFFINE[2][1]))


@pytest.mark.parallel
@pytest.mark.parametrize("dim", [2, 3])
def test_the_reference_mesh_is_graded_node_for_node_as_before(dim):
    """A candidate on the reference's nodes (stored in another order) and cells takes the path
    of section 6: exactly the numbers of Metrics on the distributed reference space with the
    candidate's values matched node for node, and no note."""
    mesh = MESHES[dim]["reference"]
    ref = series("ref.xdmf", mesh, lambda X: np.sin(2 * X) * X[:, :1] + 0.01)
    values = [u * 1.1 + 0.002 * np.cos(5 * mesh[0]) for u in ref.displacements]
    p, c, stored = shuffled(mesh[0], mesh[1], values)
    g = grade_series(ref, Series(Path("cand.xdmf"), p, c, mesh[2], TIMES, stored))
    assert g.notes == []
    V, nodes = function_space(MPI.COMM_WORLD, ref)
    metrics = Metrics(V)
    for i in range(len(TIMES)):
        expected = metrics.evaluate(ref.displacements[i][nodes].ravel(), values[i][nodes].ravel())
        for name, value in expected.items():
            assert np.array_equal(g.curves[name][i], value, equal_nan=True), (name, i)


# --- files (serial) -------------------------------------------------------------------------


def pad(u):
    return np.c_[u, np.zeros((len(u), 3 - u.shape[1]))]


def write_xdmf(path, mesh, s):
    points, cells, cell_type = mesh
    data = np.array([pad(u) for u in s.displacements])
    write_series(path, ((pad(points), cells, cell_type), {"displacement": data}), s.times)


def write_pvd(path, mesh, s):
    points, cells, cell_type = mesh
    name = {"triangle": "triangle", "tetrahedron": "tetra", "quadrilateral": "quad"}.get(
        cell_type, cell_type
    )
    entries = []
    for k, (t, u) in enumerate(zip(s.times, s.displacements, strict=True)):
        vtu = path.with_name(f"{path.stem}_{k:03d}.vtu")
        meshio.write(
            vtu, meshio.Mesh(pad(points), [(name, cells)], point_data={"displacement": pad(u)})
        )
        entries.append(f'    <DataSet timestep="{float(t)!r}" part="0" file="{vtu.name}"/>')
    path.write_text(
        '<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
        + "\n".join(entries)
        + "\n  </Collection>\n</VTKFile>\n"
    )


@pytest.mark.serial
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("writer", [write_xdmf, write_pvd])
def test_simplices_read_from_files_are_graded_on_their_own_mesh(tmp_path, dim, writer):
    """Triangles and tetrahedra from XDMF ("Triangle", "Tetrahedron") and .vtu ("triangle",
    "tetra"): the numbers of the same series in memory; compare() prints the note first."""
    meshes = MESHES[dim]
    name = "moved triangles" if dim == 2 else "moved tetrahedra"
    ref = series("reference.xdmf", meshes["reference"], lambda X: np.sin(3 * X) * X[:, :1])
    cand = series("cand.xdmf", meshes[name], lambda X: 1.1 * np.sin(3 * X) * X[:, :1] + 0.001)
    write_xdmf(tmp_path / "reference.xdmf", meshes["reference"], ref)
    suffix = ".xdmf" if writer is write_xdmf else ".pvd"
    writer(tmp_path / f"cand{suffix}", meshes[name], cand)
    read = read_series(tmp_path / f"cand{suffix}")
    assert read.cell_type == meshes[name][2] and read.dim == dim
    expected = curves(grade_series(ref, cand))
    g = grade(tmp_path / "reference.xdmf", tmp_path / f"cand{suffix}")
    np.testing.assert_allclose(curves(g), expected, rtol=1e-14, atol=1e-18)
    kind = "triangles" if dim == 2 else "tetrahedra"
    lines = compare(tmp_path / "reference.xdmf", tmp_path / f"cand{suffix}", tmp_path / "out")
    assert list(lines)[0] == "note 1" and lines["note 1"] == g.notes[0]
    assert lines["note 1"] == (
        f"candidate on its own mesh: {len(read.points):,} nodes, {kind} (reference: "
        f"{len(ref.points):,} nodes, {'quadrilaterals' if dim == 2 else 'hexahedra'}); "
        f"interpolated at the reference's {len(ref.points):,} nodes and "
        f"{len(ref.cells) * (9 if dim == 2 else 27):,} quadrature points"
    )


@pytest.mark.serial
@pytest.mark.parametrize("dim", [2, 3])
def test_crossmesh_serial_and_two_ranks_agree(tmp_path, dim):
    """compare() of a candidate on its own (moved simplex) mesh under mpiexec -n 2 writes the
    serial metrics.csv to 1e-12."""
    meshes = MESHES[dim]
    name = "moved triangles" if dim == 2 else "moved tetrahedra"
    finer = meshes["finer quadrilaterals" if dim == 2 else "finer hexahedra"]
    ref = series("reference.xdmf", finer, lambda X: np.sin(3 * X) * X[:, :1])
    cand = series("cand.xdmf", meshes[name], lambda X: 1.1 * np.sin(3 * X) * X[:, :1] + 0.001)
    write_xdmf(tmp_path / "reference.xdmf", finer, ref)
    write_xdmf(tmp_path / "cand.xdmf", meshes[name], cand)
    table, _ = serial_and_two_ranks(tmp_path / "reference.xdmf", tmp_path / "cand.xdmf")
    assert np.isfinite(table[1:, 2:]).all() and np.all(table[1:, 2:] > 0)


def old_metrics(folder: Path) -> Path | None:
    """The metrics/ folder of commit BEFORE, extracted into folder; None without git or it."""
    repository = HERE.parent
    try:
        archive = subprocess.run(
            ["git", "-C", str(repository), "archive", BEFORE, "metrics"],
            capture_output=True,
            check=True,
            timeout=60,
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True, timeout=60)
    except (OSError, subprocess.SubprocessError):
        return None
    return folder / "metrics"


@pytest.mark.serial
@pytest.mark.parametrize("dim", [2, 3])
def test_same_mesh_numbers_are_those_of_the_code_before(tmp_path, dim):
    """test_compare's series (shuffled nodes, meshio XDMF): grade() gives bit for bit the
    curves that the metrics package of commit BEFORE (before the cross-mesh grading) gives."""
    old = old_metrics(tmp_path)
    if old is None:
        pytest.skip(f"git or commit {BEFORE[:10]} not available")
    V = make_space(dim)
    ref, cand = fields(V)
    points, cells, cell_type = mesh_data(V)
    write_meshio_xdmf(tmp_path / "reference.xdmf", points, cells, cell_type, ref)
    p, c, values = shuffled(points, cells, cand)
    write_meshio_xdmf(tmp_path / "cand.xdmf", p, c, cell_type, values)
    cmd, env = job(
        [HERE / "mpi_crossmesh.py", old, tmp_path / "reference.xdmf", tmp_path / "cand.xdmf"]
    )
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    before = json.loads(out.stdout.strip().splitlines()[-1])
    g = grade(tmp_path / "reference.xdmf", tmp_path / "cand.xdmf")
    assert g.notes == before["notes"] == []
    for name, values in before["curves"].items():
        now = [repr(float(v)) for v in g.curves[name]]
        assert now == values, name
