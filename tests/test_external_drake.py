"""The Drake runner of `tissuebench external` (workflows/simulators/drake.py) on the small rod
(mesh size 2, 4 x 2 x 2 hexahedra split into 6 tetrahedra each): its linear body is checked
against a P1 Newmark written here (numpy and scipy only, on the same tetrahedra), which
reproduces it to round-off once given the departures the module states (the one-point mass,
Newmark gamma = 1, beta = 1/2) and departs by them otherwise; the scheme is shown first order;
the neo-Hookean mapping is checked against the small-strain Lame constants of Drake's energy;
a blow-up comes back failed. Serial: Drake runs on one process; 3 to 9 s."""

import unittest.mock

from mpi4py import MPI

import h5py
import numpy as np
import pytest
import scipy.sparse.linalg as spla
from p1 import p1_matrices

pytestmark = pytest.mark.outside  # an outside simulator: make external-tests

pytest.importorskip("pydrake")

from tissuebench.solvers.materials import Material, get_material  # noqa: E402
from tissuebench.workflows.compare.posing import build  # noqa: E402
from tissuebench.workflows.simulators import drake as dk  # noqa: E402
from tissuebench.workflows.simulators.newton import split_hexahedra  # noqa: E402

H = 1 / 30  # the paper's h, s
MP3 = get_material("MP3")


def rod(steps=30, material=MP3, model="linear", h=H, scale=1.0, procedure="dynamic"):
    """The rod of mesh size 2 as exported."""
    options = {} if scale == 1.0 else {"load_scale": scale}
    data, _, _ = build(
        "rod", 2, options, material, model, h, steps, "strain", procedure, MPI.COMM_WORLD
    )
    return data


@pytest.fixture(scope="module")
def small_rod():
    return rod()


def relative(U, V):
    """max over t_1.. of |U - V| / |V| (all nodal components): E_n's maximum."""
    return max(np.linalg.norm(U[i] - V[i]) / np.linalg.norm(V[i]) for i in range(1, len(V)))


# --- an independent P1 Newmark on the same tetrahedra -----------------------------------------


def p1_newmark(data, mass="consistent", gamma=0.5, beta_n=0.5, material=None, h=None, steps=None):
    """Linear P1 elastodynamics on the rod's six-tetrahedra split: M a + (alpha M + beta K) v +
    K u = f, Newmark in the SPEC's parameterisation (beta_n = 1/2, gamma = 1/2: our trapezoidal
    implicit; beta_n = 1, gamma = 1: Drake's), a_0 from the equation of motion, the clamped
    face held. Returns U (steps + 1, N, 3) m."""
    m = material or data.material
    h = data.h if h is None else h
    steps = data.steps if steps is None else steps
    tets = split_hexahedra(data.nodes, data.cells)
    K, masses, f = p1_matrices(data.nodes, tets, m.mu, m.lmbda, m.rho, data.gravity)
    M = masses[mass]
    C = m.alpha * M + m.beta * K
    n = 3 * len(data.nodes)
    free = np.setdiff1d(np.arange(n), (3 * data.node_sets["clamped"][:, None] + np.arange(3)))
    K, M, C, f = K[free][:, free], M[free][:, free], C[free][:, free], f[free]
    u, v = np.zeros(len(free)), np.zeros(len(free))
    a = spla.spsolve(M.tocsc(), f)
    solve = spla.factorized((M + gamma * h * C + beta_n * h * h / 2 * K).tocsc())
    U = np.zeros((steps + 1, n))
    for i in range(1, steps + 1):
        u_star = u + h * v + (1 - beta_n) * h * h / 2 * a
        v_star = v + (1 - gamma) * h * a
        a = solve(f - C @ v_star - K @ u_star)
        u, v = u_star + beta_n * h * h / 2 * a, v_star + gamma * h * a
        U[i, free] = u
    return U.reshape(steps + 1, -1, 3)


def drake(data, variant, tmp_path):
    """Drake's displacement history (steps + 1, N, 3) m of variant on the export."""
    result = dk.simulate(data, variant, tmp_path)
    assert result["diverged"] is None, result["reason"]
    return result["U"]


# --- posing (no time stepping) -----------------------------------------------------------------


