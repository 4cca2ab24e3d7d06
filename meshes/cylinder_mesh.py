"""The mesh of the tissue cylinder Omega_0 = {sqrt(x^2 + y^2) <= R_B, 0 <= z <= H}, R_B = 0.5 m,
H = 1 m, axis along z, in gmsh's tetrahedra or in a structured O-grid of hexahedra; the top
face's centre (0, 0, H) is a node of both. Physical groups: the volume "cylinder" (1), the faces
"bottom" (z = 0, 1), "side" (r = R_B, 2) and "top" (z = H, 3).

n is the number of cells along the radius, target cell size h = R_B / n m (2n layers in z).
The O-grid: a square core of half-side 0.55 R_B, split at the axes into four quadrants of c x c
cells, c = round(2n / 3), and eight blocks of c x k cells (k = n - c radially) from the core to
the circle, extruded in 2n layers: c + k = n cells along a radius through the middle of a core
side (the x and y axes), 8c segments around the circle. Its cells are 0.8 h to 1.4 h wide
(n = 12: core 0.83 h, circle 1.18 h, radially 1.35 h on the axes and 0.67 h on the diagonals),
the smallest corner angle 45 degrees (the core's corners: scaled Jacobian 0.707).

grading g > 1 makes the cells at the top centre about g times smaller: the tetrahedra's size
grows linearly from h / g there to h at GRADING_REACH m from it; the O-grid's layers thin
geometrically toward the top (the top one h / g thick) and its core's lines on the x and y
axes start at 1 / g of the core's cell a / c (n = 2, one core cell: not graded across).
"""

from __future__ import annotations

import math
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes.gmshio import MeshError, TaggedMesh, gmsh_options, start_gmsh, to_dolfinx

RADIUS_BODY = 0.5  # m, R_B
HEIGHT = 1.0  # m, H
CORE = 0.55  # the O-grid's core half-side over R_B
GRADING_REACH = RADIUS_BODY  # m: tets grow from h / grading at the top centre to h this far off
CELLS = ("tetrahedron", "hexahedron")
# gmsh's options for the tetrahedra: the size from the field alone, Frontal-Delaunay faces and
# Delaunay inside (set while meshing, then put back: gmsh.clear() keeps options)
TETRAHEDRA_OPTIONS: dict[str, float] = {
    "Mesh.MeshSizeFromPoints": 0,
    "Mesh.MeshSizeFromCurvature": 0,
    "Mesh.MeshSizeExtendFromBoundary": 0,
    "Mesh.Algorithm": 6,
    "Mesh.Algorithm3D": 1,
}


def cylinder_cell_size(n: int) -> float:
    """The target cell size R_B / n (m) of the mesh of size n."""
    return RADIUS_BODY / n


def core_cells(n: int) -> int:
    """c: the O-grid's cells along a half-side of its core (and along each eighth of the
    circle), round(2n / 3); the other k = n - c cells of a radius are in the outer blocks."""
    return (2 * n + 1) // 3


def cylinder_nodes(n: int, cell: str) -> int:
    """The exact node count of the hexahedral O-grid of size n: 2n + 1 node layers of
    (2c + 1)^2 core nodes and k rings of 8c nodes. Tetrahedra have no formula (MeshError)."""
    if cell != "hexahedron":
        raise MeshError(f"only the hexahedral O-grid has a node count formula, not {cell!r}")
    c = core_cells(n)
    k = n - c
    return (2 * n + 1) * ((2 * c + 1) ** 2 + 8 * c * k)


