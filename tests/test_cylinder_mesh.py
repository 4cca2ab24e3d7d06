"""The cylinder's meshes (meshes/cylinder_mesh.py): R_B = 0.5 m, H = 1 m, in tetrahedra or the
hexahedral O-grid. Every test is collective (it allreduces before asserting); the one marked
`parallel` compares 2 ranks with the serial mesh.

The volume and area bounds. Every node lies in the (convex) cylinder and every cell in the
convex hull of its nodes (a tetrahedron; a trilinear hexahedron, whose side faces here are
planar rectangles), so the mesh volume is at most pi R^2 H and the face areas at most pi R^2.
A side facet whose nodes span the angle theta around the axis lies, seen from above, in the
circular segment cut off by the chord of that arc: at a distance from the axis of at least
R cos(theta / 2) = R - s, s = R (1 - cos(theta / 2)) the sagitta of the chord. The top and
bottom are flat, so the mesh holds the cylinder of radius R - s: the faceting loses at most
pi (R^2 - (R - s)^2) H of the volume, and as much of the area pi R^2 of the top and bottom;
the side (its nearest-point projection onto that inner cylinder, which shortens no distance
it does not keep, covers the inner side) has an area of at least 2 pi (R - s) H. It is
inscribed in the cylinder, so its area is below 2 pi R H too unless its triangles are as flat
as those of Schwarz's lantern (a bad mesh, which the test would catch). theta is measured on
the mesh (the largest over the side facets) and checked against the mesh size: a side facet
spans at most 2 h / R = 2 / n radians (edges of at most about 2h, h = R / n).
The O-grid's side is the regular polygon of 8c chords, c = core_cells(n) (its grading is
inside the core), so its volume and areas are known exactly.
"""

import math

from mpi4py import MPI

import dolfinx.fem as fem
import dolfinx.mesh
import numpy as np
import pytest
import ufl

from tissuebench.meshes.cylinder_mesh import (
    CELLS,
    CORE,
    HEIGHT,
    RADIUS_BODY,
    core_cells,
    cylinder_cell_size,
    cylinder_mesh,
    cylinder_nodes,
)
from tissuebench.meshes.gmshio import MeshError, TaggedMesh
from tissuebench.meshes.rod import rod_mesh

R, H = RADIUS_BODY, HEIGHT
TOP_CENTRE = (0.0, 0.0, HEIGHT)
CASES = [(n, cell) for cell in CELLS for n in (2, 3, 4)]
# the graded meshes checked too: the hexahedra's core grades from n = 3 (c = 2 cells) on
GRADED = [(3, "hexahedron", 3.0), (4, "tetrahedron", 3.0), (4, "hexahedron", 4.0)]


def total(tagged: TaggedMesh, value):
    """The sum over the ranks of a rank's `value`."""
    return tagged.mesh.comm.allreduce(value, op=MPI.SUM)


def volume(tagged: TaggedMesh) -> float:
    """The mesh volume (m^3): 1 dx."""
    return total(tagged, fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=tagged.mesh))))


def area(tagged: TaggedMesh, name: str) -> float:
    """The area (m^2) of the facets of physical group `name`."""
    _, tags = tagged.tags[name]
    ds = ufl.Measure("ds", domain=tagged.mesh, subdomain_data=tags)
    return total(tagged, fem.assemble_scalar(fem.form(1.0 * ds(tagged.groups[name]))))


def side_span(tagged: TaggedMesh) -> float:
    """theta: the largest angle (rad) around the axis spanned by the nodes of a side facet."""
    mesh = tagged.mesh
    _, facets = tagged.entities("side")
    nodes = dolfinx.mesh.entities_to_geometry(mesh, 2, facets)
    x = mesh.geometry.x[nodes]  # (facet, node, 3)
    phi = np.arctan2(x[:, :, 1], x[:, :, 0])
    turn = np.mod(phi - phi[:, :1] + np.pi, 2 * np.pi) - np.pi  # from the facet's first node
    span = float((turn.max(axis=1) - turn.min(axis=1)).max(initial=0.0))
    return mesh.comm.allreduce(span, op=MPI.MAX)


def owned_nodes_at(tagged: TaggedMesh, point) -> int:
    """How many owned geometry nodes (all ranks) sit at `point` (m)."""
    geometry = tagged.mesh.geometry
    owned = geometry.x[: geometry.index_map().size_local]
    return int(total(tagged, int(np.isclose(owned, point, atol=1e-12).all(axis=1).sum())))


