"""The Kratos runner of `tissuebench external` (workflows/simulators/kratos.py) on the small rod
(mesh size 2, 30 steps of h = 1/30 s): its Q1 hexahedra against our own implicit and
implicit-lumped on the same grid (and its plane-strain quadrilaterals on the block, the
needle prescribed), its P1 tetrahedra against an independent dense P1 solve on
the same split (trapezoidal rule and Bossak), the departures it would have left (Kratos's own
a_0 = 0) told apart, and its failures recorded. Serial: Kratos runs in a child process, one
thread; about 15 s."""

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from p1 import p1_matrices as p1_system

from tissuebench.workflows.simulators import kratos as kr

pytestmark = pytest.mark.outside  # an outside simulator: make external-tests

if kr.available() is not None:
    pytest.skip(kr.available(), allow_module_level=True)

from tissuebench.solvers import get_integrator  # noqa: E402
from tissuebench.solvers.materials import get_material  # noqa: E402
from tissuebench.solvers.simulate import simulate  # noqa: E402
from tissuebench.solvers.system import System  # noqa: E402
from tissuebench.workflows.compare.posing import build  # noqa: E402
from tissuebench.workflows.io.xdmf import gather_series  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.newton import split_hexahedra  # noqa: E402

H = 1 / 30  # the paper's h, s
STEPS = 30
# Kratos and our implicit solve the same linear system every step with a direct LU: they
# differ by round-off growing with the conditioning of M + hC/2 + h^2 K/4 over 30 steps
# (measured 2e-15 relative); 1e-9 relative leaves six orders for other machines' BLAS.
SAME = 1e-9


@pytest.fixture(scope="module")
def rod():
    """(Exported rod of mesh size 2 with 30 steps, its Benchmark)."""
    data, bench, _ = build(
        "rod", 2, {}, get_material("MP3"), "linear", H, STEPS, "strain", "dynamic", MPI.COMM_WORLD
    )
    return data, bench


@pytest.fixture(scope="module")
def block():
    """(Exported block MP1 of mesh size 4 with 30 steps: the needle moving throughout, its
    Benchmark)."""
    data, bench, _ = build(
        "block", 4, {}, get_material("MP1"), "linear", H, STEPS, "strain", "dynamic", MPI.COMM_WORLD
    )
    return data, bench


def ours(rod, algorithm: str) -> np.ndarray:
    """Our algorithm's displacement (steps + 1, N, 3) m on the export's nodes."""
    data, bench = rod
    system = System(bench, data.material, plane="strain")
    integrator = get_integrator(algorithm, system, H, solver="direct", model="linear")
    try:
        run = simulate(integrator, STEPS, bench.extent, algorithm)
    finally:
        integrator.destroy()
    return gather_series(system.V, {"u": run.u})[1]["u"]


def kratos(data, variant: str, workdir) -> np.ndarray:
    """Run variant and read its series back (steps + 1, N, 3) m."""
    result = kr.run(data, variant, workdir)
    assert result.status == "ok", result.reason
    with h5py.File(workdir / "kratos.h5") as f:
        return np.array([f[f"/Function/displacement/{i}"][...] for i in range(data.steps + 1)])


def relative(U, R) -> float:
    return float(np.abs(U - R).max() / np.abs(R).max())


# --- an independent P1 solve on the same tetrahedra --------------------------------------------


def p1_matrices(data, tets):
    """Dense K, consistent M and the body force f of P1 on tets (clamped rows included;
    tests/p1.py, independent of Kratos)."""
    m = data.material
    K, M, f = p1_system(data.nodes, tets, m.mu, m.lmbda, m.rho, data.gravity)
    return K.toarray(), M["consistent"].toarray(), f


