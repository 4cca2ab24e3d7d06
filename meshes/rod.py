"""The 3D rod of benchmark B (SPEC section 5): [0, 0.5] x [0, 0.25] x [0, 0.25] m,
2n x n x n hexahedra, or tetrahedra on that grid or unstructured (SPEC 9). Physical group
"clamped": the face x = 0; "free_end": the face x = 0.5.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes.benchmark import (
    LOAD_SCALE_HELP,
    Benchmark,
    Constraint,
    Entry,
    check_load_scale,
    check_shape,
    fixed,
    shape_options,
)
from tissuebench.meshes.gmshio import TaggedMesh, check_positive_int, start_gmsh, to_dolfinx
from tissuebench.meshes.regions import Posing, Region, Term

SIZE = (0.5, 0.25, 0.25)  # m: length (x), height (y), depth (z)
TIP = (0.5, 0.25, 0.125)  # m: middle of the top edge of the free end


def gmsh_rod(n: int, cell: str = "hexahedron", mesh: str = "structured") -> None:
    """Build the 2n x n x n rod in the current gmsh model: the structured grid of hexahedra or
    of tetrahedra (each grid cell split into six: the side face's squares into triangles,
    extruded in layers), or gmsh's unstructured Delaunay tetrahedra at spacing 0.25/n m."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    L, H, D = SIZE
    structured = mesh == "structured"
    size = H / n  # m, the target spacing of an unstructured mesh
    geo = gmsh.model.geo
    p = [geo.addPoint(x, y, 0.0, size) for x, y in [(0, 0), (L, 0), (L, H), (0, H)]]
    lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
    rect = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    if structured:
        for curve, cells in zip(lines, [2 * n, n, 2 * n, n]):  # noqa: B905
            geo.mesh.setTransfiniteCurve(curve, cells + 1)
        geo.mesh.setTransfiniteSurface(rect)
        hexahedra = cell == "hexahedron"
        if hexahedra:
            geo.mesh.setRecombine(2, rect)
        out = geo.extrude([(2, rect)], 0, 0, D, numElements=[n], recombine=hexahedra)
    else:
        out = geo.extrude([(2, rect)], 0, 0, D)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay on the faces
        gmsh.option.setNumber("Mesh.Algorithm3D", 1)  # Delaunay inside
    geo.synchronize()
    volume = [tag for dim, tag in out if dim == 3]
    eps = 1e-9
    clamped = gmsh.model.getEntitiesInBoundingBox(-eps, -eps, -eps, eps, H + eps, D + eps, 2)
    free_end = gmsh.model.getEntitiesInBoundingBox(
        L - eps, -eps, -eps, L + eps, H + eps, D + eps, 2
    )
    gmsh.model.addPhysicalGroup(3, volume, 1, name="rod")
    gmsh.model.addPhysicalGroup(2, [t for _, t in clamped], 1, name="clamped")
    gmsh.model.addPhysicalGroup(2, [t for _, t in free_end], 2, name="free_end")
    gmsh.model.mesh.generate(3)


def rod_mesh(
    n: int = 3,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "hexahedron",
    mesh: str = "structured",
) -> TaggedMesh:
    """The 2n x n x n rod as a TaggedMesh distributed over `comm` (cell size 0.25/n m)."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    check_positive_int("mesh size n", n)
    check_shape(3, cell, mesh)
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add(f"rod-{n}")
        gmsh_rod(n, cell, mesh)
    return to_dolfinx(comm, gdim=3, msh_path=msh_path)


GRAVITY = (0.0, -0.05, 0.0)  # m/s^2, switched on at t = 0


def benchmark(
    mesh_size: int = 3,
    load_scale: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "hexahedron",
    mesh: str = "structured",
) -> Benchmark:
    """Benchmark B: the rod clamped at x = 0, bending under gravity 0.05 s m/s^2 in -y, s the
    load scale of SPEC section 8 (1: the paper's load); cell and mesh pick the mesh (SPEC 9:
    hexahedron or tetrahedron, structured or unstructured)."""
    check_load_scale(load_scale)
    tagged = rod_mesh(mesh_size, comm, msh_path, cell, mesh)
    return Benchmark(
        name="rod",
        tagged=tagged,
        constraints=[Constraint("clamped", *tagged.entities("clamped"), fixed(3))],
        gravity=tuple(load_scale * g for g in GRAVITY),
        material=ENTRY.material,
        dt=ENTRY.dt,
        end_time=ENTRY.end_time,
        extent=max(SIZE),
        mesh_size=mesh_size,
        probe=ENTRY.probe,
        options={"load_scale": load_scale, **shape_options(3, cell, mesh)},
    )


def posing(load_scale: float = 1.0) -> Posing:
    """The rod's regions (SPEC 5): clamped on x = 0, gravity 0.05 s m/s^2 in -y."""
    check_load_scale(load_scale)
    return Posing(
        (Region("clamped", (Term(0, 0.0),), fixed(3)),),
        tuple(load_scale * g for g in GRAVITY),
        max(SIZE),
    )


def place(x, mesh_size: int, option) -> str:
    """Where the point x (m) lies on the rod, in words: clamped at x = 0, height 0.25 m over
    n cells."""
    cell = SIZE[1] / mesh_size
    text = ""
    if x[0] < cell:
        text += ", in the first layer of cells at the clamped face x = 0"
        if x[1] < cell:
            text += ", at its lower edge (compressed as the rod bends down)"
    return text


ENTRY = Entry(
    build=benchmark,
    gdim=3,
    material="MP3",
    mesh_size=3,
    dt=1 / 30,
    end_time=10.0,
    nodes=lambda n: (2 * n + 1) * (n + 1) ** 2,
    cell_size=lambda n: SIZE[1] / n,
    materials=("MP3",),
    study_sizes=(2, 3, 6, 12),
    options={"load_scale": LOAD_SCALE_HELP},
    probe=TIP,
    probe_label="tip (0.5, 0.25, 0.125) m",
    box=SIZE,
    posing=posing,
    truth_levels=(2, 4, 8),
    quick_truth_levels=(1, 2, 4),
    quick_truth_seconds=3.0,  # rod 1.7 s, rod-MP2 2.8 s, whole commands (probe 0.78)
    title="Bending rod",
    size_name="n",
    grid=((2, 1, 1), "hexahedra", ""),
    place=place,
)
