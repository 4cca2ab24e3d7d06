"""The MuJoCo runner of `tissuebench external` (workflows/simulators/mujoco.py) on the small rod
(mesh size 2: 4 x 2 x 2 hexahedra split into 96 tetrahedra): the posed
masses and damping, MuJoCo's step against backward Euler on linear P1 (a dense numpy solve on
the same tetrahedra, independent of MuJoCo), the departures told apart (integrator, mass,
alpha damping, substeps, geometric nonlinearity), the objectivity of its stiffness damping,
and a run's files and failures. Serial: MuJoCo runs on one process; about 5 s."""

import dataclasses

from mpi4py import MPI

import h5py
import numpy as np
import pytest
from p1 import p1_matrices as p1_system

pytestmark = pytest.mark.outside  # an outside simulator: make external-tests

mujoco = pytest.importorskip("mujoco")

from tissuebench.solvers.materials import get_material  # noqa: E402
from tissuebench.workflows.compare.posing import build  # noqa: E402
from tissuebench.workflows.simulators import mujoco as mj  # noqa: E402

H = 1 / 30  # the paper's h, s
LENGTH, HEIGHT, DEPTH = 0.5, 0.25, 0.25  # the rod, m (SPEC section 5)


def rod(steps=30, material=None, procedure="dynamic", model="linear", scale=1.0, h=H):
    """The rod of mesh size 2 as exported (gravity times scale)."""
    material = material or get_material("MP3")
    data, _, _ = build(
        "rod", 2, {"load_scale": scale}, material, model, h, steps, "strain", procedure,
        MPI.COMM_WORLD,
    )  # fmt: skip
    return data


@pytest.fixture(scope="module")
def small_rod():
    return rod()


def p1_matrices(data, tets):
    """Linear P1 on the tetrahedra: (K, consistent M, row-sum lumped M_L), dense (N3 x N3),
    SI units (tests/p1.py, independent of MuJoCo)."""
    m = data.material
    K, M, _ = p1_system(data.nodes, tets, m.mu, m.lmbda, m.rho, data.gravity)
    return K.toarray(), M["consistent"].toarray(), M["lumped"].toarray()


def p1_run(data, tets, mass="lumped", scheme="backward-euler", substeps=1, alpha=None):
    """Linear P1 dynamics under the export's gravity and clamp, (steps + 1, N, 3) m:
    C = alpha M + beta K; "backward-euler" M (v+ - v) = h (f - K (u + h v+) - C v+),
    u+ = u + h v+ (MuJoCo's `discrete` step, linearised), "euler" (M + h alpha M)(v+ - v) =
    h (f - K u - C v), u+ = u + h v+ (MuJoCo's `Euler`: its joint damping implicit), or SPEC
    section 3's "trapezoidal" Newmark (initial acceleration from the equation of motion), at
    h / substeps."""
    m = data.material
    alpha = m.alpha if alpha is None else alpha
    K, Mc, ML = p1_matrices(data, tets)
    M = ML if mass == "lumped" else Mc
    n = len(K)
    clamped = (3 * mj.clamped_nodes(data)[:, None] + np.arange(3)).ravel()
    free = np.setdiff1d(np.arange(n), clamped)
    K, M = K[np.ix_(free, free)], M[np.ix_(free, free)]
    C = alpha * M + m.beta * K
    f = M @ np.tile(data.gravity, len(data.nodes))[free]  # P1: the consistent load M g
    h = data.h / substeps
    U = np.zeros((data.steps + 1, n))
    u, v = np.zeros(len(free)), np.zeros(len(free))
    a = np.linalg.solve(M, f)
    step = np.linalg.inv({
        "backward-euler": M + h * C + h * h * K,
        "euler": M + h * alpha * M,
        "trapezoidal": M + h / 2 * C + h * h / 4 * K,
    }[scheme])  # fmt: skip
    for i in range(data.steps):
        for _ in range(substeps):
            if scheme == "backward-euler":
                v = step @ (M @ v + h * (f - K @ u))
                u = u + h * v
            elif scheme == "euler":
                v = v + h * step @ (f - K @ u - C @ v)
                u = u + h * v
            else:
                up, vp = u + h * v + h * h / 4 * a, v + h / 2 * a
                a = step @ (f - C @ vp - K @ up)
                u, v = up + h * h / 4 * a, vp + h / 2 * a
        U[i + 1, free] = u
    return U.reshape(data.steps + 1, -1, 3)


