"""The Newton runner of `tissuebench external` (workflows/simulators/newton.py) on the small rod
(mesh size 2): its tetrahedra against the box geometry, its masses and springs against closed
sums, its material mappings against the small-strain limits of Newton's energies, and its
runs against a linear P1 solve on the same tetrahedra and our quasi-static reference. Serial:
Newton runs on one process; about 15 s with Warp's kernels cached, 40 s compiling them."""

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from p1 import p1_matrices

pytestmark = pytest.mark.outside  # an outside simulator: make external-tests

pytest.importorskip("newton")

from tissuebench.solvers.materials import Material, get_material  # noqa: E402
from tissuebench.workflows.compare.posing import build, run_reference  # noqa: E402
from tissuebench.workflows.simulators import newton as nw  # noqa: E402

H = 1 / 30  # the paper's h, s
LENGTH, HEIGHT, DEPTH = 0.5, 0.25, 0.25  # the rod, m (SPEC section 5)


def rod(steps=30, material=None, procedure="dynamic", h=H):
    """The rod of mesh size 2 (4 x 2 x 2 hexahedra) as exported."""
    material = material or get_material("MP3")
    data, bench, _ = build(
        "rod", 2, {}, material, "linear", h, steps, "strain", procedure, MPI.COMM_WORLD
    )
    return data, bench


@pytest.fixture(scope="module")
def small_rod():
    return rod()[0]


def tip(data, U):
    """The displacement at the rod's tip: the mean of the nodes nearest to it (one on n = 2)."""
    distance = np.linalg.norm(data.nodes - np.asarray(data.probe), axis=1)
    return U[..., distance <= distance.min() + 1e-12, :].mean(axis=-2)


def p1_static(data, tets):
    """Linear elasticity on the P1 tetrahedra under the export's gravity and clamp: nodal
    displacements (N, 3) m, solved densely (135 unknowns on n = 2), independent of Newton."""
    m = data.material
    K, _, f = p1_matrices(data.nodes, tets, m.mu, m.lmbda, m.rho, data.gravity)
    K, n = K.toarray(), len(f)
    clamped = (3 * data.node_sets["clamped"][:, None] + np.arange(3)).ravel()
    free = np.setdiff1d(np.arange(n), clamped)
    u = np.zeros(n)
    u[free] = np.linalg.solve(K[np.ix_(free, free)], f[free])
    return u.reshape(-1, 3)


# --- the posed mesh, masses and parameters (numpy only) ----------------------------------------


@pytest.mark.serial
def test_split_conserves_volume_and_conforms(small_rod):
    """Six positive tetrahedra per hexahedron whose volumes add up to each box's volume and to
    the rod's (to round-off); the split conforms, and a cell turned a quarter round (its
    diagonal then crosses its neighbours') is caught."""
    data = small_rod
    tets = nw.split_hexahedra(data.nodes, data.cells)
    volumes = nw.tet_volumes(data.nodes, tets)
    assert tets.shape == (6 * len(data.cells), 4) and volumes.min() > 0
    x = data.nodes[data.cells]
    boxes = np.prod(x.max(axis=1) - x.min(axis=1), axis=1)
    # the exported nodes sit up to 1e-12 m off the grid (DOLFINx's tabulated coordinates)
    assert np.allclose(volumes.reshape(-1, 6).sum(axis=1), boxes, rtol=1e-10, atol=0)
    assert volumes.sum() == pytest.approx(LENGTH * HEIGHT * DEPTH, rel=1e-12)
    assert nw.conforming(tets, data.cells)

    hexes = nw.canonical_hexahedra(data.nodes, data.cells)
    hexes[0] = hexes[0][[1, 2, 3, 0, 5, 6, 7, 4]]  # the same box, numbered a quarter round
    mixed = hexes[:, np.array(nw.HEX_TETS)].reshape(-1, 4)
    assert not nw.conforming(mixed, data.cells)


