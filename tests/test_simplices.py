"""Our own runs on simplices (SPEC 9): the meshes hold the body, the needle's nodes and the
whole clamped face; the P1 lumped mass conserves the body's mass; the stability limits hold
for real runs; and the solutions converge to the grid's reference at the order that the
problems' singular points allow (as the quadrilaterals and hexahedra do, results/convergence.md).
"""

from mpi4py import MPI

import numpy as np
import pytest
import ufl
from dolfinx import fem
from helpers import tissuebench

from tissuebench.meshes import get_benchmark
from tissuebench.meshes.gmshio import MeshError
from tissuebench.solvers.stability import explicit_schemes, run_check, stability_limits
from tissuebench.solvers.system import System
from tissuebench.workflows.study.convergence import difference_orders, space_study

SHAPES = [
    ("block", 10, "triangle", "structured"),
    ("block", 10, "triangle", "unstructured"),
    ("rod", 2, "tetrahedron", "structured"),
    ("rod", 2, "tetrahedron", "unstructured"),
]
VOLUME = {"block": 1.0, "rod": 0.5 * 0.25 * 0.25}  # m^2, m^3
WIDTH = 0.2  # m, the needle width of the refinement studies


def build(name, size, cell, kind):
    options = {"needle_width": WIDTH} if name == "block" else {}
    return get_benchmark(name, mesh_size=size, cell=cell, mesh=kind, **options)


def integral(mesh, expression, measure):
    return mesh.comm.allreduce(fem.assemble_scalar(fem.form(expression * measure)), op=MPI.SUM)


def constrained_points(bench, name):
    """The undeformed coordinates of the nodes of constraint `name`, from every rank."""
    c = next(c for c in bench.constraints if c.name == name)
    V = fem.functionspace(bench.mesh, ("Lagrange", 1))
    bench.mesh.topology.create_connectivity(c.dim, bench.mesh.topology.dim)
    dofs = fem.locate_dofs_topological(V, c.dim, c.entities)
    x = V.tabulate_dof_coordinates()[dofs]
    return np.concatenate(bench.mesh.comm.allgather(x))


@pytest.mark.parametrize("name,size,cell,kind", SHAPES)
def test_mesh_holds_the_body_the_needle_and_the_clamped_face(name, size, cell, kind):
    bench = build(name, size, cell, kind)
    mesh = bench.mesh
    assert mesh.topology.cell_name() == cell
    one = fem.Constant(mesh, 1.0)
    assert integral(mesh, one, ufl.dx) == pytest.approx(VOLUME[name], rel=1e-12)
    if name == "block":
        x = constrained_points(bench, "needle")
        assert np.allclose(x[:, 0], 1.0) and np.all(np.abs(x[:, 1] - 0.5) <= WIDTH / 2 + 1e-10)
        for y in (0.5 - WIDTH / 2, 0.5, 0.5 + WIDTH / 2):  # the embedded needle points
            assert np.min(np.abs(x[:, 1] - y)) < 1e-12, y
    else:
        dim, facets = bench.tagged.entities("clamped")
        tags = bench.tagged.tags["clamped"][1]
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=tags)
        area = integral(mesh, one, ds(bench.tagged.groups["clamped"]))
        assert area == pytest.approx(0.25 * 0.25, rel=1e-12)  # the whole face x = 0
        assert np.allclose(constrained_points(bench, "clamped")[:, 0], 0.0)


@pytest.mark.parallel
@pytest.mark.parametrize("name,size,cell,kind", SHAPES)
def test_lumped_mass_is_positive_and_conserves_the_mass(name, size, cell, kind):
    """Row sums of the P1 mass matrix: every entry positive, and their sum is the body's mass
    once per displacement component."""
    s = System(build(name, size, cell, kind))
    comm = s.comm
    assert comm.allreduce(s.ML.array.min(), op=MPI.MIN) > 0
    total = s.ML.sum()
    assert total == pytest.approx(s.gdim * s.material.rho * VOLUME[name], rel=1e-12)


@pytest.mark.parametrize(
    "name,size,cell,kind,material",
    [
        ("block", 4, "triangle", "structured", "MP1"),
        ("rod", 2, "tetrahedron", "unstructured", "MP3"),
    ],
)
def test_real_runs_diverge_just_above_the_limit_and_not_below(name, size, cell, kind, material):
    bench = get_benchmark(name, mesh_size=size, cell=cell, mesh=kind)
    s = System(bench, material)
    rows = run_check(s, stability_limits(s, explicit_schemes()), margin=0.05, max_steps=20_000)
    for row in rows:
        expected = "diverged" if row["ratio"] > 1 else "ok"
        assert row["status"] == expected, row


def test_triangles_converge_at_the_order_of_the_needle_singularity():
    """Block MP1 with the needle 0.2 m wide, implicit to t = 1 s on structured triangles
    N = 10 .. 80: at the ends of the needle segment the displacement goes as r^(1/2), which
    bounds the order of an L2-type error such as E_i by 1; the quadrilaterals show 1.07
    (results/convergence.md)."""
    sizes = (10, 20, 40, 80)
    result = space_study(
        "block", "MP1", sizes, problems=("implicit",), needle_width=WIDTH, cell="triangle"
    )["implicit"]
    errors = [e["interior_error"] for e in result["errors"]]
    assert errors[0] > errors[1] > errors[2]
    rates = difference_orders(sizes, [d["interior_error"] for d in result["differences"]])
    assert min(rates) > 0.9, rates


def test_tetrahedra_converge_and_approach_the_hexahedra():
    """Rod MP3, quasi-static, structured tetrahedra n = 2 .. 16: E_i against the n = 16 grid
    falls at every refinement, with an order that rises towards the hexahedra's (1.5-2,
    results/convergence.md: the clamped edges bound it) and passes 1.2 from n = 4 to 8."""
    sizes = (2, 4, 8, 16)
    tets = space_study("rod", "MP3", sizes, problems=("quasi-static",), cell="tetrahedron")
    errors = [e["interior_error"] for e in tets["quasi-static"]["errors"]]
    assert errors[0] > errors[1] > errors[2]
    rates = difference_orders(
        sizes, [d["interior_error"] for d in tets["quasi-static"]["differences"]]
    )
    assert rates[1] > rates[0] and rates[1] > 1.2, rates


def test_bad_shapes_are_refused():
    with pytest.raises(MeshError, match="hexahedron or tetrahedron"):
        get_benchmark("rod", mesh_size=1, cell="triangle")
    with pytest.raises(MeshError, match="unstructured mesh is made of simplices"):
        get_benchmark("block", mesh_size=4, mesh="unstructured")
    with pytest.raises(MeshError, match="structured or unstructured"):
        get_benchmark("block", mesh_size=4, cell="triangle", mesh="random")


@pytest.mark.serial
def test_command_line_refuses_shapes_it_cannot_pose(tmp_path):
    r = tissuebench("run", "rod", "--cell", "triangle", "--out", tmp_path / "a")
    assert r.returncode == 2 and "hexahedron or tetrahedron" in r.stderr
    r = tissuebench("run", "block", "--mesh", "unstructured", "--out", tmp_path / "b")
    assert r.returncode == 2 and "--cell triangle" in r.stderr
    r = tissuebench("export", "rod", "--cell", "tetrahedron", "--out", tmp_path / "c.json")
    assert r.returncode == 2 and "do not apply here" in r.stderr
    assert not any(tmp_path.iterdir())