def hexahedron_corner_jacobians(tagged: TaggedMesh) -> np.ndarray:
    """det J of every hexahedron at each of its 8 corners (cells, 8), m^3: the three edges from
    the corner toward the opposite faces, in DOLFINx's vertex order (v = i + 2j + 4k)."""
    mesh = tagged.mesh
    x = mesh.geometry.x[mesh.geometry.dofmaps[0]]
    dets = []
    for v in range(8):
        edges = np.stack([x[:, v ^ bit] - x[:, v] for bit in (1, 2, 4)], axis=2)
        sign = (-1) ** (v & 1) * (-1) ** ((v >> 1) & 1) * (-1) ** ((v >> 2) & 1)
        dets.append(sign * np.linalg.det(edges))
    return np.stack(dets, axis=1)


def regular_polygon(n: int) -> tuple[float, float]:
    """(area m^2, perimeter m) of the O-grid's polygon: 8c chords of the circle."""
    sides = 8 * core_cells(n)
    return 0.5 * sides * R**2 * math.sin(2 * math.pi / sides), sides * 2 * R * math.sin(
        math.pi / sides
    )


@pytest.mark.parametrize("n,cell", CASES)
def test_volume_and_areas_are_the_faceted_cylinders(n, cell):
    tagged = cylinder_mesh(n, cell=cell)
    theta = side_span(tagged)
    assert 0 < theta <= 2 / n
    s = R * (1 - math.cos(theta / 2))  # the sagitta of the widest chord
    inner = math.pi * (R - s) ** 2
    V = volume(tagged)
    assert inner * H <= V <= math.pi * R**2 * H
    for face in ("bottom", "top"):
        assert inner <= area(tagged, face) <= math.pi * R**2
    assert 2 * math.pi * (R - s) * H <= area(tagged, "side") <= 2 * math.pi * R * H
    if cell == "hexahedron":  # exactly the prism on the regular polygon of 8c sides
        polygon, perimeter = regular_polygon(n)
        # gmsh spaces an arc's nodes by its computed arc length: equal angles to 1e-9 rad
        assert theta == pytest.approx(math.pi / (4 * core_cells(n)), rel=1e-8)
        assert V == pytest.approx(polygon * H, rel=1e-12)
        assert area(tagged, "bottom") == pytest.approx(polygon, rel=1e-12)
        assert area(tagged, "top") == pytest.approx(polygon, rel=1e-12)
        assert area(tagged, "side") == pytest.approx(perimeter * H, rel=1e-12)


@pytest.mark.parametrize("n,cell,grading", GRADED)
def test_graded_meshes_keep_the_bounds(n, cell, grading):
    tagged = cylinder_mesh(n, cell=cell, grading=grading)
    theta = side_span(tagged)
    assert 0 < theta <= 2 / n
    inner = math.pi * (R * math.cos(theta / 2)) ** 2
    assert inner * H <= volume(tagged) <= math.pi * R**2 * H
    assert inner <= area(tagged, "top") <= math.pi * R**2
    assert owned_nodes_at(tagged, TOP_CENTRE) == 1
    if cell == "hexahedron":  # graded inside the core only: still the regular polygon's prism
        assert volume(tagged) == pytest.approx(regular_polygon(n)[0] * H, rel=1e-12)


@pytest.mark.parametrize("n,cell", CASES)
def test_the_top_centre_is_one_node(n, cell):
    assert owned_nodes_at(cylinder_mesh(n, cell=cell), TOP_CENTRE) == 1


@pytest.mark.parametrize("n,cell", CASES)
def test_every_boundary_facet_is_in_exactly_one_group(n, cell):
    tagged = cylinder_mesh(n, cell=cell)
    mesh = tagged.mesh
    mesh.topology.create_connectivity(2, 3)
    facets = mesh.topology.index_map(2)
    owned = facets.size_local
    groups = np.zeros(owned + facets.num_ghosts, dtype=np.int32)
    sizes = {}
    for name in ("bottom", "side", "top"):
        _, found = tagged.entities(name)
        groups[found] += 1
        sizes[name] = total(tagged, int((found < owned).sum()))
    exterior = np.zeros_like(groups, dtype=bool)
    exterior[dolfinx.mesh.exterior_facet_indices(mesh.topology)] = True
    wrong = (exterior & (groups != 1)) | (~exterior & (groups != 0))
    assert total(tagged, int(wrong[:owned].sum())) == 0
    assert min(sizes.values()) > 0
    if cell == "hexahedron":  # quadrilaterals: 4c^2 + 8ck on a flat face, 8c around x 2n layers
        c = core_cells(n)
        flat = 4 * c * c + 8 * c * (n - c)
        assert sizes == {"bottom": flat, "side": 8 * c * 2 * n, "top": flat}