@pytest.mark.serial
def test_masses_and_springs_add_up(small_rod):
    """The lumped masses add up to rho * volume; Newton's model holds them on the free nodes
    (float32) and 0 on the clamped face; every edge has one spring and sum(k L^2) = 6 E V (each
    tetrahedron's volume counted by its six edges)."""
    data = small_rod
    m = data.material
    tets = nw.split_hexahedra(data.nodes, data.cells)
    masses = nw.lumped_masses(data.nodes, tets, m.rho)
    volume = LENGTH * HEIGHT * DEPTH
    assert masses.sum() == pytest.approx(m.rho * volume, rel=1e-13)

    clamped = data.node_sets["clamped"]
    free = np.setdiff1d(np.arange(len(data.nodes)), clamped)
    for variant in ("vbd", "springs"):
        model = nw._builder(data, variant, tets).finalize(device="cpu")
        held = model.particle_mass.numpy()
        assert np.all(held[clamped] == 0)
        assert np.allclose(held[free], masses[free], rtol=1e-6, atol=0)

    edges, k = nw.spring_network(data.nodes, tets, m.E)
    # the grid's edges, face diagonals and cell diagonals: 6 distinct per tet, shared
    assert len(np.unique(edges, axis=0)) == len(edges)
    lengths2 = np.sum((data.nodes[edges[:, 0]] - data.nodes[edges[:, 1]]) ** 2, axis=1)
    assert np.sum(k * lengths2) == pytest.approx(6 * m.E * volume, rel=1e-12)


def lame_tangent(stress, mu, lam):
    """max |(P(I + e G) - P(I)) / e - (2 mu sym(G) + lam tr(G) I)| over random G, relative."""
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(5):
        G = rng.standard_normal((3, 3))
        e = 1e-6
        tangent = (stress(np.eye(3) + e * G) - stress(np.eye(3) - e * G)) / (2 * e)
        linear = mu * (G + G.T) + lam * np.trace(G) * np.eye(3)
        worst = max(worst, np.abs(tangent - linear).max() / np.abs(linear).max())
    return worst, np.abs(stress(np.eye(3))).max()


@pytest.mark.serial
def test_tet_parameters_give_the_lame_constants():
    """Newton's tetrahedral stresses, as its kernels write them (semi-implicit: Smith et al.'s
    neo-Hookean with 1/(I_C + 1); VBD: stable neo-Hookean, lambda_nh = k_lambda + k_mu),
    under tet_parameters: stress-free at rest with mu and lambda as tangent."""
    m = get_material("MP3")

    def cof(F):
        return np.linalg.det(F) * np.linalg.inv(F).T

    k_mu, k_lambda, _ = nw.tet_parameters(m, "semi-implicit")

    def semi_implicit(F):
        alpha = 1 + k_mu / k_lambda - k_mu / (4 * k_lambda)
        Ic = np.sum(F * F)
        return k_mu * F * (1 - 1 / (Ic + 1)) + k_lambda * (np.linalg.det(F) - alpha) * cof(F)

    k_mu_v, k_lambda_v, _ = nw.tet_parameters(m, "vbd")
    lambda_nh = k_lambda_v + k_mu_v

    def vbd(F):
        return k_mu_v * F + lambda_nh * (np.linalg.det(F) - 1 - k_mu_v / lambda_nh) * cof(F)

    for stress in (semi_implicit, vbd):
        error, rest = lame_tangent(stress, m.mu, m.lmbda)
        assert error < 1e-6 and rest < 1e-9 * m.E


@pytest.mark.serial
def test_variants_only_for_the_dynamic_3d_rod(small_rod):
    """The static procedure and the 2D block pose nothing; the dynamic rod every variant, each
    description naming its substeps."""
    assert set(nw.variants(small_rod)) == set(nw.VARIANTS)
    assert all(
        "substep" in line or "one step of h" in line for line in nw.variants(small_rod).values()
    )
    static, _ = rod(steps=2, procedure="static")
    assert nw.variants(static) == {}
    block, _, _ = build(
        "block", 4, {}, get_material("MP1"), "linear", H, 2, "strain", "dynamic", MPI.COMM_WORLD
    )
    assert nw.variants(block) == {}


