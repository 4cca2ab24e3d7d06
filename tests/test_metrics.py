"""The metrics of SPEC section 6 against answers derived here, independently of the code."""

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx import mesh as dmesh
from helpers import run_script

from tissuebench.meshes.block import block_mesh
from tissuebench.meshes.rod import SIZE as ROD
from tissuebench.meshes.rod import rod_mesh
from tissuebench.metrics import Metrics, summarize
from tissuebench.metrics.surface import surface_error


def space(mesh):
    return fem.functionspace(mesh, ("Lagrange", 1, (mesh.geometry.dim,)))


def owned(V, f):
    """Owned dof values of the interpolant of the vector field f(x) (x of shape (3, n))."""
    u = fem.Function(V)
    u.interpolate(f)
    return u.x.array[: V.dofmap.index_map.size_local * V.mesh.geometry.dim].copy()


def translation(V, d):
    return np.tile(np.asarray(d, dtype=float), V.dofmap.index_map.size_local)


def deformed_measure(V, u):
    """|Ω_t| = ∫_{Ω_0} det(I + grad u) dX, exact by quadrature for the deformations used here."""
    f = fem.Function(V)
    f.x.array[: len(u)] = u
    f.x.scatter_forward()
    F = ufl.Identity(V.mesh.geometry.dim) + ufl.grad(f)
    form = fem.form(ufl.det(F) * ufl.dx(metadata={"quadrature_degree": 6}))
    return V.mesh.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


@pytest.fixture(scope="module")
def square():
    return space(block_mesh(4, MPI.COMM_WORLD).mesh)


@pytest.fixture(scope="module")
def rod():
    return space(rod_mesh(2, MPI.COMM_WORLD).mesh)


@pytest.fixture(scope="module")
def square_metrics(square):
    return Metrics(square)


@pytest.fixture(scope="module")
def rod_metrics(rod):
    return Metrics(rod)


def smooth(x):
    return np.array(
        [0.05 * x[1] * np.sin(np.pi * x[0]), -0.03 * x[0] ** 2 + 0.01 * x[1], 0.02 * x[0] * x[2]]
    )


@pytest.mark.parametrize("case", ["square", "rod"])
def test_identical_inputs_give_zero(case, request):
    V, metrics = request.getfixturevalue(case), request.getfixturevalue(f"{case}_metrics")
    u = owned(V, lambda x: smooth(x)[: V.mesh.geometry.dim])
    values = metrics.evaluate(u, u)
    assert values["relative_error"] == 0
    assert values["interior_error"] == 0 and values["interior_error_nodal"] == 0
    assert abs(values["surface_error"]) < 1e-14


@pytest.mark.parametrize("case", ["square", "rod"])
def test_a_shape_against_itself_gives_what_the_boolean_gives(case, request):
    """E_s of one deformed shape against itself is 0 without the boolean operation (the
    reference's own row); the boolean (Polygon/Solid.error: shapely, manifold3d) gives the
    same 0 for it, its round-off clipped, and a nearby shape is not taken for it."""
    V, metrics = request.getfixturevalue(case), request.getfixturevalue(f"{case}_metrics")
    u = owned(V, lambda x: smooth(x)[: V.mesh.geometry.dim])
    x = metrics.boundary.gather(u)
    if MPI.COMM_WORLD.rank == 0:
        x = metrics.boundary.X + x
        assert surface_error(metrics.domain, x, x.copy()) == 0.0
        shape = metrics.domain
        assert shape.error(shape.region(x), shape.region(x.copy())) == 0.0
        nearby = x.copy()
        nearby[0, 0] += 1e-3
        assert surface_error(metrics.domain, x, nearby) > 0


@pytest.mark.parametrize(
    "d1, d2",
    [
        ((0.1, 0.05, 0.02), (0.13, 0.01, -0.03)),
        ((0.1, 0.0, 0.0), (-0.05, 0.0, 0.0)),
        ((0.0, 0.2, 0.1), (0.0, 0.2, 0.1 + 1e-4)),
    ],
)
@pytest.mark.parametrize("case, lengths", [("square", (1.0, 1.0)), ("rod", ROD)])
def test_rigid_translations(case, lengths, d1, d2, request):
    """Reference u = d1, candidate u' = d2 everywhere, Δ = d2 - d1:
    E_n = |Δ| / |d1| (every node contributes the same vector);
    E_s = |Ω Δ Ω'| / |Ω| with |Ω ∩ Ω'| = Π_k (L_k - |Δ_k|) for two boxes, so
    E_s = 2 (1 - Π_k (1 - |Δ_k| / L_k));  E_i = |Ω|^(-1/d) |Ω| |Δ| (both forms)."""
    V, metrics = request.getfixturevalue(case), request.getfixturevalue(f"{case}_metrics")
    dim = len(lengths)
    d1, d2 = np.array(d1[:dim]), np.array(d2[:dim])
    delta, L = d2 - d1, np.array(lengths)
    volume = np.prod(L)
    values = metrics.evaluate(translation(V, d1), translation(V, d2))
    assert values["relative_error"] == pytest.approx(
        np.linalg.norm(delta) / np.linalg.norm(d1), rel=1e-13
    )
    assert values["surface_error"] == pytest.approx(
        2 * (1 - np.prod(1 - np.abs(delta) / L)), rel=1e-10
    )
    E_i = volume ** (1 - 1 / dim) * np.linalg.norm(delta)
    assert values["interior_error"] == pytest.approx(E_i, rel=1e-13)
    assert values["interior_error_nodal"] == pytest.approx(E_i, rel=1e-13)
    assert metrics.volume == pytest.approx(volume, rel=1e-14)