def check_arguments(n: object, cell: object, grading: object) -> None:
    """MeshError unless n is a whole number >= 2, cell one of CELLS and grading >= 1."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 2:
        raise MeshError(f"cylinder mesh size n must be a whole number >= 2, got {n!r}")
    if cell not in CELLS:
        raise MeshError(f"cell {cell!r}: the cylinder takes {' or '.join(CELLS)}")
    if isinstance(grading, bool) or not isinstance(grading, int | float):
        raise MeshError(f"grading must be a number >= 1, got {grading!r}")
    if not (math.isfinite(grading) and grading >= 1):
        raise MeshError(f"grading must be a number >= 1, got {grading!r}")


def progression(cells: int, grading: float) -> float:
    """The ratio q >= 1 of a geometric progression of `cells` cells whose first cell is
    1 / grading of the uniform one: sum(q^i, i < cells) = cells * grading. 1 for one cell
    (which cannot be graded) or grading 1."""
    if cells < 2 or grading == 1:
        return 1.0
    target = cells * grading
    low, high = 1.0, target
    for _ in range(200):
        mid = 0.5 * (low + high)
        if sum(mid**i for i in range(cells)) < target:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)


def layer_heights(layers: int, grading: float) -> list[float]:
    """The cumulative heights (fractions of H, last 1) of `layers` extrusion layers, thinning
    geometrically toward the top so that the top layer is 1 / grading of the uniform one."""
    q = progression(layers, grading)
    sizes = [q ** (layers - 1 - i) for i in range(layers)]  # bottom first, top smallest
    total = sum(sizes)
    heights, z = [], 0.0
    for size in sizes:
        z += size
        heights.append(z / total)
    heights[-1] = 1.0
    return heights


def gmsh_tetrahedra(n: int, grading: float) -> None:
    """Build the cylinder in gmsh's Frontal-Delaunay triangles and Delaunay tetrahedra of size
    h = R_B / n m, h / grading at the top centre (0, 0, H) (a node: embedded in the top face),
    growing linearly to h over GRADING_REACH m."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    h = cylinder_cell_size(n)
    occ = gmsh.model.occ
    occ.addCylinder(0.0, 0.0, 0.0, 0.0, 0.0, HEIGHT, RADIUS_BODY)
    centre = occ.addPoint(0.0, 0.0, HEIGHT, h / grading)
    occ.synchronize()
    eps = 1e-3  # m: OpenCASCADE's bounding boxes are 1e-7 m larger than the shapes
    r = RADIUS_BODY + eps
    top = gmsh.model.getEntitiesInBoundingBox(-r, -r, HEIGHT - eps, r, r, HEIGHT + eps, 2)
    gmsh.model.mesh.embed(0, [centre], 2, top[0][1])
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "PointsList", [centre])
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance)
    field.setNumber(threshold, "SizeMin", h / grading)
    field.setNumber(threshold, "SizeMax", h)
    field.setNumber(threshold, "DistMin", 0.0)
    field.setNumber(threshold, "DistMax", GRADING_REACH)
    field.setAsBackgroundMesh(threshold)


