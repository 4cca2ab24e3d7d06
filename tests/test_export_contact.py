"""The contact benchmark (SPEC 12) as the export states it and as meshes.regions poses it on a
mesh that is not ours; the other benchmarks' JSON keeps no trace of contact."""

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest

from tissuebench.core.errors import UserError
from tissuebench.meshes import get_benchmark
from tissuebench.meshes.block import block_mesh
from tissuebench.meshes.posed import on_mesh
from tissuebench.solvers import get_integrator
from tissuebench.solvers.contact import Measures
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.system import System
from tissuebench.workflows.compare.posing import build, export
from tissuebench.workflows.io.exported import to_json


def pushed(bench, steps: int = 15) -> tuple[float, float, float]:
    """(F_x, F_y in N/m, interpenetration in m) of the benchmark with MP1, quasi-static to
    t = 2 s (the needle 0.16 m in) in `steps` steps."""
    system = System(bench, "MP1")
    integrator = get_integrator("quasi-static", system, 2.0 / steps)
    state = integrator.start()
    for _ in range(steps):
        state = integrator.step(state)
    measured = Measures(system)(state.u.array_r.copy(), state.t)
    integrator.destroy()
    return measured


def test_on_mesh_poses_the_needle_as_on_our_mesh():
    """The contact benchmark posed by its regions and tool on our own 10 x 10 grid is the one
    we build: the same fixed nodes, the right edge's 10 facets with h_e = 0.1 m, and the same
    needle force and interpenetration at t = 2 s (kappa 20, load scale 0.5)."""
    options = {"kappa": 20.0, "load_scale": 0.5}
    ours = get_benchmark("contact", mesh_size=10, **options)
    posed = on_mesh("contact", block_mesh(10).mesh, **options)
    assert [c.name for c in posed.constraints] == ["left", "bottom", "top"]
    contact = posed.contact
    assert contact is not None and contact.edge_size == pytest.approx(0.1, rel=1e-12)
    assert (contact.tool.radius, contact.kappa) == (0.1, 20.0)
    assert np.allclose(contact.centre(1.0), ours.contact.centre(1.0), rtol=0, atol=1e-15)
    owned = posed.mesh.topology.index_map(1).size_local
    assert MPI.COMM_WORLD.allreduce(int(np.sum(contact.facets < owned))) == 10
    a, b = pushed(ours), pushed(posed)
    assert a[0] > 1.0 and b[0] == pytest.approx(a[0], rel=1e-9)
    assert b[2] == pytest.approx(a[2], rel=1e-9)


def test_on_mesh_poses_the_needle_on_a_finer_triangle_mesh():
    """On DOLFINx's own 16 x 16 squares crossed into four triangles each (symmetric about
    y = 0.5; not a mesh of ours): the tool's surface holds the right edge's 16 facets,
    h_e = 1/16 m, and the tissue pushes the needle back along x."""
    mesh = dolfinx.mesh.create_unit_square(
        MPI.COMM_WORLD,
        16,
        16,
        dolfinx.mesh.CellType.triangle,
        diagonal=dolfinx.mesh.DiagonalType.crossed,
    )
    posed = on_mesh("contact", mesh)
    contact = posed.contact
    assert contact is not None and contact.edge_size == pytest.approx(1 / 16, rel=1e-12)
    owned = mesh.topology.index_map(1).size_local
    assert MPI.COMM_WORLD.allreduce(int(np.sum(contact.facets < owned))) == 16
    Fx, Fy, depth = pushed(posed)
    assert Fx > 1.0 and abs(Fy) < 1e-6 * Fx and 0 < depth < 0.05


@pytest.mark.serial
def test_contact_is_stated_for_the_contact_benchmark_only(tmp_path):
    """The block's and rod's JSON objects have no `contact` and no contact units (their files
    are what they were); the contact benchmark's has it, its surface nodes on x = 1; the
    CalculiX deck, which cannot pose the tool, is refused in one line."""
    material = get_material("MP1")
    for name in ("block", "rod"):
        data, _, _ = build(name, 2, {}, material, "linear", 1 / 30, 2, "strain", "dynamic")
        doc = to_json(data)
        assert data.contact is None and "contact" not in doc
        assert not any("contact" in k for k in doc["units"])
    data, _, _ = build("contact", 4, {}, material, "linear", 1 / 30, 2, "strain", "dynamic")
    doc = to_json(data)
    assert doc["contact"]["law"]["surface_nodes"] == np.flatnonzero(data.nodes[:, 0] == 1).tolist()
    assert doc["contact"]["penalty"]["k"] == pytest.approx(10 * material.E * 4)
    assert len(doc["contact"]["motion"]["c"]) == 3
    with pytest.raises(UserError, match="CalculiX deck does not pose contact's rigid tool") as err:
        export("contact", "inp", tmp_path / "c.inp", mesh_size=4, options={}, material=material,
               model="linear", h=1 / 30, steps=2)  # fmt: skip
    assert "\n" not in str(err.value) and not (tmp_path / "c.inp").exists()