@pytest.mark.parametrize("theta", [0.01, 0.05, 0.2])
def test_rotated_square_overlap(square, square_metrics, theta):
    """The unit square rotated by θ about its centre (boundary nodes stay on the rotated
    edges: the map is linear) sticks out of the square by four right triangles, one per
    corner. Each has its right angle at the rotated corner, height
    h = (cos θ + sin θ - 1) / 2 above the edge it crosses and base angles θ and π/2 - θ,
    so base h (cot θ + tan θ) and area h² / sin 2θ. Hence |Ω Δ Ω'| = 2 · 4 h² / sin 2θ.
    The reference (zero) has ‖u‖ = 0, so E_n is NaN."""
    c, s = np.cos(theta), np.sin(theta)

    def rotation(x):
        X, Y = x[0] - 0.5, x[1] - 0.5
        return np.array([c * X - s * Y - X, s * X + c * Y - Y])

    h = (c + s - 1) / 2
    exact = 8 * h**2 / np.sin(2 * theta)
    zero, rotated = np.zeros_like(translation(square, (0, 0))), owned(square, rotation)
    values = square_metrics.evaluate(zero, rotated)
    assert values["surface_error"] == pytest.approx(exact, rel=1e-12)
    assert np.isnan(values["relative_error"])
    assert square_metrics.evaluate(rotated, zero)["surface_error"] == pytest.approx(
        exact, rel=1e-12
    )
    assert square_metrics.evaluate(rotated, zero)["relative_error"] == pytest.approx(1.0, rel=1e-14)


def test_surface_error_relation_2d(square, square_metrics):
    """|Ω|·E_s(Ω, Ω') = |Ω'|·E_s(Ω', Ω) = |Ω Δ Ω'|, with |Ω| = ∫ det F dX computed independently
    (exact for Q1 displacements on the affine square cells)."""
    a = owned(square, lambda x: smooth(x)[:2])
    b = owned(square, lambda x: np.array([0.04 * np.cos(2 * x[1]) * x[0], 0.06 * x[0] * x[1] ** 2]))
    area_a, area_b = deformed_measure(square, a), deformed_measure(square, b)
    ab = square_metrics.evaluate(a, b)["surface_error"]
    ba = square_metrics.evaluate(b, a)["surface_error"]
    assert ab > 0.01
    assert area_a * ab == pytest.approx(area_b * ba, rel=1e-12)
    assert area_a != pytest.approx(area_b, rel=1e-3)  # the relation is not trivially E_s symmetric


def test_surface_error_relation_3d(rod, rod_metrics):
    """As in 2D, on the rod with u = (0, y s(x), z r(x)): non-affine, but every boundary face
    stays planar, so the split faces bound exactly the deformed Q1 mesh, whose volume is
    ∫ (1 + s_h)(1 + r_h) dX = ∫ det F dX."""
    a = owned(
        rod, lambda x: np.array([0 * x[0], x[1] * 0.3 * x[0] ** 2, x[2] * 0.2 * np.sin(4 * x[0])])
    )
    b = owned(
        rod, lambda x: np.array([0 * x[0], -x[1] * 0.1 * np.cos(5 * x[0]), x[2] * 0.4 * x[0]])
    )
    vol_a, vol_b = deformed_measure(rod, a), deformed_measure(rod, b)
    ab = rod_metrics.evaluate(a, b)["surface_error"]
    ba = rod_metrics.evaluate(b, a)["surface_error"]
    assert ab > 0.01
    assert vol_a * ab == pytest.approx(vol_b * ba, rel=1e-10)
    assert vol_a != pytest.approx(vol_b, rel=1e-3)


def test_rod_surface_error_is_exact_for_a_shear(rod, rod_metrics):
    """A shear u = (γ y, 0, 0) maps the box to a parallelepiped of the same volume (faces stay
    planar). At height y the sheared box spans x in [γ y, L + γ y], the box [0, L], so
    |Ω ∩ Ω'| = D ∫_0^H (L - γ y) dy = (L - γ H / 2) H D (γ H < L), |Ω Δ Ω'| = 2 (|Ω| - |Ω ∩ Ω'|)."""
    L, H, D = ROD
    gamma = 0.4
    sheared = owned(rod, lambda x: np.array([gamma * x[1], 0 * x[0], 0 * x[0]]))
    values = rod_metrics.evaluate(np.zeros_like(sheared), sheared)
    volume = L * H * D
    assert values["surface_error"] == pytest.approx(
        2 * (volume - (L - gamma * H / 2) * H * D) / volume, rel=1e-10
    )