def gmsh_ogrid(n: int, grading: float) -> None:
    """Build the O-grid of hexahedra (module docstring) with gmsh's geo kernel: twelve
    transfinite recombined quadrilateral patches at z = 0, extruded in 2n layers. With
    grading g > 1 the cells of the core's four lines on the x and y axes grow geometrically
    away from the axis (the first 1 / g of the uniform a / c) and the layers thicken
    geometrically downward from the top one, 1 / g of H / 2n thick; the core's sides, the
    circle and the outer blocks stay uniform (the side stays the regular polygon of 8c chords),
    so the core's cells blend from 1 / g of the uniform size at the axis to it at its sides."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    c = core_cells(n)
    k = n - c
    a = CORE * RADIUS_BODY
    R = RADIUS_BODY
    q = progression(c, grading)  # the ratio of the core's lines on the axes
    geo = gmsh.model.geo
    centre = geo.addPoint(0.0, 0.0, 0.0)
    # counterclockwise from the +x axis: the middles of the core sides (even j) and its corners
    # (odd j), and the points of the circle on the same rays
    core, rim, spokes = [], [], []
    for j in range(8):
        angle = j * math.pi / 4
        x, y = round(math.cos(angle)), round(math.sin(angle))
        core.append(geo.addPoint(a * x, a * y, 0.0))
        rim.append(geo.addPoint(R * math.cos(angle), R * math.sin(angle), 0.0))
    # lines drawn from the centre outward, the core's sides from their middles
    for j in range(8):
        spokes.append(geo.addLine(core[j], rim[j]))
    axes = {j: geo.addLine(centre, core[j]) for j in (0, 2, 4, 6)}
    half_sides, arcs = {}, {}
    for j in range(8):
        middle = j if j % 2 == 0 else (j + 1) % 8  # the side's middle, of the pair (j, j+1)
        corner = j + 1 if j % 2 == 0 else j
        half_sides[j] = geo.addLine(core[middle], core[corner % 8])
        arcs[j] = geo.addCircleArc(rim[middle], centre, rim[corner % 8])
    for line in axes.values():
        geo.mesh.setTransfiniteCurve(line, c + 1, "Progression", q)
    for line in list(half_sides.values()) + list(arcs.values()):
        geo.mesh.setTransfiniteCurve(line, c + 1)
    for line in spokes:
        geo.mesh.setTransfiniteCurve(line, k + 1)
    patches = []
    for j in (0, 2, 4, 6):  # the core quadrant between the rays j and j + 2
        loop = [axes[j], half_sides[j], -half_sides[j + 1], -axes[(j + 2) % 8]]
        patches.append(geo.addPlaneSurface([geo.addCurveLoop(loop)]))
    for j in range(8):  # the outer block between the rays j and j + 1
        if j % 2 == 0:
            loop = [spokes[j], arcs[j], -spokes[j + 1], -half_sides[j]]
        else:
            loop = [spokes[j], -arcs[j], -spokes[(j + 1) % 8], half_sides[j]]
        patches.append(geo.addPlaneSurface([geo.addCurveLoop(loop)]))
    for patch in patches:
        geo.mesh.setTransfiniteSurface(patch)
        geo.mesh.setRecombine(2, patch)
    layers = 2 * n
    heights = layer_heights(layers, grading)
    base = [(2, patch) for patch in patches]
    geo.extrude(base, 0, 0, HEIGHT, numElements=[1] * layers, heights=heights, recombine=True)
    geo.synchronize()


def cylinder_mesh(
    n: int,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "tetrahedron",
    grading: float = 1.0,
) -> TaggedMesh:
    """The cylinder (R_B = 0.5 m, H = 1 m) as a TaggedMesh distributed over `comm`: n >= 2
    cells along the radius (size R_B / n m), first-order tetrahedra or the hexahedral O-grid,
    cells about `grading` times smaller at the top centre (0, 0, H) m than elsewhere."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    check_arguments(n, cell, grading)
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add(f"cylinder-{n}")
        if cell == "tetrahedron":
            gmsh_tetrahedra(n, float(grading))
        else:
            gmsh_ogrid(n, float(grading))
        volumes = [tag for _, tag in gmsh.model.getEntities(3)]
        boundary = gmsh.model.getBoundary([(3, v) for v in volumes], oriented=False)
        faces: dict[str, list[int]] = {"bottom": [], "side": [], "top": []}
        eps = 1e-3  # m: OpenCASCADE's bounding boxes are 1e-7 m larger than the shapes
        for _, surface in boundary:
            zmin, zmax = gmsh.model.getBoundingBox(2, surface)[2::3]
            if zmax < eps:
                faces["bottom"].append(surface)
            elif zmin > HEIGHT - eps:
                faces["top"].append(surface)
            else:
                faces["side"].append(surface)
        gmsh.model.addPhysicalGroup(3, volumes, 1, name="cylinder")
        for tag, name in enumerate(("bottom", "side", "top"), start=1):
            gmsh.model.addPhysicalGroup(2, faces[name], tag, name=name)
        with gmsh_options(TETRAHEDRA_OPTIONS if cell == "tetrahedron" else {}):
            gmsh.model.mesh.generate(3)
    return to_dolfinx(comm, gdim=3, msh_path=msh_path)
