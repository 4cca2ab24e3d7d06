"""Issue 2: meshes, materials and the assembled K, M, M_L, f against closed forms."""

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem
from helpers import run_script

from tissuebench.meshes import MeshError, get_benchmark
from tissuebench.meshes.block import block_mesh
from tissuebench.meshes.rod import rod_mesh
from tissuebench.solvers.materials import MATERIALS, Material, MaterialError, get_material
from tissuebench.solvers.system import System, sigma

comm = MPI.COMM_WORLD


def owned_nodes(s):
    """Coordinates (n_owned, gdim) of the owned nodes of V, in dof order."""
    n = s.V.dofmap.index_map.size_local
    return s.V.tabulate_dof_coordinates()[:n, : s.gdim]


def vec(s, values):
    x = s.K.createVecRight()
    x.array[:] = np.asarray(values).ravel()
    return x


@pytest.mark.parallel
@pytest.mark.parametrize("name, size, volume", [("block", 6, 1.0), ("rod", 2, 0.5 * 0.25 * 0.25)])
def test_mass_totals(name, size, volume):
    s = System(get_benchmark(name, mesh_size=size))
    rho = s.material.rho
    # u = e_k (unit translation): u^T M u = rho |Omega| for each component k
    x = owned_nodes(s)
    for k in range(s.gdim):
        e = np.zeros_like(x)
        e[:, k] = 1.0
        Me = s.M.createVecLeft()
        s.M.mult(vec(s, e), Me)
        total = comm.allreduce(float(np.dot(e.ravel(), Me.array)))
        assert total == pytest.approx(rho * volume, rel=1e-12)
        lumped = comm.allreduce(float(s.ML.array.reshape(-1, s.gdim)[:, k].sum()))
        assert lumped == pytest.approx(rho * volume, rel=1e-12)
    assert comm.allreduce(float(s.ML.array.min()), op=MPI.MIN) > 0


def rigid_modes(x):
    """Translations and infinitesimal rotations sampled at nodes x (n, d)."""
    n, d = x.shape
    modes = []
    for k in range(d):
        t = np.zeros_like(x)
        t[:, k] = 1.0
        modes.append(t)
    axes = [(0, 1)] if d == 2 else [(0, 1), (1, 2), (2, 0)]
    for i, j in axes:
        r = np.zeros_like(x)
        r[:, i], r[:, j] = -x[:, j], x[:, i]
        modes.append(r)
    return modes


@pytest.mark.parametrize("name, size", [("block", 6), ("rod", 2)])
def test_rigid_body_modes_have_zero_energy(name, size):
    s = System(get_benchmark(name, mesh_size=size))
    for mode in rigid_modes(owned_nodes(s)):
        Kr = s.K.createVecLeft()
        s.K.mult(vec(s, mode), Kr)
        scale = s.K.norm() * comm.allreduce(float(np.sum(mode**2))) ** 0.5
        assert Kr.norm() < 1e-12 * scale


