"""A toy third benchmark, defined here alone (issue 34 item 1): a 2D plate [0, 0.4] x [0, 0.1] m
of 4n x n quadrilaterals (or triangles, SPEC 9), clamped on its left edge x = 0 and bending
under gravity 0.01 s m/s^2 in -y (s the load scale), material MP3, h = 0.01 s to T = 0.2 s
(20 steps: the explicit schemes are stable at n <= 4). Its probe: the free end's top corner.

`registered()` adds it to the registry (meshes.register) with one linear truth case, "plate"
(solvers.truth.cases.register_case), its leaderboard case plate-MP3 graded against that truth
(workflows.boards.register) and its two cases of the paper, plate-MP3 in part 1 and plate-MP3-s1
in part 2 (workflows.paper_cases.register), for as long as the context lasts; everything the
commands know of it is in its ENTRY, its BOARD and its PAPER cases."""

from __future__ import annotations

import contextlib
from pathlib import Path

from mpi4py import MPI

import gmsh

from tissuebench.meshes import register, unregister
from tissuebench.meshes.benchmark import (
    LOAD_SCALE_HELP,
    Benchmark,
    Entry,
    check_load_scale,
    check_shape,
    fixed,
    shape_options,
)
from tissuebench.meshes.gmshio import check_positive_int, start_gmsh, to_dolfinx
from tissuebench.meshes.posed import on_mesh
from tissuebench.meshes.regions import Posing, Region, Term
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.models import REFERENCE_MODEL, run_label
from tissuebench.solvers.truth.cases import register_case, remove_case
from tissuebench.workflows.leaderboard import boards
from tissuebench.workflows.run.case import algorithm_case, model_case
from tissuebench.workflows.study import cases as paper_cases

NAME = "plate"
SIZE = (0.4, 0.1)  # m
GRAVITY = (0.0, -0.01)  # m/s^2: a static deflection of about 5 cm
CORNER = (0.4, 0.1)  # m, the free end's top corner


def posing(load_scale: float = 1.0) -> Posing:
    """Clamped on x = 0, gravity 0.01 s m/s^2 in -y."""
    check_load_scale(load_scale)
    return Posing(
        (Region("clamped", (Term(0, 0.0),), fixed(2)),),
        tuple(load_scale * g for g in GRAVITY),
        max(SIZE),
    )


def gmsh_plate(n: int, cell: str, mesh: str) -> None:
    """The 4n x n plate in the current gmsh model: the structured grid of quadrilaterals or
    triangles, or gmsh's unstructured triangles at spacing 0.1/n m (SPEC 9's shapes)."""
    length, height = SIZE
    geo = gmsh.model.geo
    p = [
        geo.addPoint(x, y, 0.0, height / n)
        for x, y in [(0, 0), (length, 0), (length, height), (0, height)]
    ]
    lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    geo.synchronize()
    if mesh == "structured":
        for curve, cells in zip(lines, (4 * n, n, 4 * n, n), strict=True):
            gmsh.model.mesh.setTransfiniteCurve(curve, cells + 1)
        quadrilaterals = cell == "quadrilateral"
        gmsh.model.mesh.setTransfiniteSurface(
            surface, arrangement="Left" if quadrilaterals else "Alternate"
        )
        if quadrilaterals:
            gmsh.model.mesh.setRecombine(2, surface)
    else:
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
    gmsh.model.addPhysicalGroup(2, [surface], 1, name=NAME)
    gmsh.model.mesh.generate(2)


def benchmark(
    mesh_size: int = 2,
    load_scale: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "quadrilateral",
    mesh: str = "structured",
) -> Benchmark:
    """The plate: its mesh from gmsh, its constrained nodes found by its regions' predicates."""
    check_positive_int("mesh size n", mesh_size)
    check_shape(2, cell, mesh)
    check_load_scale(load_scale)
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add(f"{NAME}-{mesh_size}")
        gmsh_plate(mesh_size, cell, mesh)
    tagged = to_dolfinx(comm, gdim=2, msh_path=msh_path)
    posed = on_mesh(NAME, tagged.mesh, load_scale=load_scale)  # its regions' nodes, found
    return Benchmark(
        name=NAME,
        tagged=tagged,
        constraints=posed.constraints,
        gravity=posed.gravity,
        material=ENTRY.material,
        dt=ENTRY.dt,
        end_time=ENTRY.end_time,
        extent=posed.extent,
        mesh_size=mesh_size,
        probe=ENTRY.probe,
        options={"load_scale": load_scale, **shape_options(2, cell, mesh)},
    )


ENTRY = Entry(
    build=benchmark,
    gdim=2,
    material="MP3",
    mesh_size=2,
    dt=0.01,
    end_time=0.2,
    nodes=lambda n: (4 * n + 1) * (n + 1),
    cell_size=lambda n: SIZE[1] / n,
    materials=("MP3",),
    study_sizes=(1, 2, 4),
    options={"load_scale": LOAD_SCALE_HELP},
    probe=CORNER,
    probe_label="corner (0.4, 0.1) m",
    box=SIZE,
    posing=posing,
    truth_levels=(1, 2, 4),
    quick_truth_levels=(1, 2, 4),
    quick_truth_seconds=3.0,
    title="Plate under gravity",
    size_name="n",
)


# its leaderboard case: ours (linear) on the default mesh, no outside simulator, graded against
# its truth "plate"
BOARD = boards.Board(
    "plate-MP3", NAME, "MP3", "linear", simulators=(), truth=NAME, description="the plate"
)
# its cases of the paper: part 1, every algorithm against implicit; part 2, every algorithm with
# every model against implicit with the reference model
PAPER = algorithm_case("plate-MP3", NAME, "MP3", list(ALGORITHMS), description="Plate")
LARGE = model_case(
    "plate-MP3-s1",
    NAME,
    "MP3",
    list(ALGORITHMS),
    list(MODELS),
    run_label("implicit", REFERENCE_MODEL),
)


@contextlib.contextmanager
def registered():
    """The plate in the registry, with its truth case, its leaderboard case and its cases of
    the paper, for the context's length (each taken out again, in the reverse order)."""
    with contextlib.ExitStack() as added:
        register(NAME, ENTRY)
        added.callback(unregister, NAME)
        register_case(NAME, NAME, "MP3", "linear")
        added.callback(remove_case, NAME)
        boards.register(BOARD)
        added.callback(boards.unregister, BOARD.name)
        paper_cases.register(PAPER)
        added.callback(paper_cases.unregister, PAPER.name)
        paper_cases.register(LARGE, large=True)
        added.callback(paper_cases.unregister, LARGE.name)
        yield ENTRY
