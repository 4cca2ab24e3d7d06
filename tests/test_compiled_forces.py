"""Issue 32 item 4: the compiled element loop of the explicit schemes (solvers/compiled_forces.py)
against the UFL forms it replaces there: f_int and the smallest det F of every nonlinear model
and of F-bar, on distorted meshes of every P1/Q1 cell with a large deformation; the Python
fallback of the rotation; short explicit-lumped runs step by step; serial against 2 ranks."""

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest
import test_models
from dolfinx.mesh import CellType
from helpers import run_script

from tissuebench.meshes import get_benchmark
from tissuebench.meshes.benchmark import Benchmark, Constraint, fixed
from tissuebench.meshes.gmshio import TaggedMesh
from tissuebench.solvers import ALGORITHMS, get_integrator
from tissuebench.solvers.compiled_forces import available
from tissuebench.solvers.elastic import ElasticForces
from tissuebench.solvers.materials import Material
from tissuebench.solvers.models import MODELS
from tissuebench.solvers.nonlinear import ExplicitLumpedModel, ExplicitModel
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System

comm = MPI.COMM_WORLD
NONLINEAR = ["svk", "neo-hookean", "neo-hookean-barrier", "corotational"]
# nu = 0.45: lambda = 9 mu, so that the volumetric terms weigh as in tissue
TISSUE = Material("tissue", E=3000.0, nu=0.45, rho=1000.0)
CELLS = {
    "quadrilateral": (2, CellType.quadrilateral),
    "triangle": (2, CellType.triangle),
    "hexahedron": (3, CellType.hexahedron),
    "tetrahedron": (3, CellType.tetrahedron),
}
N = {2: 6, 3: 3}  # cells per side
TOL = 1e-12  # relative, f_int and min det


def distorted_mesh(cell: str) -> dolfinx.mesh.Mesh:
    """test_models' distorted unit square (cube) in N^gdim cells of `cell`: no cell is a
    parallelogram."""
    gdim, cell_type = CELLS[cell]
    return test_models.distorted_mesh(gdim, N[gdim], cell_type)


def clamped(mesh: dolfinx.mesh.Mesh) -> Benchmark:
    """The mesh clamped at x = 0 (a System needs a constraint)."""
    gdim = mesh.geometry.dim
    nodes = dolfinx.mesh.locate_entities_boundary(mesh, 0, lambda x: np.isclose(x[0], 0.0))
    return Benchmark(
        name="distorted",
        tagged=TaggedMesh(mesh, {}, {}),
        constraints=[Constraint("clamp", 0, nodes, fixed(gdim))],
        gravity=(0.0,) * gdim,
        material="MP1",
        dt=0.01,
        end_time=0.1,
        extent=1.0,
        mesh_size=N[gdim],
    )


def rotation(gdim: int, angle: float) -> np.ndarray:
    """The rotation by `angle` (rad): about z in 2D, about the axis (1, 2, 2)/3 in 3D."""
    c, s = np.cos(angle), np.sin(angle)
    if gdim == 2:
        return np.array([[c, -s], [s, c]])
    a = np.array([1.0, 2.0, 2.0]) / 3
    W = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + s * W + (1 - c) * W @ W


def large_u(system: System) -> np.ndarray:
    """Owned dof values of a large deformation: a 40 degree rotation of a stretch with shear,
    plus a rough field (up to 3 % of a cell per component, a function of the coordinates)."""
    gdim = system.gdim
    n = system.V.dofmap.index_map.size_local
    X = system.V.tabulate_dof_coordinates()[:n, :gdim]
    S = np.diag([1.25, 0.8, 1.1][:gdim]) + 0.1 * (np.ones((gdim, gdim)) - np.eye(gdim))
    A = rotation(gdim, 0.7) @ S - np.eye(gdim)
    rough = 0.03 / N[gdim] * np.sin(X @ np.array([311.7, 175.3, 239.1])[:gdim])[:, None]
    return (X @ A.T + rough * np.array([1.0, -0.7, 0.4])[:gdim]).ravel()


def max_abs(x: np.ndarray) -> float:
    return comm.allreduce(float(np.abs(x).max()) if x.size else 0.0, op=MPI.MAX)


def both_forces(system: System, model: str, u: np.ndarray):
    """(UFL f_int, compiled f_int, UFL min det, compiled min det, compiled ElasticForces)."""
    ufl_forces = ElasticForces(system, MODELS[model])
    compiled = ElasticForces(system, MODELS[model], compiled=True)
    assert compiled.compiled is not None
    x = system.K.createVecLeft()
    x.array[:] = u
    a, b = x.duplicate(), x.duplicate()
    ufl_forces.internal_force(x, a)
    compiled.internal_force(x, b)
    result = a.array.copy(), b.array.copy(), ufl_forces.min_det(), compiled.min_det()
    ufl_forces.destroy()
    return (*result, compiled)