@pytest.mark.parametrize(
    "name, size, plane", [("block", 4, "strain"), ("block", 4, "stress"), ("rod", 2, "strain")]
)
def test_patch_linear_field(name, size, plane):
    """u = A x: the stress is the constant 2 mu sym(A) + lambda tr(A) I in every cell, and
    K u vanishes at nodes away from the boundary (no body force)."""
    s = System(get_benchmark(name, mesh_size=size), plane=plane)
    d = s.gdim
    rng = np.random.default_rng(3)
    A = rng.normal(size=(d, d)) * 1e-3
    if plane == "stress":  # uniaxial stress: sigma = (E eps, 0) when eps_yy = -nu eps_xx
        A = np.diag([1e-3, -s.material.nu * 1e-3])
    u = fem.Function(s.V)
    u.interpolate(lambda x: A @ x[:d])
    mu, lmbda = s.mu.value, s.lmbda.value
    expected = 2 * mu * (A + A.T) / 2 + lmbda * np.trace(A) * np.eye(d)
    if plane == "stress":
        assert expected[0, 0] == pytest.approx(s.material.E * 1e-3, rel=1e-12)
        assert abs(expected[1, 1]) < 1e-12 * s.material.E
    cell = s.mesh.basix_cell()
    import basix

    points = basix.create_lattice(cell, 2, basix.LatticeType.equispaced, True)
    expr = fem.Expression(sigma(u, s.mu, s.lmbda), points)
    cells = np.arange(s.mesh.topology.index_map(d).size_local, dtype=np.int32)
    values = expr.eval(s.mesh, cells).reshape(len(cells), len(points), d, d)
    assert np.allclose(values, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    # residual K u at interior nodes
    Ku = s.K.createVecLeft()
    s.K.mult(vec(s, u.x.array[: s.K.getLocalSize()[0]]), Ku)
    x = owned_nodes(s)
    hi = np.array([1.0, 1.0] if d == 2 else [0.5, 0.25, 0.25])
    interior = np.all((x > 1e-9) & (x < hi - 1e-9), axis=1)
    r = Ku.array.reshape(-1, d)[interior]
    assert comm.allreduce(len(r)) > 0
    assert (
        comm.allreduce(float(np.abs(r).max(initial=0)), op=MPI.MAX)
        < 1e-12 * s.K.norm() * np.abs(A).max()
    )


@pytest.mark.parallel
def test_node_counts_and_needle():
    for N in (4, 20):
        m = block_mesh(N).mesh
        assert m.topology.index_map(0).size_global == (N + 1) ** 2
        assert m.topology.index_map(2).size_global == N * N
    for n in (1, 3):
        m = rod_mesh(n).mesh
        assert m.topology.index_map(0).size_global == (2 * n + 1) * (n + 1) ** 2
        assert m.topology.index_map(3).size_global == 2 * n**3
    tagged = block_mesh(20)
    dim, needle = tagged.entities("needle")
    assert dim == 0
    owned = needle[needle < tagged.mesh.topology.index_map(0).size_local]
    assert comm.allreduce(len(owned)) == 1
    x = tagged.mesh.geometry.x
    tagged.mesh.topology.create_connectivity(0, 2)
    from dolfinx.mesh import entities_to_geometry

    coords = (
        x[entities_to_geometry(tagged.mesh, 0, owned).ravel()] if len(owned) else np.zeros((0, 3))
    )
    found = comm.allgather(coords)
    coords = np.concatenate(found)
    assert np.allclose(coords[0, :2], [1.0, 0.5])


@pytest.mark.parallel
def test_needle_width_takes_right_edge_nodes():
    # nodes of N = 20 on the right edge are 0.05 apart: w = 0.2 covers y in [0.4, 0.6], 5 nodes
    s = System(get_benchmark("block", mesh_size=20, needle_width=0.2))
    moved = s.prescribed(1.0)[0] != 0
    assert comm.allreduce(int(moved.sum())) == 5
    assert np.allclose(s.prescribed(1.0)[0][moved], -0.08)


def test_materials_and_refusals(tmp_path):
    assert get_material("MP2").E == 60_000 and MATERIALS["MP3"].rho == 10_000
    assert Material("x", 1.0, 0.3, 1.0).lame("strain") == pytest.approx(
        (1 / 2.6, 0.3 / (1.3 * 0.4))
    )
    tmp_path = (
        tmp_path / f"rank{MPI.COMM_WORLD.rank}"
    )  # each rank its own files (tmp_path is shared)
    tmp_path.mkdir()
    good = tmp_path / "liver.toml"
    good.write_text('name = "liver"\nE = 640.0\nnu = 0.45\nrho = 1060\nalpha = 1.0\nbeta = 0.1\n')
    assert get_material(str(good)).E == 640.0
    bad = {
        "E = -1.0\nnu = 0.3\nrho = 1.0\n": "E must be > 0",
        "E = 1.0\nnu = 0.5\nrho = 1.0\n": "nu must satisfy",
        "E = 1.0\nnu = 0.3\nrho = 0\n": "rho must be > 0",
        "E = 1.0\nnu = 0.3\nrho = 1.0\nalpha = -1\n": "alpha must be >= 0",
        "E = 1.0\nnu = 0.3\n": "missing rho",
        "E = 1.0\nnu = 0.3\nrho = 1.0\nyoung = 2\n": "unknown key",
        "E = [1.0\n": "not valid TOML",
        'E = "soft"\nnu = 0.3\nrho = 1.0\n': "E must be a finite number",
    }
    for i, (text, message) in enumerate(bad.items()):
        path = tmp_path / f"bad{i}.toml"
        path.write_text(text)
        with pytest.raises(MaterialError, match=message):
            get_material(str(path))
    with pytest.raises(MaterialError, match="does not exist"):
        get_material(str(tmp_path / "missing.toml"))
    with pytest.raises(MaterialError, match="unknown material"):
        get_material("MP9")
    with pytest.raises(MaterialError, match="plane"):
        Material("x", 1.0, 0.3, 1.0).lame("axisymmetric")


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(name="block", mesh_size=5), "must be even"),
        (dict(name="block", mesh_size=0), "positive whole number"),
        (dict(name="rod", mesh_size=-2), "positive whole number"),
        (dict(name="block", mesh_size=2.5), "positive whole number"),
        (dict(name="block", needle_width=1.5), "needle width"),
        (dict(name="sphere"), "unknown benchmark"),
    ],
)
def test_mesh_refusals(kwargs, message):
    with pytest.raises(MeshError, match=message):
        get_benchmark(**kwargs)


def test_msh_export(tmp_path):
    import meshio

    block_mesh(4, msh_path=tmp_path / "block.msh")
    comm.barrier()
    m = meshio.read(tmp_path / "block.msh")
    assert len(m.points) == 25 and sum(len(c.data) for c in m.cells if c.type == "quad") == 16


@pytest.mark.serial
def test_norms_serial_equal_parallel():
    """The assembled system does not depend on the partition, and the compiled block-CSR
    products (solvers/blockcsr.py, ghost columns included) equal PETSc's MatMult to
    round-off, on 1 and 2 ranks."""
    serial = run_script("mpi_system.py", ranks=1)
    parallel = run_script("mpi_system.py", ranks=2)
    assert serial["norms"].keys() == parallel["norms"].keys()
    for key in serial["norms"]:
        assert parallel["norms"][key] == pytest.approx(
            serial["norms"][key], rel=1e-12, abs=1e-300
        ), key
    for result in (serial, parallel):
        assert len(result["kernel"]) == 6
        for key, diff in result["kernel"].items():
            assert diff < 1e-14, key


@pytest.mark.serial
def test_package_names_do_not_leak():
    """The code folders are tissuebench.* only: no bare `metrics` or `solvers` on sys.path."""
    import importlib.util

    import tissuebench.metrics
    import tissuebench.solvers

    for bare in ("metrics", "solvers", "meshes", "workflows"):
        assert importlib.util.find_spec(bare) is None, bare
    assert tissuebench.metrics.Metrics.__module__ == "tissuebench.metrics.table"
