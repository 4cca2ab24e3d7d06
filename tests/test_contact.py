"""The needle as contact (SPEC 12): the needle's geometry, the penalty's forms, and the Hertz
check, serial and under mpiexec -n 2 (the same numbers as the committed record's)."""

import json
from pathlib import Path

from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from tissuebench.meshes.contact import needle
from tissuebench.solvers import contact
from tissuebench.workflows.contact import hertz

COMMITTED = Path(__file__).parents[1] / "results" / "contact" / "hertz.json"
TOOL = needle()  # the half-stadium at load scale 1 (meshes/tools/)


def centre(t: float, scale: float = 1.0) -> np.ndarray:
    return needle(scale).centre(t)


def test_signed_distance_closed_forms():
    """Points at known distances from the needle at rest (centre (1.1, 0.5), R = 0.1 m)."""
    c = centre(0.0)
    assert np.allclose(c, [1.1, 0.5])
    points = np.array(
        [
            [1.0, 0.5],  # the tip: on the boundary
            [0.9, 0.5],  # 0.1 m in front of the tip
            [1.1, 0.5],  # the centre: R inside
            [1.5, 0.65],  # beside the flank, 0.05 m above it
            [1.5, 0.55],  # inside the strip, 0.05 m below the upper flank
            [1.1 - 0.3, 0.5 + 0.4],  # 0.5 m from the centre, in front
        ]
    )
    assert np.allclose(TOOL.signed_distance(points, c), [0.0, 0.1, -0.1, 0.05, -0.05, 0.4])
    n = TOOL.outward_normal(points, c)
    assert np.allclose(n[[0, 1, 3, 4, 5]], [[-1, 0], [-1, 0], [0, 1], [0, 1], [-0.6, 0.8]])
    # the needle moves with the block's needle: 0.16 m in at t >= 2 s
    assert np.allclose(centre(5.0), [1.1 - 0.16, 0.5])
    assert np.allclose(centre(1.0, scale=0.5), [1.1 - 0.04, 0.5])


def test_ufl_gap_matches_numpy():
    """The UFL signed distance and normal of the deformed point equal the numpy ones at the
    quadrature points, for a displacement that moves points into, along and out of the needle."""
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 8, 8)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(lambda x: np.stack([0.3 * x[0] * x[1] - 0.05, 0.1 * np.sin(3 * x[1])]))
    c = dolfinx.fem.Constant(mesh, np.array([1.02, 0.47]))
    x = contact.deformed(u)
    points = np.array([[0.1, 0.2], [0.9, 0.5], [0.99, 0.4], [0.5, 0.95]])
    expr = dolfinx.fem.Expression(
        ufl.as_vector([TOOL.ufl_signed_distance(x, c), *TOOL.ufl_outward_normal(x, c)]),
        points,
    )
    cells = np.arange(mesh.topology.index_map(2).size_local, dtype=np.int32)
    values = expr.eval(mesh, cells).reshape(len(cells), len(points), 3)
    X = mesh.geometry.x[:, :2]
    # the quadrature points mapped by each (affine) cell and displaced by the P1 field there
    ref = np.column_stack([1 - points.sum(axis=1), points])  # barycentric weights
    physical = np.einsum("pv,cvd->cpd", ref, X[mesh.geometry.dofmaps[0][cells]])
    u_h = np.einsum("pv,cvd->cpd", ref, u.x.array.reshape(-1, 2)[V.dofmap.list[cells]])
    deformed = (physical + u_h).reshape(-1, 2)
    g = TOOL.signed_distance(deformed, c.value)
    inside, outside = (
        mesh.comm.allreduce(int(n), op=MPI.SUM) for n in ((g < 0).sum(), (g > 0).sum())
    )
    assert inside > 0 and outside > 0  # points inside and outside the needle
    assert np.allclose(values[..., 0].ravel(), g, atol=1e-12)
    assert np.allclose(values[..., 1:].reshape(-1, 2), TOOL.outward_normal(deformed, c.value))


@pytest.mark.parallel
def test_hertz_law_and_the_committed_record():
    """SPEC 12: the truth's static 5 mm push holds Hertz's line-contact law within 1 % (p0) and
    2 % (a) on the finest level; the stiffer penalty changes p0 by less than 0.1 %; the finest
    level, computed here (serial or on 2 ranks), gives the committed record's numbers, and the
    committed levels converge."""
    pushes = hertz.compute(levels=(hertz.LEVELS[-1],))
    record = hertz.record(pushes)
    assert record["holds"]
    assert abs(record["p0_error"]) <= 0.01
    assert abs(record["a_error"]) <= 0.02
    soft, stiff = pushes
    assert abs(stiff.p0 / soft.p0 - 1) < 1e-3
    assert stiff.interpenetration < 1e-3 * record["depth"]
    committed = json.loads(COMMITTED.read_text())
    for key in ("P", "p0", "a", "p0_hertz", "a_hertz"):
        assert record[key] == pytest.approx(committed[key], rel=1e-7), key
    p0 = [level["p0"] for level in committed["levels"] if level["kappa"] == stiff.kappa]
    assert len(p0) == len(hertz.LEVELS)
    assert abs(p0[2] - p0[1]) < abs(p0[1] - p0[0])  # the mesh levels converge


def test_needle_force_is_the_energy_derivative():
    """The needle's force F = -int p n dS is minus the penalty energy's derivative in the
    needle's position, which is its derivative along a rigid translation of the tissue, for a
    displacement that pushes the edge into the needle's tip and flanks."""
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 16, 16)
    V = dolfinx.fem.functionspace(mesh, ("Lagrange", 2, (2,)))
    u = dolfinx.fem.Function(V)
    u.interpolate(
        lambda x: np.stack([0.06 * x[0] ** 3 * (1 - 4 * (x[1] - 0.5) ** 2), 0.05 * x[1] * x[0]])
    )
    c = dolfinx.fem.Constant(mesh, np.array([1.12, 0.52]))
    k = dolfinx.fem.Constant(mesh, 1e4)
    right = dolfinx.mesh.locate_entities_boundary(mesh, 1, lambda x: np.isclose(x[0], 1.0))
    tags = dolfinx.mesh.meshtags(mesh, 1, right, np.ones(len(right), np.int32))
    ds = ufl.Measure("ds", mesh, subdomain_data=tags)(1)
    energy = contact.energy(u, c, TOOL, k, ds)
    comm = mesh.comm
    for i, form in enumerate(contact.needle_force(u, c, TOOL, k, ds)):
        F = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(form)), op=MPI.SUM)
        direction = dolfinx.fem.Constant(mesh, np.eye(2)[i])
        virtual = ufl.derivative(energy, u, ufl.as_vector([direction[0], direction[1]]))
        work = comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(virtual)), op=MPI.SUM)
        assert abs(F) > 0.01  # N/m: the edge is inside the needle, off its axis
        assert F == pytest.approx(work, rel=1e-10, abs=1e-12)


def test_the_graded_block_leaves_gmsh_as_it_was():
    """The graded block's gmsh options (its sizes from the field alone, Frontal-Delaunay) are
    put back after it: gmsh.clear() keeps options, and an unstructured rod meshed after it had
    24 tetrahedra in place of its 383."""
    from tissuebench.meshes.contact import graded_block
    from tissuebench.meshes.rod import rod_mesh

    def tetrahedra() -> int:
        mesh = rod_mesh(3, MPI.COMM_SELF, cell="tetrahedron", mesh="unstructured").mesh
        return mesh.topology.index_map(3).size_local

    before = tetrahedra()
    graded_block(0.02, comm=MPI.COMM_SELF)
    assert tetrahedra() == before