def p1_dynamic(data, tets, alpha_m: float) -> np.ndarray:
    """Bossak-Newmark on P1 (alpha_m = 0: the trapezoidal rule): (1 - alpha_m) M a_{n+1} +
    alpha_m M a_n + C v_{n+1} + K u_{n+1} = f, beta = (1 - alpha_m)^2 / 4, gamma = 1/2 -
    alpha_m, C = alpha M + beta_R K, a_0 from M a_0 = f; (steps + 1, N, 3) m."""
    K, M, f = p1_matrices(data, tets)
    m = data.material
    C = m.alpha * M + m.beta * K
    clamped = (3 * data.node_sets["clamped"][:, None] + np.arange(3)).ravel()
    free = np.setdiff1d(np.arange(len(f)), clamped)
    K, M, C, f = K[np.ix_(free, free)], M[np.ix_(free, free)], C[np.ix_(free, free)], f[free]
    beta, gamma, h = (1 - alpha_m) ** 2 / 4, 0.5 - alpha_m, data.h
    u, v = np.zeros(len(f)), np.zeros(len(f))
    a = np.linalg.solve(M, f)
    S = (1 - alpha_m) * M + gamma * h * C + beta * h * h * K
    U = np.zeros((data.steps + 1, 3 * len(data.nodes)))
    for i in range(1, data.steps + 1):
        u_p = u + h * v + (0.5 - beta) * h * h * a
        v_p = v + (1 - gamma) * h * a
        a = np.linalg.solve(S, f - alpha_m * M @ a - C @ v_p - K @ u_p)
        u, v = u_p + beta * h * h * a, v_p + gamma * h * a
        U[i, free] = u
    return U.reshape(data.steps + 1, -1, 3)


# --- tests -------------------------------------------------------------------------------------


@pytest.mark.serial
def test_hexahedra_are_our_implicit_and_a0_is_the_only_departure(rod, tmp_path, monkeypatch):
    """hex8-newmark (Q1, consistent mass, trapezoidal, the SPEC's a_0 set) is our implicit to
    round-off; hex8-newmark-lumped our implicit-lumped. Left with Kratos's own a_0 = 0, the
    first step is exactly half ours (trapezoidal rule from u = v = 0: ours u_1 = h^2/2 S^-1 f,
    Kratos's h^2/4 S^-1 f with S = M + hC/2 + h^2 K/4), and the series stays off by a few %
    (the velocity h a_0 / 2 it lacks, damped by alpha = 1/s: measured 3.1 %)."""
    data, _ = rod
    implicit, lumped = ours(rod, "implicit"), ours(rod, "implicit-lumped")
    (tmp_path / "a").mkdir()
    U = kratos(data, "hex8-newmark", tmp_path / "a")
    assert relative(U, implicit) < SAME
    (tmp_path / "b").mkdir()
    U_lumped = kratos(data, "hex8-newmark-lumped", tmp_path / "b")
    assert relative(U_lumped, lumped) < SAME
    assert relative(U_lumped, implicit) > 0.01  # the lumping is seen: measured 6.9 %

    monkeypatch.setattr(kr, "SPEC_INITIAL_ACCELERATION", False)
    (tmp_path / "c").mkdir()
    U_zero = kratos(data, "hex8-newmark", tmp_path / "c")
    assert np.allclose(U_zero[1], implicit[1] / 2, rtol=0, atol=SAME * np.abs(implicit[1]).max())
    assert 0.01 < relative(U_zero, implicit) < 0.1


@pytest.mark.serial
def test_tetrahedra_and_bossak_match_an_independent_p1_solve(rod, tmp_path):
    """tet4-newmark and tet4-bossak on newton.py's split equal a dense P1 Bossak-Newmark solve
    (alpha_m = 0 and -0.3: beta = 0.4225, gamma = 0.8 as the docstring says) to round-off,
    and Bossak differs from the trapezoidal rule (its dissipation: measured 4.5e-4 over 1 s on
    the hexahedra) by more than round-off."""
    data, _ = rod
    tets = split_hexahedra(data.nodes, data.cells)
    trapezoidal = p1_dynamic(data, tets, 0.0)
    bossak = p1_dynamic(data, tets, kr.BOSSAK_ALPHA_M)
    for variant, reference in (("tet4-newmark", trapezoidal), ("tet4-bossak", bossak)):
        (tmp_path / variant).mkdir()
        U = kratos(data, variant, tmp_path / variant)
        assert relative(U, reference) < SAME, variant
    assert relative(bossak, trapezoidal) > 1e3 * SAME
    with h5py.File(tmp_path / "tet4-bossak" / "kratos.h5") as f:
        assert f["/Mesh/mesh/topology"].shape == (6 * len(data.cells), 4)


