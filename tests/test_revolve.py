"""SPEC 13's revolved truth (solvers/truth/revolve.py): a meridian truth's samples revolved about
the z axis into the 3D samples that a 3D candidate is graded against. The volume and a field
that the Gauss rule in (r, z) and the trapezoidal rule in theta integrate exactly come out
exact; the truth sampled on 3D meshes of the cylinder grades at its interpolation error,
falling with the mesh; rotating the angles changes nothing beyond round-off."""

from pathlib import Path

from mpi4py import MPI

import dolfinx.geometry
import numpy as np
import pytest
from dolfinx import fem
from dolfinx.io.utils import cell_perm_vtk

from tissuebench.meshes import get_entry
from tissuebench.metrics.crossmesh import Mesh
from tissuebench.metrics.surface import Solid
from tissuebench.metrics.truth import TruthMetrics
from tissuebench.solvers.truth import axisymmetric as axi
from tissuebench.solvers.truth import case_truth
from tissuebench.solvers.truth.revolve import revolve
from tissuebench.solvers.truth.store import is_axisymmetric, sample, size_of

pytestmark = pytest.mark.serial  # numpy on one process; the truth on COMM_SELF
SELF = MPI.COMM_SELF
CASE = "cylinder-MP1"
STEPS = 12  # the capsule 0.032 m deep at t = 0.4 s


@pytest.fixture(scope="module")
def quick():
    """A quick meridian truth (n = 4, STEPS steps of h) and its 2D samples."""
    truth, bench = case_truth(CASE, 4, SELF)
    run = truth.run(bench.dt, STEPS)
    samples = sample(truth, run, CASE, inputs={"axisymmetric": {}})
    return run, samples


def test_sampled_meridian_is_marked_and_its_volume_revolves_exactly(quick):
    """The revolved weights w_q r_q (2 pi / angles) sum to pi R_B^2 H to round-off: the
    trapezoidal rule in theta is exact for a theta-independent integrand (its error, for
    every trigonometric polynomial of degree below the angles, is zero), and 3 Gauss points
    integrate r exactly on the meridian's affine quadrilaterals."""
    _, samples = quick
    assert is_axisymmetric(samples) and samples.gdim == 2
    for angles in (3, 8, 32):
        three = revolve(samples, angles)
        assert not is_axisymmetric(three) and three.gdim == 3
        assert three.weights.sum() == pytest.approx(np.pi * axi.R_B**2 * axi.H, rel=1e-13)
        assert len(three.points) == angles * len(samples.points)
        # a vertex on the axis once, every other on every angle
        on_axis = int(np.sum(samples.vertices[:, 0] == 0.0))
        assert len(three.vertices) == on_axis + angles * (len(samples.vertices) - on_axis)
    # the size that judges the target (store.size_of) is the revolved body's: the same
    assert size_of(revolve(samples, 32)) == pytest.approx(size_of(samples), rel=1e-12)


def test_a_field_with_cos_squared_integrates_exactly():
    """int u_x^2 dV for u_r = r, u_z = 0 (u_x = r cos theta): pi int r^3 dr dz = pi R_B^4 H / 4,
    exact for angles >= 3 (cos^2 is of degree 2 in theta) and for the Gauss rule (r^3 on affine
    cells, degree 3 <= 5)."""
    meridian = _structured(4, 6)
    meridian.u_points[:] = 0.0
    meridian.u_points[0, :, 0] = meridian.points[:, 0]
    for angles in (3, 5, 32):
        three = revolve(meridian, angles)
        value = three.weights @ three.u_points[0, :, 0] ** 2
        assert value == pytest.approx(np.pi * axi.R_B**4 * axi.H / 4, rel=1e-13)


def test_revolved_cells_and_boundary_bound_the_faceted_cylinder():
    """The swept hexahedra's volumes sum to the faceted body's (the meridian's areas times the
    chord's sector: pi R^2 H sin(2 pi / N) N / (2 pi) for the full radius), positively; the
    swept boundary (facets touching the axis with a repeated vertex) is a closed surface of
    that volume, as metrics/surface.py's Solid takes it."""
    from tissuebench.metrics.cells import measures

    angles = 16
    three = revolve(_structured(4, 6), angles)
    faceted = np.pi * axi.R_B**2 * axi.H * np.sin(2 * np.pi / angles) * angles / (2 * np.pi)
    volumes = measures(three.vertices, three.cells, "hexahedron")
    assert volumes.min() > 0 and volumes.sum() == pytest.approx(faceted, rel=1e-12)
    solid = Solid(three.vertices, three.boundary).region(three.vertices)
    assert solid.volume() == pytest.approx(faceted, rel=1e-12)