@pytest.mark.serial
def test_variants_wall_and_skips(small_rod):
    """The linear rod poses `linear` only, the neo-Hookean rod the three nonlinear models; the
    wall holds exactly the clamped face (x = 0, halfway to the next layer at x = 0.125 m); the
    block, the static procedure are skipped with their reason in one line."""
    assert list(dk.variants(small_rod)) == ["linear"]
    assert dk.skipped(small_rod) == {}
    point, normal = dk.wall(small_rod)
    assert np.allclose(point, [0.0625, 0, 0], atol=1e-12) and np.array_equal(normal, [1, 0, 0])
    held = np.flatnonzero((small_rod.nodes - point) @ normal < 0)
    assert np.array_equal(held, small_rod.node_sets["clamped"])

    neo = rod(steps=2, model="neo-hookean")
    assert set(dk.variants(neo)) == {"corotated", "linear-corotated", "neo-hookean"}
    svk = rod(steps=2, model="svk")
    assert dk.variants(svk) == {} and "svk" in dk.skipped(svk)["all"]
    static = rod(steps=2, procedure="static")
    assert dk.variants(static) == {} and "static" in dk.skipped(static)["all"]
    block, _, _ = build(
        "block", 4, {}, get_material("MP1"), "linear", H, 2, "strain", "dynamic", MPI.COMM_WORLD
    )
    assert dk.variants(block) == {}
    assert "z motion" in dk.skipped(block)["all"]


@pytest.mark.serial
def test_neo_hookean_mapping_has_the_lame_constants():
    """Drake's stable neo-Hookean stress P = mu_D F + lambda_D (J - 1 - mu_D/lambda_D) cof F
    (neohookean_model.cc), with (mu_D, lambda_D) the Lame constants of the E, nu it is given:
    under drake_elasticity its tangent at rest is the SPEC's (mu, lambda); given MP3's own
    E, nu it is (mu, lambda - mu)."""
    rng = np.random.default_rng(2)

    def tangent(E, nu, G, e=1e-6):
        mu_d, lam_d = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))

        def P(F):
            J = np.linalg.det(F)
            return mu_d * F + lam_d * (J - 1 - mu_d / lam_d) * J * np.linalg.inv(F).T

        return (P(np.eye(3) + e * G) - P(np.eye(3) - e * G)) / (2 * e)

    for _ in range(3):
        G = rng.standard_normal((3, 3))

        def lame(mu, lam):
            return mu * (G + G.T) + lam * np.trace(G) * np.eye(3)

        mapped = tangent(*dk.drake_elasticity(MP3, "neo-hookean"), G)
        assert np.allclose(mapped, lame(MP3.mu, MP3.lmbda), rtol=1e-7, atol=1e-6)
        raw = tangent(MP3.E, MP3.nu, G)
        assert np.allclose(raw, lame(MP3.mu, MP3.lmbda - MP3.mu), rtol=1e-7, atol=1e-6)
    assert dk.drake_elasticity(MP3, "linear") == (MP3.E, MP3.nu)


# --- runs ---------------------------------------------------------------------------------------


@pytest.mark.serial
def test_linear_is_p1_with_its_mass_and_scheme(small_rod, tmp_path):
    """Drake's linear body, 30 steps of h, equals the P1 Newmark here with the one-point mass
    and gamma = 1, beta_N = 1 to round-off (1e-9: the linear solves are direct); so do its
    runs with either Rayleigh coefficient switched off, each differing from MP3's by more than
    1 %: both coefficients act, as alpha M and beta K. With the consistent mass, or with the
    trapezoidal rule, the P1 solution is another one (above 1e-3): the two departures are
    Drake's, and together they are all of its difference from our trapezoidal P1."""
    data = small_rod
    U = drake(data, "linear", tmp_path)
    assert np.all(U[:, data.node_sets["clamped"]] == 0)
    own = p1_newmark(data, mass="one-point", gamma=1.0, beta_n=1.0)
    assert relative(U, own) < 1e-9
    for changed in ({"alpha": 0.0}, {"beta": 0.0}):
        m = MP3.__dict__ | changed
        material = Material(**m)
        other = rod(material=material)
        V = drake(other, "linear", tmp_path)
        assert relative(V, p1_newmark(other, "one-point", 1.0, 1.0)) < 1e-9
        assert relative(V, U) > 1e-2
    trapezoidal_one_point = p1_newmark(data, mass="one-point")
    consistent_drake_scheme = p1_newmark(data, mass="consistent", gamma=1.0, beta_n=1.0)
    assert relative(U, trapezoidal_one_point) > 1e-3
    assert relative(U, consistent_drake_scheme) > 1e-3
    ours = p1_newmark(data)  # our implicit's scheme and mass, on the same tetrahedra
    assert abs(relative(U, ours) - relative(own, ours)) < 1e-8