def test_self_intersecting_boundary_is_kept():
    """2 x 2 unit square, the node (1, 1/2) pulled to (-1/2, 1/2): the boundary crosses the left
    edge at (0, 1/3) and (0, 2/3). make_valid keeps the two slivers (0,0),(1,0),(0,1/3) and
    (0,2/3),(1,1),(0,1) (area 1/6 each) and the tip (0,1/3),(-1/2,1/2),(0,2/3) (area 1/12):
    |Ω'| = 5/12, |Ω Δ Ω'| = (1 - 1/3) + 1/12 = 3/4. Dropping the folded domain would give
    E_s = 1 (or a division by zero)."""
    V = space(dmesh.create_unit_square(MPI.COMM_WORLD, 2, 2, dmesh.CellType.quadrilateral))
    metrics = Metrics(V)
    folded = owned(
        V,
        lambda x: np.array(
            [np.where(np.isclose(x[0], 1) & np.isclose(x[1], 0.5), -1.5, 0.0), 0 * x[0]]
        ),
    )
    zero = np.zeros_like(folded)
    assert metrics.evaluate(zero, folded)["surface_error"] == pytest.approx(3 / 4, rel=1e-13)
    assert metrics.evaluate(folded, zero)["surface_error"] == pytest.approx(
        (3 / 4) / (5 / 12), rel=1e-13
    )


def test_history_pads_a_shorter_candidate(square, square_metrics):
    d = [translation(square, (0.1 * k, 0.0)) for k in range(4)]
    curves = square_metrics.history(d, [x * 1.5 for x in d[:2]])
    assert set(curves) == {
        "relative_error",
        "surface_error",
        "interior_error",
        "interior_error_nodal",
    }
    assert np.isnan(curves["relative_error"][0]) and curves["relative_error"][1] == pytest.approx(
        0.5
    )
    assert curves["interior_error"][1] == pytest.approx(0.05)
    assert all(np.isnan(c[2:]).all() and len(c) == 4 for c in curves.values())


@pytest.mark.parametrize("case, lengths", [("square", (1.0, 1.0)), ("rod", ROD)])
def test_histories_step_by_step_give_each_candidates_exact_surface_error(case, lengths, request):
    """histories() measures every candidate at a step against one reference domain (built once
    for them all): each E_s is still that of its own pair of boxes, 2 (1 - Π_k (1 - |Δ_k| / L_k))
    (test_rigid_translations), whichever candidate came before it; a shorter one is padded."""
    V, metrics = request.getfixturevalue(case), request.getfixturevalue(f"{case}_metrics")
    dim, L = len(lengths), np.array(lengths)
    shift = np.array([0.01, 0.02, 0.005][:dim])
    ref = [translation(V, k * shift) for k in range(4)]
    moves = {"a": np.array([0.02, 0.0, 0.0][:dim]), "b": np.array([0.0, -0.01, 0.003][:dim])}
    cands = {
        "a": [translation(V, k * shift + moves["a"]) for k in range(4)],
        "b": [translation(V, k * shift + moves["b"]) for k in range(3)],
    }
    curves = metrics.histories(ref, cands)
    for label, delta in moves.items():
        expected = 2 * (1 - np.prod(1 - np.abs(delta) / L))
        steps = len(cands[label])
        assert curves[label]["surface_error"][:steps] == pytest.approx(expected, rel=1e-10)
        assert np.isnan(curves[label]["surface_error"][steps:]).all()


def test_bad_input_shape(square_metrics):
    with pytest.raises(ValueError, match="owned dof values"):
        square_metrics.evaluate(np.zeros(3), np.zeros(3))


def test_summarize_skips_step_zero_and_nan():
    assert summarize([np.nan, 1.0, np.nan, 3.0]) == (3.0, 2.0)
    assert summarize([5.0, 1.0, 2.0]) == (2.0, 1.5)
    assert all(np.isnan(summarize([0.0, np.nan])))


@pytest.mark.serial
def test_serial_and_two_ranks_agree():
    serial, parallel = run_script("mpi_metrics.py"), run_script("mpi_metrics.py", ranks=2)
    for case in ("block", "rod"):
        for name, value in serial[case].items():
            assert value > 0
            assert parallel[case][name] == pytest.approx(value, rel=1e-12), (case, name)
        # histories: E_s of steps 0, 2, 4 measured on rank 0 and of 1, 3 on rank 1 under mpiexec
        curves, parallel_curves = serial[f"{case} histories"], parallel[f"{case} histories"]
        surface = np.array(curves["a"]["surface_error"])
        assert surface[0] == 0 and (surface[1:] > 0).all()  # step 0: both undeformed
        for label, names in curves.items():
            for name, values in names.items():
                got = parallel_curves[label][name]
                np.testing.assert_allclose(got, values, rtol=1e-12, err_msg=f"{case} {label}")