def relative(U, R):
    """E_n (SPEC 6) of U against R at every step i >= 1."""
    num = np.linalg.norm((U - R).reshape(len(R), -1), axis=1)[1:]
    return num / np.linalg.norm(R.reshape(len(R), -1), axis=1)[1:]


# --- the posed model --------------------------------------------------------------------------


@pytest.mark.serial
def test_posed_masses_damping_and_pins(small_rod):
    """Each free vertex's body holds its row-sum lumped mass (total rho * volume with the
    clamped nodes' share), its three slide joints alpha m_i; the clamped nodes are world
    vertices without degrees of freedom; the displacement read from qpos is the vertex
    position minus the exported node."""
    data = small_rod
    tets = mj.tetrahedra(data)
    assert tets.shape == (6 * len(data.cells), 4) and mj.tet_volumes(data.nodes, tets).min() > 0
    model, address = mj.compile_model(data, tets)
    masses = mj.lumped_masses(data.nodes, tets, data.material.rho)
    assert masses.sum() == pytest.approx(data.material.rho * LENGTH * HEIGHT * DEPTH, rel=1e-12)
    clamped = data.node_sets["clamped"]
    assert np.all(address[clamped] == -1) and np.sum(address >= 0) == len(data.nodes) - len(clamped)
    assert model.nv == 3 * (len(data.nodes) - len(clamped))
    bodies = model.flex_vertbodyid
    free = address >= 0
    assert np.array_equal(model.body_mass[bodies[free]], masses[free])
    damping = model.dof_damping[model.body_dofadr[bodies[free]][:, None] + np.arange(3)]
    assert np.allclose(damping, data.material.alpha * masses[free][:, None], rtol=1e-15)

    d = mujoco.MjData(model)
    for _ in range(3):
        mujoco.mj_step(model, d)
    mujoco.mj_forward(model, d)
    u = mj.displacement(d.qpos, address)
    assert np.abs(u).max() > 1e-6
    assert np.allclose(d.flexvert_xpos - data.nodes, u, rtol=0, atol=1e-15)


@pytest.mark.serial
def test_small_loads_step_as_backward_euler_on_p1(small_rod):
    """At small loads MuJoCo's `discrete` step is backward Euler on linear P1 with M_L and
    C = alpha M_L + beta K, on every node and step: what is left is SVK's geometric
    nonlinearity, which grows with the load (relative to the displacement, in proportion to
    it: ten times the load, ten times the difference, 1 % allowed for the next order), and is
    below 1e-5 at load scale 1e-4 (measured 7.4e-3 at scale 1 after 1 s, so 7.4e-7).
    Each departure is told apart: against the trapezoidal rule (SPEC's implicit) or the
    consistent mass, or with flexcomp's own equal masses, or without the alpha damping, the
    difference is orders above that; ten substeps are backward Euler at h / 10, and `euler-10`
    symplectic Euler at h / 10 with the alpha damping implicit."""
    data = small_rod
    tets = mj.tetrahedra(data)
    differences = {}
    for scale in (1e-4, 1e-3):
        small = dataclasses.replace(data, gravity=data.gravity * scale)
        be = p1_run(small, tets)
        U = mj.simulate(small, "discrete")["U"]
        differences[scale] = relative(U, be).max()
        if scale == 1e-4:
            assert relative(U, p1_run(small, tets, scheme="trapezoidal")).mean() > 1e-2
            assert relative(U, p1_run(small, tets, mass="consistent")).mean() > 1e-3
            no_alpha = mj.integrate(
                small, tets, 1, data.steps, mj.compile_model(small, tets, alpha=0.0)
            )
            assert relative(no_alpha["U"], p1_run(small, tets, alpha=0.0)).max() < 1e-5
            assert relative(no_alpha["U"], be).max() > 1e-3
            U10 = mj.simulate(small, "discrete-10")["U"]
            assert relative(U10, p1_run(small, tets, substeps=10)).max() < 1e-5
            assert relative(U10, be).max() > 1e-2
            Ue = mj.simulate(small, "euler-10")["U"]
            assert relative(Ue, p1_run(small, tets, scheme="euler", substeps=10)).max() < 1e-5
            assert relative(Ue, p1_run(small, tets, substeps=10)).max() > 1e-3  # 4e-3
    assert differences[1e-4] < 1e-5
    assert differences[1e-3] / differences[1e-4] == pytest.approx(10.0, rel=0.01)

    # flexcomp's own masses (rho spread equally over the points) instead of M_L
    model, address = mj.compile_model(data, tets)
    equal = mujoco.MjModel.from_xml_string(mj.mjcf(data, tets))
    for b in range(1, model.nbody):
        equal.dof_damping[equal.body_dofadr[b] : equal.body_dofadr[b] + 3] = (
            data.material.alpha * equal.body_mass[b]
        )
    ours = mj.integrate(data, tets, 1, data.steps, (model, address))["U"]
    theirs = mj.integrate(data, tets, 1, data.steps, (equal, address))["U"]
    assert relative(theirs, ours).mean() > 0.05