@pytest.mark.serial
def test_scheme_is_first_order(tmp_path):
    """Over the first second, Drake's distance from a converged solution (the trapezoidal P1 on
    its own mass at h/16, second order: its own error is 256 x below its h one) halves when h
    halves (first order: ratio 2; a second-order scheme gives 4): ratio within 1.6 to 2.4."""
    errors = []
    for k in (1, 2):
        data = rod(steps=30 * k, h=H / k)
        U = drake(data, "linear", tmp_path)[::k]
        fine = p1_newmark(data, mass="one-point", h=H / 16, steps=480)[::16]
        errors.append(relative(U, fine))
    assert 1.6 < errors[0] / errors[1] < 2.4


@pytest.mark.serial
def test_neo_hookean_at_small_strain(tmp_path):
    """At load scale 0.01 (strains about 1e-4: geometric nonlinearity about 1e-4 relative),
    over 90 steps, Drake's neo-Hookean under drake_elasticity follows the linear P1 on its
    scheme and mass within 2 % (E_n max; the bound is Drake's Newton, which stops at a residual
    of 1e-2 times its first, doubled); given MP3's raw E, nu it follows instead the linear P1 of
    Lame constants (mu, lambda - mu) (E = 4375 Pa, nu = -0.25), and its distance from the
    right P1 is that softer P1's distance, within the same 2 %."""
    data = rod(steps=90, model="neo-hookean", scale=0.01)
    linear = p1_newmark(data, "one-point", 1.0, 1.0)
    assert relative(drake(data, "neo-hookean", tmp_path), linear) < 0.02

    lam_eff = MP3.lmbda - MP3.mu
    E_eff = MP3.mu * (3 * lam_eff + 2 * MP3.mu) / (lam_eff + MP3.mu)
    nu_eff = lam_eff / (2 * (lam_eff + MP3.mu))
    soft = Material("MP3 raw neo-Hookean", E=E_eff, nu=nu_eff, rho=MP3.rho, alpha=1.0, beta=0.1)
    soft_p1 = p1_newmark(data, "one-point", 1.0, 1.0, material=soft)
    with unittest.mock.patch.object(dk, "drake_elasticity", lambda m, v: (m.E, m.nu)):
        raw = drake(data, "neo-hookean", tmp_path)
    assert relative(raw, soft_p1) < 0.02
    assert relative(soft_p1, linear) > 0.1  # the softer rod is another rod
    assert abs(relative(raw, linear) - relative(soft_p1, linear)) < 0.02


@pytest.mark.serial
def test_run_writes_the_series_and_reports_failures(small_rod, tmp_path):
    """A run leaves drake.xdmf: the displacement at t_0..t_30 on the tetrahedra, zero at t = 0,
    sagging; an unknown variant comes back failed; a load 1e5 times the rod's (gravity
    5000 m/s^2) carries the tip beyond 100 x the rod's extent (50 m) and fails there, NaN on."""
    data = small_rod
    result = dk.run(data, "linear", tmp_path)
    assert result.status == "ok" and result.reason is None and result.wall_time_s > 0
    assert result.dofs == 3 * len(data.nodes) and result.mesh.startswith("tetrahedra")
    assert 'TopologyType="Tetrahedron"' in result.series.read_text()
    with h5py.File(tmp_path / "drake.h5") as f:
        U = np.array([f[f"/Function/displacement/{i}"][...] for i in range(data.steps + 1)])
    assert np.all(U[0] == 0) and np.all(np.isfinite(U))
    tip = np.argmin(np.linalg.norm(data.nodes - np.asarray(data.probe), axis=1))
    assert -0.05 < U[-1, tip, 1] < -0.005  # about 2 cm down at t = 1 s

    unknown = dk.run(data, "neo-hookean", tmp_path / "x")
    assert unknown.status == "failed" and "does not pose" in unknown.reason

    blown = dk.run(rod(scale=1e5), "linear", tmp_path)
    assert blown.status == "failed" and "exceeds 100 x" in blown.reason
    with h5py.File(tmp_path / "drake.h5") as f:
        assert np.all(np.isnan(f["/Function/displacement/30"][...]))