@pytest.mark.parametrize("cell", list(CELLS))
@pytest.mark.parametrize("model", NONLINEAR)
def test_compiled_force_equals_the_ufl_form(cell, model):
    """f_int of the model's C stress in the compiled loop equals the UFL form's assembly, and
    its smallest det F the quadrature-point Expression's, to 1e-12, on a distorted mesh under
    a large deformation (det F from about 0.6 to 1.4)."""
    system = System(clamped(distorted_mesh(cell)), TISSUE)
    assert available(MODELS[model], cell)
    f_ufl, f_c, det_ufl, det_c, _ = both_forces(system, model, large_u(system))
    scale = max_abs(f_ufl)
    assert scale > 0
    assert max_abs(f_c - f_ufl) <= TOL * scale
    assert 0.3 < det_ufl < 1.0
    assert det_c == pytest.approx(det_ufl, rel=TOL)


@pytest.mark.parametrize("cell", ["quadrilateral", "hexahedron"])
@pytest.mark.parametrize("model", ["svk", "neo-hookean", "neo-hookean-barrier"])
def test_compiled_f_bar_equals_the_ufl_form(cell, model):
    """The same for SPEC 11's mean-dilatation with a nonlinear model (F-bar: the cell's mean J
    in the same loop)."""
    system = System(clamped(distorted_mesh(cell)), TISSUE, scheme="mean-dilatation")
    f_ufl, f_c, det_ufl, det_c, _ = both_forces(system, model, large_u(system))
    assert max_abs(f_c - f_ufl) <= TOL * max_abs(f_ufl)
    assert det_c == pytest.approx(det_ufl, rel=TOL)


@pytest.mark.parametrize("cell", ["quadrilateral", "hexahedron"])
def test_rotation_falls_back_to_python_where_newton_fails(cell):
    """Corotational where a cell's centre is inverted (det F < 0 there: the polar Newton
    iteration fails): that cell's R comes from solvers/polar.rotations (the SVD), the force
    still equals the UFL form's, and the smallest det F is negative."""
    system = System(clamped(distorted_mesh(cell)), TISSUE)
    gdim = system.gdim
    n = system.V.dofmap.index_map.size_local
    X = system.V.tabulate_dof_coordinates()[:n, :gdim]
    u = 0.01 * np.sin(X @ np.array([3.0, 5.0, 7.0])[:gdim])[:, None] * np.ones(gdim)
    # the node nearest the centre moved 2.5 (2D) or 5 (3D) cells along x: the cells on its +x
    # side turn inside out, their centres too
    nearest = np.linalg.norm(X - 0.5, axis=1)
    closest = comm.allreduce(float(nearest.min()) if n else np.inf, op=MPI.MIN)
    u[nearest == closest, 0] += (2.5 if gdim == 2 else 5.0) / N[gdim]
    f_ufl, f_c, det_ufl, det_c, forces = both_forces(system, "corotational", u.ravel())
    assert det_ufl < 0 and det_c == pytest.approx(det_ufl, rel=TOL)
    assert comm.allreduce(forces.compiled.fallbacks) >= 1
    assert max_abs(f_c - f_ufl) <= TOL * max_abs(f_ufl)


def test_min_det_is_minus_infinity_where_u_is_not_finite():
    """A NaN in u gives min det = -inf, as the Expression's check does."""
    system = System(clamped(distorted_mesh("hexahedron")), TISSUE)
    u = large_u(system)
    if comm.rank == 0 and u.size:
        u[0] = np.nan
    _, _, det_ufl, det_c, _ = both_forces(system, "neo-hookean", u)
    assert det_ufl == det_c == -np.inf


@pytest.mark.parametrize(
    "benchmark, size, scale, model, scheme",
    [
        ("rod", 2, 3.0, "neo-hookean", "standard"),
        ("rod", 2, 3.0, "corotational", "standard"),
        ("rod", 2, 3.0, "neo-hookean-barrier", "mean-dilatation"),
        ("block", 8, 2.0, "svk", "standard"),
        ("block", 8, 2.0, "neo-hookean", "mean-dilatation"),
    ],
)
def test_explicit_lumped_run_equals_the_ufl_path(benchmark, size, scale, model, scheme):
    """explicit-lumped with a model takes the compiled loop and its fused update
    (ExplicitLumpedModel); 20 steps of it give the displacements of the general explicit step
    with the UFL form (ExplicitModel, compiled=False) to round-off, on SPEC 8's large loads."""
    options = {"needle_width": 0.2} if benchmark == "block" else {}
    bench = get_benchmark(benchmark, mesh_size=size, load_scale=scale, **options)
    system = System(bench, scheme=scheme)
    h = bench.dt / 4
    compiled = get_integrator("explicit-lumped", system, h, model=model)
    assert isinstance(compiled, ExplicitLumpedModel)
    scheme_entry = ALGORITHMS["explicit-lumped"]
    reference = ExplicitModel(
        system, h, scheme_entry, MODELS[model], "explicit_lumped_", compiled=False
    )
    assert reference.forces.compiled is None
    runs = [simulate(it, 20, bench.extent, "explicit-lumped") for it in (compiled, reference)]
    for it in (compiled, reference):
        it.destroy()
    assert [r.status for r in runs] == ["ok", "ok"]
    for a, b in zip(runs[0].u, runs[1].u, strict=True):
        scale = max(max_abs(b), 1e-300)
        assert max_abs(a - b) <= 1e-11 * scale
    assert max_abs(runs[1].u[-1]) > 0