@pytest.mark.serial
def test_block_with_its_moving_needle_is_our_implicit(block, tmp_path, monkeypatch):
    """quad4-newmark (plane strain Q1) on the block, the needle's u, v and a prescribed every
    step, is our implicit to round-off; left with the v and a that Kratos derives from the
    needle's u by its Newmark formulas (the trapezoidal rule makes them alternate step by step)
    it departs by far more than round-off (measured 3.1 % of the largest displacement)."""
    data, _ = block
    implicit = ours(block, "implicit")
    assert set(kr.variants(data)) == {"quad4-newmark", "quad4-newmark-lumped", "quad4-bossak"}
    (tmp_path / "a").mkdir()
    U = kratos(data, "quad4-newmark", tmp_path / "a")
    assert relative(U, implicit) < SAME
    monkeypatch.setattr(kr, "SPEC_CONSTRAINED_RATES", False)
    (tmp_path / "b").mkdir()
    U_own = kratos(data, "quad4-newmark", tmp_path / "b")
    assert relative(U_own, implicit) > 1e3 * SAME


@pytest.mark.serial
def test_what_is_posed_and_what_fails(rod, tmp_path, monkeypatch):
    """The dynamic linear rod poses the hex8 and tet4 variants; the static procedure, the
    block's neo-Hookean and the rod's corotational none, each with its reason. An unknown
    variant, a Kratos error (an element it does not know) and a blow-up (gravity x 1e6:
    displacements beyond 100 x the extent in the first steps) come back failed with their
    reasons, the blow-up's series NaN from there."""
    data, _ = rod
    posed = {name for name in kr.VARIANTS if name.startswith(("hex8", "tet4"))}
    assert set(kr.variants(data)) == posed and len(posed) == 5 and kr.skipped(data) == {}
    for benchmark, size, material, model, procedure in (
        ("rod", 2, "MP3", "linear", "static"),
        ("block", 4, "MP1", "neo-hookean", "dynamic"),
        ("rod", 2, "MP3", "corotational", "dynamic"),  # (neo-hookean: ..._nonlinear.py)
    ):
        other, _, _ = build(
            benchmark, size, {}, get_material(material), model, H, 2, "strain", procedure,
            MPI.COMM_WORLD,
        )  # fmt: skip
        assert kr.variants(other) == {} and set(kr.skipped(other)) == {"all"}

    unknown = kr.run(data, "no-such-variant", tmp_path)
    assert unknown.status == "failed" and "no-such-variant" in unknown.reason

    (tmp_path / "bad").mkdir()
    monkeypatch.setitem(kr.MESHES, "hex8", ("NoSuchElement3D8N", "reference"))
    bad = kr.run(data, "hex8-newmark", tmp_path / "bad")
    assert bad.status == "failed" and bad.reason.startswith("Kratos failed")
    monkeypatch.undo()

    (tmp_path / "blow").mkdir()
    data.gravity = data.gravity * 1e6
    try:
        blown = kr.run(data, "hex8-newmark", tmp_path / "blow")
    finally:
        data.gravity = data.gravity / 1e6
    assert blown.status == "failed" and blown.reason.startswith("diverged at step")
    with h5py.File(tmp_path / "blow" / "kratos.h5") as f:
        assert np.all(np.isnan(f[f"/Function/displacement/{data.steps}"][...]))
        assert np.all(f["/Function/displacement/0"][...] == 0)


def test_the_contact_benchmark_is_not_posed_and_says_why():
    """A contact export (SPEC 12) gets no Kratos variant (the block's would pose it without
    its needle) and CONTACT_NOTE as the reason; no contact adapter for the runner."""
    data, _, _ = build(
        "contact", 4, {"kappa": 10.0, "load_scale": 1.0}, get_material("MP1"), "linear", H, 2,
        "strain", "dynamic", MPI.COMM_WORLD,
    )  # fmt: skip
    assert kr.variants(data) == {}
    assert kr.skipped(data) == {"all": kr.CONTACT_NOTE}
    assert adapter("kratos") is None