@pytest.mark.serial
def test_stiffness_damping_is_objective(small_rod):
    """MuJoCo's flex damping acts on the Green strain rate: on the rod (unclamped) turned a
    quarter round about z and spinning about z, its passive force vanishes (to round-off),
    where SPEC 8's beta K_0 v does not; at rest, under a uniform stretching rate, it is
    beta K_0 v."""
    data = dataclasses.replace(small_rod, node_sets={}, motions={})
    tets = mj.tetrahedra(data)
    model, address = mj.compile_model(data, tets, alpha=0.0)
    d = mujoco.MjData(model)
    X = data.nodes
    centre = X.mean(axis=0)
    R = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 1]])
    W = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]])  # the spin about z, 1 rad/s
    K = p1_matrices(data, tets)[0]
    beta = data.material.beta

    def passive(x, v):
        for i, a in enumerate(address):
            d.qpos[a : a + 3] = x[i] - X[i]
            d.qvel[a : a + 3] = v[i]
        mujoco.mj_forward(model, d)
        force = np.zeros_like(X)
        for i, a in enumerate(address):
            force[i] = d.qfrc_passive[a : a + 3]  # slide joints: qpos and dof addresses agree
        return force

    x = (X - centre) @ R.T + centre
    v = (x - centre) @ W.T
    spin = passive(x, v)
    k0v = (beta * K @ v.ravel()).reshape(-1, 3)
    assert np.abs(spin).max() < 1e-9 * np.abs(k0v).max()
    assert np.abs(k0v).max() > 1e-2

    # MuJoCo's strain rate is a difference over one step, (E(q + h v) - E(q)) / h: quadratic
    # in v, a relative O(h |grad v|) = 3.3e-5 here (measured 1.7e-5), and ten times less at h/10
    stretch = np.diag([1e-3, -2e-4, 5e-4])  # 1/s
    v = (X - centre) @ stretch.T
    linear = -(beta * K @ v.ravel()).reshape(-1, 3)
    gaps = []
    for h in (H, H / 10):
        model.opt.timestep = h
        gaps.append(np.abs(passive(X, v) - linear).max() / np.abs(linear).max())
    assert gaps[0] < H * np.abs(stretch).max()  # h |grad v| = 3.3e-5
    assert gaps[1] / gaps[0] == pytest.approx(0.1, rel=0.05)