@pytest.mark.serial
def test_compiled_forces_serial_equal_parallel():
    """f_int and the smallest det F of the compiled loop on 2 ranks (owned cells, then the
    ghost nodes' sums to their owners) equal those of 1 rank."""
    serial_run = run_script("mpi_compiled_forces.py", ranks=1)
    parallel_run = run_script("mpi_compiled_forces.py", ranks=2)
    assert serial_run.keys() == parallel_run.keys()
    for key, a in serial_run.items():
        a, b = np.array(a), np.array(parallel_run[key])
        assert a.shape == b.shape, key
        assert np.abs(a - b).max() <= 1e-12 * np.abs(a).max(), key


@pytest.mark.serial
def test_bench_only_explicit_models_writes_its_own_files(tmp_path):
    """`tissuebench bench --only explicit-models --quick` measures the linear explicit-lumped
    step and every model or remedy beside it in one worker per size, and writes
    performance-explicit.md and .json only (no performance.*)."""
    import json

    from helpers import tissuebench

    from tissuebench.workflows.bench.measure import EXPLICIT_CASES, key

    r = tissuebench("bench", "--only", "explicit-models", "--quick", "--out", tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.glob("performance*")) == [
        "performance-explicit.json",
        "performance-explicit.md",
    ]
    data = json.loads((tmp_path / "performance-explicit.json").read_text())
    assert data["mode"] == "quick" and data["only"] == "explicit-models"
    first = data["records"][0]["ours1"]["cases"]  # the smallest rod: every case runs
    for case in EXPLICIT_CASES:
        record = first[key(case)]
        assert record["step_s"] > 0 and record["cpu_step_s"] > 0, case
    report = (tmp_path / "performance-explicit.md").read_text()
    assert report.count("step / explicit-lumped step (1 rank)") == 2 * (len(EXPLICIT_CASES) - 1)


@pytest.mark.parallel
@pytest.mark.parametrize(
    "benchmark, size, model, scheme",
    [
        ("rod", 2, "neo-hookean", "standard"),
        ("rod", 2, "corotational", "standard"),
        ("block", 8, "neo-hookean-barrier", "mean-dilatation"),
        ("contact", 10, "neo-hookean", "standard"),
    ],
)
def test_fused_explicit_lumped_step_equals_the_general_step(benchmark, size, model, scheme):
    """ExplicitLumpedModel's fused update (the next predictor written into a second buffer, the
    contact's penalty force added before a) against the general explicit step with the same
    compiled f_int (ExplicitModel): u and v over 300 steps to 1e-12 of their largest norm, at 0.9
    of the critical step, serial and under mpiexec."""
    from tissuebench.solvers.stability import stability_limits

    bench = get_benchmark(benchmark, mesh_size=size)
    system = System(bench, scheme=scheme)
    h = 0.9 * stability_limits(system, ["explicit-lumped"])["explicit-lumped"].critical_dt
    fused = get_integrator("explicit-lumped", system, h, model=model)
    assert isinstance(fused, ExplicitLumpedModel)
    assert (fused.forces.edge is not None) == (benchmark == "contact")
    general = ExplicitModel(system, h, ALGORITHMS["explicit-lumped"], MODELS[model], "general_")
    runs = [simulate(it, 300, bench.extent, "explicit-lumped") for it in (fused, general)]
    for it in (fused, general):
        it.destroy()
    assert [r.status for r in runs] == ["ok", "ok"]
    for x, y in ((runs[0].u, runs[1].u), (runs[0].v, runs[1].v)):
        # relative to the run's largest norm: v dies out as the body settles
        scale = max(np.sqrt(comm.allreduce(float(b @ b))) for b in y)
        assert scale > 0
        for a, b in zip(x, y, strict=True):
            assert np.sqrt(comm.allreduce(float((a - b) @ (a - b)))) <= 1e-12 * scale
