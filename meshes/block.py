"""The 2D block of benchmark A (SPEC section 4): [0, 1] x [0, 1] m, N x N quadrilaterals, or
triangles on that grid or unstructured (SPEC 9).

The right edge is split at the needle node (1, 0.5), so that N must be even. Physical groups:
"left", "right", "bottom", "top" (edges) and "needle" (the node at (1, 0.5)).
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

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
from tissuebench.meshes.gmshio import (
    MeshError,
    TaggedMesh,
    check_positive_int,
    start_gmsh,
    to_dolfinx,
)
from tissuebench.meshes.regions import Posing, Region, Term

LENGTH = 1.0  # m, both sides
NEEDLE = (1.0, 0.5)  # m


def gmsh_block(
    N: int, cell: str = "quadrilateral", mesh: str = "structured", needle_width: float = 0.0
) -> None:
    """Build the N x N block in the current gmsh model: the structured grid of quadrilaterals
    or of triangles (each square split in two, alternating diagonals), or gmsh's unstructured
    Frontal-Delaunay triangles at spacing 1/N m. The right edge is split at the needle node
    (1, 0.5) and, on an unstructured mesh with needle_width w > 0, at y = 0.5 -/+ w/2 too, so
    that every mesh carries the needle's nodes (SPEC 9)."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    structured = mesh == "structured"
    size = LENGTH / N  # m, the target spacing of an unstructured mesh
    marks = (
        [] if structured or needle_width <= 0 else [0.5 - needle_width / 2, 0.5 + needle_width / 2]
    )
    right_y = sorted({0.0, NEEDLE[1], 1.0, *marks})
    geo = gmsh.model.geo
    corners = [(0, 0), (1, 0), (1, 1), (0, 1)]
    p0, p1, p3, p4 = (geo.addPoint(x, y, 0.0, size) for x, y in corners)
    on_right = [p1, *(geo.addPoint(1.0, y, 0.0, size) for y in right_y[1:-1]), p3]
    needle = on_right[right_y.index(NEEDLE[1])]
    bottom = geo.addLine(p0, p1)
    right = [geo.addLine(a, b) for a, b in zip(on_right[:-1], on_right[1:])]  # noqa: B905
    top = geo.addLine(p3, p4)
    left = geo.addLine(p4, p0)
    loop = geo.addCurveLoop([bottom, *right, top, left])
    surface = geo.addPlaneSurface([loop])
    geo.synchronize()
    if structured:
        for curve, cells in [(bottom, N), (top, N), (left, N), *((c, N // 2) for c in right)]:
            gmsh.model.mesh.setTransfiniteCurve(curve, cells + 1)
        gmsh.model.mesh.setTransfiniteSurface(
            surface,
            arrangement="Left" if cell == "quadrilateral" else "Alternate",
            cornerTags=[p0, p1, p3, p4],
        )
        if cell == "quadrilateral":
            gmsh.model.mesh.setRecombine(2, surface)
    else:
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
    gmsh.model.addPhysicalGroup(2, [surface], 1, name="block")
    gmsh.model.addPhysicalGroup(1, [left], 1, name="left")
    gmsh.model.addPhysicalGroup(1, right, 2, name="right")
    gmsh.model.addPhysicalGroup(1, [bottom], 3, name="bottom")
    gmsh.model.addPhysicalGroup(1, [top], 4, name="top")
    gmsh.model.addPhysicalGroup(0, [needle], 5, name="needle")
    gmsh.model.mesh.generate(2)


def block_mesh(
    N: int = 20,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "quadrilateral",
    mesh: str = "structured",
    needle_width: float = 0.0,
) -> TaggedMesh:
    """The N x N block as a TaggedMesh distributed over `comm` (N even, cell size 1/N m)."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    check_positive_int("mesh size N", N)
    check_shape(2, cell, mesh)
    if N % 2:
        raise MeshError(
            f"mesh size N must be even so that the needle (1, 0.5) sits on a node, got {N}"
        )
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add(f"block-{N}")
        gmsh_block(N, cell, mesh, needle_width)
    return to_dolfinx(comm, gdim=2, msh_path=msh_path)


def needle_motion(t: float, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The needle's prescribed (u, v, a) at time t (s): u = (-0.08 s min(t, 2), 0) m,
    v = (-0.08 s, 0) m/s for 0 <= t < 2 and 0 after (right derivative), a = 0; s is the load
    scale of SPEC section 8 (1: the paper's motion)."""
    speed = -0.08 * scale  # m/s
    u = np.array([speed * min(t, 2.0), 0.0])
    v = np.array([speed if t < 2.0 else 0.0, 0.0])
    return u, v, np.zeros(2)


def benchmark(
    mesh_size: int = 20,
    needle_width: float = 0.0,
    load_scale: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "quadrilateral",
    mesh: str = "structured",
) -> Benchmark:
    """Benchmark A: the block fixed on its left, bottom and top edges, pushed by the needle at
    (1, 0.5). With needle_width w > 0 (m) every right-edge node with |y - 0.5| <= w/2 moves;
    load_scale s multiplies the needle's motion (SPEC section 8); cell and mesh pick the
    mesh (SPEC 9: quadrilateral or triangle, structured or unstructured)."""
    if not (isinstance(needle_width, (int, float)) and 0 <= needle_width < 1):
        raise MeshError(f"needle width must satisfy 0 <= w < 1 m, got {needle_width!r}")
    check_load_scale(load_scale)
    tagged = block_mesh(mesh_size, comm, msh_path, cell, mesh, needle_width)
    options = {"needle_width": needle_width, "load_scale": load_scale}
    options.update(shape_options(2, cell, mesh))
    mesh = tagged.mesh
    if needle_width > 0:
        half = needle_width / 2 + 1e-10
        needle = (
            0,
            dolfinx.mesh.locate_entities_boundary(
                mesh, 0, lambda x: np.isclose(x[0], 1.0) & (np.abs(x[1] - 0.5) <= half)
            ),
        )
    else:
        needle = tagged.entities("needle")
    constraints = [
        Constraint("needle", *needle, lambda t: needle_motion(t, load_scale)),
        *(Constraint(edge, *tagged.entities(edge), fixed(2)) for edge in ("left", "bottom", "top")),
    ]
    return Benchmark(
        name="block",
        tagged=tagged,
        constraints=constraints,
        gravity=(0.0, 0.0),
        material=ENTRY.material,
        dt=ENTRY.dt,
        end_time=ENTRY.end_time,
        extent=LENGTH,
        mesh_size=mesh_size,
        options=options,
    )


def posing(needle_width: float = 0.0, load_scale: float = 1.0) -> Posing:
    """The block's regions (SPEC 4): the needle at (1, 0.5) (its width w in m spread along
    x = 1), pushed by needle_motion at load scale s; fixed left, bottom and top edges."""
    if not (isinstance(needle_width, (int, float)) and 0 <= needle_width < 1):
        raise MeshError(f"needle width must satisfy 0 <= w < 1 m, got {needle_width!r}")
    check_load_scale(load_scale)
    x, y = NEEDLE
    needle = (Term(0, x), Term(1, y, needle_width / 2))
    return Posing(
        (
            Region("needle", needle, lambda t: needle_motion(t, load_scale)),
            Region("left", (Term(0, 0.0),), fixed(2)),
            Region("bottom", (Term(1, 0.0),), fixed(2)),
            Region("top", (Term(1, LENGTH),), fixed(2)),
        ),
        (0.0, 0.0),
        LENGTH,
    )


def options_text(option) -> str:
    """The needle's width in words, from option(name, default)."""
    w = option("needle_width", 0) or 0
    return f", w = {w:g} m" if w else ", w = 0 (point needle)"


def place(x, mesh_size: int, option) -> str:
    """Where the point x (m) lies on the block, in words: beside the needle (x = 1,
    |y - 0.5| <= w/2) within 1.5 cells."""
    w = option("needle_width", 0) or 0
    d = np.hypot(NEEDLE[0] - x[0], max(abs(x[1] - NEEDLE[1]) - w / 2, 0.0))
    return ", beside the needle" if d < 1.5 / mesh_size else ""


def no_truth(options: dict) -> str | None:
    """A point needle (w = 0) has no truth."""
    if float(options.get("needle_width", 0.0)) == 0:
        return (
            "the needle is a point (w = 0): a prescribed point displacement has infinite "
            "energy in 2D, so refinement converges to no solution; the block's truth cases "
            "take w = 0.2 m"
        )
    return None


def truth_hint(case: str, cases: str) -> str | None:
    """Why a block case name that is not a truth case (`cases`: the block's) has none: a
    neo-Hookean one (block-MP1-nh-s2-w0.2 as it was), or a point needle (w = 0)."""
    if not case.startswith("block"):
        return None
    if "-nh" in case:
        return (
            "the block has no large-deformation truth (SPEC 10: a needle bonded to the "
            "tissue and pushed far has no converging solution); grade it against implicit on "
            f"its own mesh. The block's truth cases are linear: {cases}"
        )
    width = case.rpartition("-w")[2] if "-w" in case else "0"
    try:
        point_needle = float(width) == 0
    except ValueError:
        point_needle = False
    if point_needle:
        return (
            "this case has no converged reference (SPEC 10: with a point needle, "
            "w = 0, refinement converges to no solution); the block's truth cases have a "
            f"needle of width w = 0.2 m: {cases}"
        )
    return None


ENTRY = Entry(
    build=benchmark,
    gdim=2,
    material="MP1",
    mesh_size=20,
    dt=1 / 30,
    end_time=10.0,
    nodes=lambda N: (N + 1) ** 2,
    cell_size=lambda N: LENGTH / N,
    materials=("MP1", "MP2"),
    study_sizes=(10, 20, 40, 80),
    options={
        "needle_width": "needle tip width w in m, 0 <= w < 1 (default 0)",
        "load_scale": LOAD_SCALE_HELP,
    },
    # a point load is singular: refinement studies spread the needle over w = 0.2 m (SPEC 4)
    refinement_options={"needle_width": 0.2},
    box=(LENGTH, LENGTH),
    posing=posing,
    truth_levels=(20, 40, 80),
    quick_truth_levels=(10, 20, 40),
    quick_truth_seconds=5.0,  # block-MP1 2.7 s, block-MP2 6.0 s, whole commands (probe 0.78)
    no_truth=no_truth,
    truth_hint=truth_hint,
    title="Block and needle",
    size_name="N",
    grid=((1, 1), "quadrilaterals", "N even: the needle's end on a node"),
    options_text=options_text,
    place=place,
    # SPEC 7, our paraphrase of the paper
    claims={
        "MP2": "Block, MP2 at h = 1/30: the explicit schemes diverge; implicit and "
        "quasi-static run."
    },
)