def test_rotating_the_angles_changes_nothing_beyond_round_off(quick):
    """revolve() at theta_j + 0.37 rad: the same weights' sum, the same int |u| dV at every
    step (the truth's size) and the same int u_x^2 dV, to round-off."""
    _, samples = quick
    a, b = revolve(samples, 32), revolve(samples, 32, offset=0.37)
    assert a.weights.sum() == pytest.approx(b.weights.sum(), rel=1e-14)
    for k in range(len(samples.times)):
        na = a.weights @ np.linalg.norm(a.u_points[k], axis=1)
        nb = b.weights @ np.linalg.norm(b.u_points[k], axis=1)
        assert na == pytest.approx(nb, rel=1e-12, abs=1e-300)
        xa = a.weights @ a.u_points[k, :, 0] ** 2
        xb = b.weights @ b.u_points[k, :, 0] ** 2
        assert xa == pytest.approx(xb, rel=1e-12, abs=1e-300)


def test_the_truth_sampled_on_3d_meshes_grades_at_its_interpolation_error(quick):
    """The meridian truth revolved on 32 angles, against a 3D candidate that is the truth
    itself sampled at the nodes of the cylinder's O-grid (n = 2, 4, 8): E_i (m^3) is the
    candidate's interpolation error, which falls with the mesh (a trilinear interpolant of a
    smooth field: about fourfold a halving; the contact's edge makes it less), to a small part
    of the truth's size (its E_i against rest)."""
    run, samples = quick
    three = revolve(samples, 32)
    k = len(run.u) - 1
    errors = []
    for n in (2, 4, 8):
        points, cells = _cylinder(n)
        sagitta = axi.R_B * (1 - np.cos(np.pi / (4 * n)))  # the O-grid's side: 8n facets or more
        metrics = TruthMetrics(three, Mesh(points, cells, "hexahedron"), 2 * sagitta, "test")
        metrics.surface = False
        u = _meridian_field(run.V, run.u[k], points)
        errors.append(metrics.evaluate(k, u)["interior_error"])
    size = (
        three.weights @ np.linalg.norm(three.u_points[k], axis=1) / three.weights.sum() ** (1 / 3)
    )  # its E_i against rest
    # measured: 3.2e-4, 2.0e-5, 7.9e-6 m^3 against a size of 5.7e-5 (n = 2 is coarser than the
    # contact: its top centre's node spreads the push over 0.25 m)
    assert errors[1] < 0.6 * errors[0] and errors[2] < 0.6 * errors[1], errors
    assert errors[2] < 0.2 * size


def test_a_3d_candidate_is_graded_against_the_meridian_truth_revolved(quick):
    """grade_truth given the meridian truth itself and a 3D candidate (the truth sampled at the
    O-grid's nodes, n = 4, every step) revolves it on 32 angles (SPEC 13): its curves are
    TruthMetrics' on revolve() step by step, the same-body check allows the faceted side's
    sagitta (the candidate's 16 side facets lie inside r = R_B, the truth's 32 too), the
    revolved history computed step by step equals the whole one, and rotating the candidate's
    mesh about the axis by a third of its facet angle changes E_i by less than the candidate's
    own interpolation error (the metric's size at this mesh)."""
    from tissuebench.metrics.series import InputError, Series
    from tissuebench.metrics.truth import grade_truth

    run, samples = quick
    three = revolve(samples, 32)
    whole = np.asarray(three.u_points)
    assert np.array_equal(whole[5], three.u_points[5])
    assert np.array_equal(whole[3:7, :, 1], three.u_points[3:7, :, 1])

    def candidate(turn: float):
        points, cells = _cylinder(4)
        c, s = np.cos(turn), np.sin(turn)
        points = points @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T
        u = [_meridian_field(run.V, run.u[k], points) for k in range(len(run.u))]
        times = np.asarray(samples.times)
        return Series(Path(f"turned{turn:.3f}.xdmf"), points, cells, "hexahedron", times, u), u

    cand, u = candidate(0.0)
    g = grade_truth(samples, cand, SELF, surface=False)
    metrics = TruthMetrics(three, Mesh(cand.points, cand.cells, "hexahedron"), 0.01, "test")
    metrics.surface = False
    k = len(run.u) - 1
    expected = metrics.evaluate(k, u[k])
    assert g.curves["interior_error"][k] == pytest.approx(expected["interior_error"], rel=1e-9)
    assert g.curves["relative_error"][k] == pytest.approx(expected["relative_error"], rel=1e-9)
    turned, _ = candidate(2 * np.pi / 48)  # the O-grid's side: 16 facets at n = 4
    g_turned = grade_truth(samples, turned, SELF, surface=False)
    e, e_turned = g.curves["interior_error"][k], g_turned.curves["interior_error"][k]
    assert e > 0 and abs(e_turned - e) < e, (e, e_turned)
    # a narrower cylinder (r <= 0.9 R_B) is not the body: refused in one line
    narrow = Series(cand.path, cand.points * [0.9, 0.9, 1.0], cand.cells, "hexahedron",
                    cand.times, cand.displacements)  # fmt: skip
    with pytest.raises(InputError, match="not a mesh of the body of truth:cylinder-MP1"):
        grade_truth(samples, narrow, SELF, surface=False)