@pytest.mark.parametrize("n", [2, 3, 4])
@pytest.mark.parametrize("grading", [1.0, 3.0])
def test_the_ogrid_has_positive_jacobians_and_its_node_count(n, grading):
    tagged = cylinder_mesh(n, cell="hexahedron", grading=grading)
    dets = hexahedron_corner_jacobians(tagged)
    mesh = tagged.mesh
    assert mesh.comm.allreduce(float(dets.min(initial=np.inf)), op=MPI.MIN) > 0
    c = core_cells(n)
    assert mesh.geometry.index_map().size_global == cylinder_nodes(n, "hexahedron")
    assert mesh.topology.index_map(3).size_global == (4 * c * c + 8 * c * (n - c)) * 2 * n


def test_graded_ogrid_cells_at_the_top_centre_are_smaller_by_the_grading():
    """n = 4: c = 3 core cells of a / 3 (a = 0.55 R) and 8 layers of h = 0.125 m, uniform; with
    grading 4 the top layer is h / 4 thick and the core's first cell a / 12 wide."""
    n, g = 4, 4.0
    h, a = cylinder_cell_size(n), CORE * R
    uniform = cylinder_mesh(n, cell="hexahedron")
    graded = cylinder_mesh(n, cell="hexahedron", grading=g)
    for tagged, factor, gone in ((uniform, 1.0, g), (graded, g, 1.0)):
        assert owned_nodes_at(tagged, (0, 0, H - h / factor)) == 1
        assert owned_nodes_at(tagged, (a / (3 * factor), 0, H)) == 1
        assert owned_nodes_at(tagged, (0, 0, H - h / gone)) == 0


def test_graded_tetrahedra_are_smaller_at_the_top_centre():
    """n = 6, h = 1/12 m: the cells at the top centre span at most 0.7 h with grading 3 (the
    field's size there is h / 3; Delaunay's cells scatter about it), over h when uniform."""
    n = 6
    h = cylinder_cell_size(n)
    spans = []
    for grading in (1.0, 3.0):
        mesh = cylinder_mesh(n, cell="tetrahedron", grading=grading).mesh
        dofmap = mesh.geometry.dofmaps[0]
        top = np.flatnonzero(np.isclose(mesh.geometry.x, TOP_CENTRE, atol=1e-12).all(axis=1))
        x = mesh.geometry.x[dofmap[np.isin(dofmap, top).any(axis=1)]]
        span = float(np.ptp(x, axis=1).max(initial=0.0))  # the largest box side of those cells
        spans.append(mesh.comm.allreduce(span, op=MPI.MAX))
    assert spans[0] > h
    assert spans[1] < 0.7 * h


def test_a_bad_size_cell_or_grading_is_refused():
    for n in (1, 0, -3, 2.0, True, "4"):
        with pytest.raises(MeshError, match="cylinder mesh size n"):
            cylinder_mesh(n)
    with pytest.raises(MeshError, match="cell 'prism'"):
        cylinder_mesh(3, cell="prism")
    for grading in (0.5, 0.0, math.nan, math.inf, "2"):
        with pytest.raises(MeshError, match="grading must be a number >= 1"):
            cylinder_mesh(3, grading=grading)
    with pytest.raises(MeshError, match="node count"):
        cylinder_nodes(3, "tetrahedron")


def test_the_tetrahedra_leave_gmsh_options_as_they_found_them():
    """gmsh.clear() keeps options: the cylinder's (size from its field alone) must not coarsen
    a later mesh sized by its points, as the rod's unstructured one is."""

    def rod_cells() -> int:
        mesh = rod_mesh(3, cell="tetrahedron", mesh="unstructured").mesh
        return mesh.topology.index_map(3).size_global

    before = rod_cells()
    cylinder_mesh(2, cell="tetrahedron")
    assert rod_cells() == before


def test_the_msh_file_is_written(tmp_path):
    path = tmp_path / "cylinder.msh"
    cylinder_mesh(2, cell="hexahedron", msh_path=path)
    assert MPI.COMM_WORLD.bcast(path.stat().st_size > 0 if MPI.COMM_WORLD.rank == 0 else None)


@pytest.mark.parallel
@pytest.mark.parametrize("cell", CELLS)
def test_every_rank_gets_the_serial_mesh(cell):
    """The mesh over all ranks has the serial mesh's volume, areas, cell and node counts."""
    n = 3
    serial = cylinder_mesh(n, MPI.COMM_SELF, cell=cell)
    shared = cylinder_mesh(n, MPI.COMM_WORLD, cell=cell)
    assert volume(shared) == pytest.approx(volume(serial), rel=1e-12)
    for face in ("bottom", "side", "top"):
        assert area(shared, face) == pytest.approx(area(serial, face), rel=1e-12)
    for tagged in (serial, shared):
        assert owned_nodes_at(tagged, TOP_CENTRE) == 1
    for count in (lambda m: m.topology.index_map(3), lambda m: m.geometry.index_map()):
        assert count(shared.mesh).size_global == count(serial.mesh).size_global