@pytest.mark.serial
def test_variants_and_skips(small_rod):
    """The dynamic rod poses every variant, each description naming its steps and how SVK
    stands to the export's model, on hexahedra (split) or on our tetrahedra (as they are);
    the static procedure and the block pose nothing, with why."""
    assert set(mj.variants(small_rod)) == set(mj.VARIANTS)
    assert all("SVK in place of linear" in line for line in mj.variants(small_rod).values())
    assert all(
        "SVK: the export's model" in line for line in mj.variants(rod(2, model="svk")).values()
    )
    static = rod(steps=2, procedure="static")
    assert mj.variants(static) == {} and "dynamics only" in mj.skipped(static)["all"]
    block, _, _ = build(
        "block", 4, {}, get_material("MP1"), "linear", H, 2, "strain", "dynamic", MPI.COMM_WORLD
    )
    assert mj.variants(block) == {} and "mocap" in mj.skipped(block)["all"]
    assert mj.skipped(small_rod) == {}
    tets, _, _ = build(
        "rod", 2, {"cell": "tetrahedron"}, get_material("MP3"), "linear", H, 2, "strain",
        "dynamic", MPI.COMM_WORLD,
    )  # fmt: skip
    assert set(mj.variants(tets)) == set(mj.VARIANTS)
    assert np.array_equal(np.sort(mj.tetrahedra(tets), axis=1), np.sort(tets.cells, axis=1))


# --- runs -------------------------------------------------------------------------------------


@pytest.mark.serial
def test_run_writes_the_series_and_reports_failures(small_rod, tmp_path, monkeypatch):
    """A run leaves mujoco.xml and mujoco.xdmf: the displacement at t_0..t_30 on 6 tetrahedra
    per hexahedron, zero at t = 0 and on the clamp, finite, sagging; an unknown variant comes
    back failed, and the rod under 1000 times its gravity collapses at its clamp: inverted
    tetrahedra, status failed, NaN from there on; `euler-10` at h = 0.5 s blows up (MuJoCo's
    own reset)."""
    data = small_rod
    result = mj.run(data, "discrete", tmp_path)
    assert result.status == "ok" and result.reason is None
    assert result.dofs == 3 * len(data.nodes) and result.wall_time_s > 0
    assert result.mesh.startswith("tetrahedra") and "mj_step" in result.timing
    assert result.series == tmp_path / "mujoco.xdmf" and result.field == "displacement"
    assert (tmp_path / "mujoco.xml").read_text().startswith("<mujoco")
    assert 'TopologyType="Tetrahedron"' in result.series.read_text()
    with h5py.File(tmp_path / "mujoco.h5") as f:
        assert f["/Mesh/mesh/topology"].shape == (6 * len(data.cells), 4)
        U = np.array([f[f"/Function/displacement/{i}"][...] for i in range(data.steps + 1)])
    assert U.shape == (data.steps + 1, len(data.nodes), 3)
    assert np.all(U[0] == 0) and np.all(U[:, data.node_sets["clamped"]] == 0)
    assert np.all(np.isfinite(U))
    tip = np.argmin(np.linalg.norm(data.nodes - np.asarray(data.probe), axis=1))
    assert -0.05 < U[-1, tip, 1] < -0.005  # sagging under gravity, about 2 cm at t = 1 s

    unknown = mj.run(data, "no-such-variant", tmp_path / "x")
    assert unknown.status == "failed" and "no-such-variant" in unknown.reason

    crushed = rod(steps=30, scale=1000.0)  # 50 m/s^2: the clamped end's tetrahedra invert
    blown = mj.run(crushed, "discrete", tmp_path)
    assert blown.status == "failed" and blown.reason.startswith("diverged at step")
    with h5py.File(tmp_path / "mujoco.h5") as f:
        last = f[f"/Function/displacement/{crushed.steps}"][...]
    assert np.all(np.isnan(last))

    coarse = rod(steps=10, h=0.5)  # euler-10 at 0.05 s: beyond its stable step
    (tmp_path / "coarse").mkdir()
    user = tmp_path / "user"  # the folder the user runs tissuebench from
    user.mkdir()
    monkeypatch.chdir(user)
    blown = mj.run(coarse, "euler-10", tmp_path / "coarse")
    assert blown.status == "failed" and "bad acceleration" in blown.reason
    assert list(user.iterdir()) == []  # MuJoCo's warning log (MUJOCO_LOG.TXT) is not written