# --- runs -------------------------------------------------------------------------------------


@pytest.mark.serial
def test_vbd_settles_on_the_tetrahedra_static_tip(tmp_path):
    """VBD, one step of h x 10 iterations, damped near critically (alpha = 2 1/s) for 15 s,
    settles within 6 % of the linear P1 static tip on its own tetrahedra (measured: +3.8 %,
    still creeping by 0.5 %; the rest is geometric nonlinearity: our hexahedral neo-Hookean and
    linear static tips differ by 2.1 % on this rod). The tetrahedra stand 31 % stiffer than our
    quasi-static hexahedral reference (measured P1 / Q1 tip = 0.688): linear tetrahedra lock
    in bending on a 4 x 2 x 2 grid."""
    material = Material("MP3, alpha 2", E=7000.0, nu=0.2, rho=10000.0, alpha=2.0, beta=0.1)
    data, _ = rod(steps=450, material=material)
    result = nw.simulate(data, "vbd-1")
    assert result["diverged"] is None
    tets = result["tets"]
    u_tet = tip(data, p1_static(data, tets))
    u_vbd = tip(data, result["U"][-1])
    assert u_vbd[1] / u_tet[1] == pytest.approx(1.0, abs=0.06)
    assert np.all(result["U"][:, data.node_sets["clamped"]] == 0)

    static, bench = rod(steps=1, material=material, procedure="static")
    run_reference(static, bench, material, tmp_path / "static.xdmf", log=lambda *a: None)
    with h5py.File(tmp_path / "static.h5") as f:
        u_hex = tip(data, f["/Function/displacement/1"][...])
    assert u_tet[1] / u_hex[1] == pytest.approx(0.688, abs=0.005)
    assert u_vbd[1] / u_hex[1] == pytest.approx(0.688, abs=0.06)


@pytest.mark.serial
def test_run_writes_the_series_and_reports_failures(small_rod, tmp_path, monkeypatch):
    """A run leaves newton.xdmf: the displacement at t_0..t_30 on 6 tetrahedra per hexahedron,
    zero at t = 0, finite; an unknown variant comes back failed, and an explicit scheme far
    beyond its stable step diverges into NaN with status failed."""
    data = small_rod
    result = nw.run(data, "vbd-1", tmp_path)
    assert result.status == "ok" and result.reason is None
    assert result.dofs == 3 * len(data.nodes) and result.wall_time_s > 0
    assert result.mesh.startswith("tetrahedra") and "excluded" in result.timing
    assert result.series == tmp_path / "newton.xdmf" and result.field == "displacement"
    assert 'TopologyType="Tetrahedron"' in result.series.read_text()
    with h5py.File(tmp_path / "newton.h5") as f:
        assert f["/Mesh/mesh/topology"].shape == (6 * len(data.cells), 4)
        U = np.array([f[f"/Function/displacement/{i}"][...] for i in range(data.steps + 1)])
    assert U.shape == (data.steps + 1, len(data.nodes), 3)
    assert np.all(U[0] == 0) and np.all(np.isfinite(U))
    assert -0.05 < tip(data, U[-1])[1] < -0.005  # sagging under gravity, about 2 cm at t = 1 s

    unknown = nw.run(data, "no-such-variant", tmp_path / "x")
    assert unknown.status == "failed" and "no-such-variant" in unknown.reason

    one = ("semi-implicit", "tets", 1, 0, "SolverSemiImplicit, one step of h (unstable)")
    monkeypatch.setitem(nw.VARIANTS, "semi-implicit-1", one)
    coarse, _ = rod(steps=30, h=0.2)
    blown = nw.run(coarse, "semi-implicit-1", tmp_path)
    assert blown.status == "failed" and blown.reason.startswith("diverged at step")
    with h5py.File(tmp_path / "newton.h5") as f:
        last = f[f"/Function/displacement/{coarse.steps}"][...]
    assert np.all(np.isnan(last))