# --- helpers ------------------------------------------------------------------------------------
def _structured(nr: int, nz: int):
    """The samples of a uniform nr x nz meridian of [0, R_B] x [0, H] (quadrilaterals in VTK
    order, Gauss 3 x 3, boundary edges with the domain on their left), u = 0, one step."""
    from tissuebench.solvers.truth.samples import TruthSamples

    r, z = np.linspace(0, axi.R_B, nr + 1), np.linspace(0, axi.H, nz + 1)
    vertices = np.array([(a, b) for b in z for a in r])

    def at(i, j):
        return j * (nr + 1) + i

    cells = np.array(
        [
            [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
            for j in range(nz)
            for i in range(nr)
        ]
    )
    g, gw = np.polynomial.legendre.leggauss(3)
    g, gw = (g + 1) / 2, gw / 2
    points, weights = [], []
    for c in cells:
        (r0, z0), (r1, z1) = vertices[c[0]], vertices[c[2]]
        for a, wa in zip(g, gw, strict=True):
            for b, wb in zip(g, gw, strict=True):
                points.append((r0 + a * (r1 - r0), z0 + b * (z1 - z0)))
                weights.append(wa * wb * (r1 - r0) * (z1 - z0))
    edges = [[at(nr, j), at(nr, j + 1)] for j in range(nz)]
    edges += [[at(0, j + 1), at(0, j)] for j in range(nz)]
    edges += [[at(i, 0), at(i + 1, 0)] for i in range(nr)]
    edges += [[at(i + 1, nz), at(i, nz)] for i in range(nr)]
    P = np.array(points)
    return TruthSamples(
        "structured",
        "quadrilateral",
        np.array([0.0]),
        vertices,
        cells,
        np.array(edges),
        P,
        np.array(weights),
        np.zeros((1, len(vertices), 2)),
        np.zeros((1, len(P), 2)),
        inputs={"axisymmetric": {}},
    )


def _cylinder(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The cylinder benchmark's O-grid of hexahedra of size n: (points (N, 3) m, cells in VTK
    order)."""
    mesh = get_entry("cylinder").build(mesh_size=n, comm=SELF).mesh
    perm = np.asarray(cell_perm_vtk(mesh.topology.cell_type, mesh.geometry.dofmaps[0].shape[1]))
    return mesh.geometry.x.copy(), mesh.geometry.dofmaps[0][:, perm].astype(np.int64)


def _meridian_field(V: fem.FunctionSpace, values: np.ndarray, points: np.ndarray) -> np.ndarray:
    """The meridian's Q2 field (u_r, u_z) with dof values `values`, at the 3D points (m):
    (u_r x / r, u_r y / r, u_z) (m)."""
    mesh = V.mesh
    fn = fem.Function(V)
    fn.x.array[: len(values)] = values
    fn.x.scatter_forward()
    r = np.hypot(points[:, 0], points[:, 1])
    rz = np.column_stack([np.minimum(r, axi.R_B), points[:, 2], np.zeros(len(r))])
    tree = dolfinx.geometry.bb_tree(mesh, mesh.topology.dim)
    found = dolfinx.geometry.compute_colliding_cells(
        mesh, dolfinx.geometry.compute_collisions_points(tree, rz), rz
    )
    cells = np.array([found.links(i)[0] for i in range(len(rz))], dtype=np.int32)
    u = fn.eval(rz, cells).reshape(-1, 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.where(r > 0, points[:, 0] / r, 0.0)
        sin = np.where(r > 0, points[:, 1] / r, 0.0)
    return np.column_stack([u[:, 0] * cos, u[:, 0] * sin, u[:, 1]])
