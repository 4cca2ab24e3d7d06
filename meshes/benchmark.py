"""What a benchmark is: a tagged mesh, the constrained boundary with its prescribed motion,
the body force, and the SPEC's defaults."""

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Callable

import dolfinx.mesh
import numpy as np

from tissuebench.meshes.gmshio import TaggedMesh
from tissuebench.meshes.tools import Tool


@dataclass
class Constraint:
    """Every component of the nodes on `entities` (of dimension `dim`, local indices) follows
    `motion(t) -> (u, v, a)`, each an array of gdim components in m, m/s and m/s^2."""

    name: str
    dim: int
    entities: np.ndarray
    motion: Callable


@dataclass
class Contact:
    """A rigid tool in frictionless penalty contact with the body (SPEC 12, 13): the boundary
    facets `facets` (local indices, dimension gdim - 1) may touch `tool` (meshes/tools/); the
    penalty is k = kappa E / edge_size (Pa/m), edge_size the smallest cell size along those
    facets (m)."""

    facets: np.ndarray
    tool: Tool
    kappa: float
    edge_size: float

    def centre(self, t: float) -> np.ndarray:
        """The tool's centre c(t) (m) at time t (s)."""
        return self.tool.centre(t)


@dataclass
class Benchmark:
    name: str
    tagged: TaggedMesh
    constraints: list
    gravity: tuple  # m/s^2, constant for t >= 0
    material: str  # default material name
    dt: float  # default time step h, s
    end_time: float  # default end time T, s
    extent: float  # largest extent of the undeformed domain, m (divergence threshold x 100)
    mesh_size: int
    probe: tuple | None = None  # a point whose displacement is reported (the rod's tip), m
    options: dict = field(default_factory=dict)
    contact: Contact | None = None  # a rigid tool in contact (SPEC 12), or none

    @property
    def mesh(self) -> dolfinx.mesh.Mesh:
        return self.tagged.mesh

    @property
    def gdim(self) -> int:
        return self.tagged.mesh.geometry.dim


@dataclass(frozen=True)
class Entry:
    """A benchmark in the registry: how to build it, and what commands need to know before
    building its mesh (defaults, the options it takes, its size for a mesh size)."""

    build: Callable[..., Benchmark]  # build(mesh_size=..., comm=..., msh_path=..., **options)
    gdim: int
    material: str  # default material name
    mesh_size: int  # default mesh size
    dt: float  # default time step h, s
    end_time: float  # default end time T, s
    nodes: Callable[[int], int]  # the number of mesh nodes for a mesh size
    cell_size: Callable[[int], float]  # the edge of one cell for a mesh size, m
    materials: tuple[str, ...]  # the SPEC's materials for it, the default first
    study_sizes: tuple[
        int, ...
    ]  # mesh sizes of the stability sweep and the space-convergence study
    # keyword options of build beyond mesh_size, comm, msh_path: {name: help}; numbers, which
    # build validates (raising MeshError); `run` offers each as --name
    options: dict[str, str] = field(default_factory=dict)
    refinement_options: dict = field(default_factory=dict)  # options for mesh-refinement studies
    probe: tuple[float, ...] | None = None  # a point whose displacement is reported, m
    probe_label: str = ""  # its name in tables and figures
    # the undeformed body: the box [0, box[0]] x [0, box[1]] (x [0, box[2]]), m
    box: tuple[float, ...] = ()
    # the undeformed body when it is no box, as the export states it ({"domain": "cylinder",
    # ...}: its shape's words and numbers, m, and "extents", the bounding box [[min, max] per
    # axis]); {} for the box above
    body: dict = field(default_factory=dict)
    # its constrained regions as predicates: posing(**options) -> meshes.regions.Posing (None:
    # the benchmark states none, so that it is neither exported with a geometry nor posed on a
    # mesh that is not ours)
    posing: Callable[..., Any] | None = None
    # a rigid tool in contact with it (SPEC 12, 13): tool(**options) -> its Tool (meshes/tools/)
    # at the posing's options (load_scale); None for a benchmark without contact
    tool: Callable[..., Tool] | None = None
    # the contact as the export states it: contact_export(mesh_size, **options) -> the JSON's
    # `contact` object (plain data: the tool's shape and motion, the law, our penalty, what is
    # graded); None for a benchmark without contact
    contact_export: Callable[..., dict] | None = None
    # the physical group of our mesh that may touch the tool, and our mesh graded toward where
    # the tool touches: graded(h_near, h_far=..., band=..., comm=...) -> TaggedMesh (m)
    contact_surface: str = ""
    graded: Callable[..., TaggedMesh] | None = None
    # the truth's hierarchy (SPEC 10): mesh sizes, each twice the last, and the quick ones (CI
    # and tests, never the truth) with about how long a quick linear case takes here, s
    truth_levels: tuple[int, ...] = ()
    quick_truth_levels: tuple[int, ...] = ()
    quick_truth_seconds: float = 10.0
    # why the truth does not pose this benchmark with these options (a sentence), or None
    no_truth: Callable[[dict], str | None] = lambda options: None
    # why `case`, a name that is not a truth case, has none (a sentence, the benchmark's truth
    # cases `cases` in it), or None when the name says nothing of this benchmark
    truth_hint: Callable[[str, str], str | None] = lambda case, cases: None
    # names for reports: its title, the letter of its mesh size, its own options in words
    # (from option(name, default): ", w = 0.2 m") and where a point (m) lies on it
    # (from the point, the mesh size and option: ", beside the needle")
    title: str = ""
    size_name: str = "n"
    # what its mesh size gives, for --mesh-size's help: a grid's cells per axis as multiples of
    # the size, the cells' name and what else the size must be ((1, 1), "quadrilaterals", "N
    # even"), or, for a mesh that is no grid, a sentence (size_words)
    grid: tuple[tuple[int, ...], str, str] | None = None
    size_words: str = ""
    options_text: Callable[[Callable], str] = lambda option: ""
    place: Callable[[Sequence[float], int, Callable], str] = lambda x, size, option: ""
    # what SPEC 7 claims of it by material, quoted in the stability report
    claims: dict[str, str] = field(default_factory=dict)
    # whether the stability sweep and the convergence studies take it (the paper's benchmarks)
    studied: bool = True


# SPEC 9: the cell shapes of each dimension, the default first, and the two kinds of mesh
CELLS = {2: ("quadrilateral", "triangle"), 3: ("hexahedron", "tetrahedron")}
MESHES = ("structured", "unstructured")
SIMPLICES = ("triangle", "tetrahedron")
PLURAL = {
    "triangle": "triangles",
    "quadrilateral": "quadrilaterals",
    "tetrahedron": "tetrahedra",
    "hexahedron": "hexahedra",
}


def check_shape(gdim: int, cell: str, mesh: str) -> None:
    """Refuse a cell shape or mesh kind that SPEC 9 does not define for a gdim-D benchmark
    (MeshError: bad input). Unstructured meshes are simplices: gmsh's Delaunay/Frontal."""
    from tissuebench.meshes.gmshio import MeshError

    if cell not in CELLS[gdim]:
        raise MeshError(f"cell {cell!r}: a {gdim}D benchmark takes {' or '.join(CELLS[gdim])}")
    if mesh not in MESHES:
        raise MeshError(f"mesh {mesh!r}: use {' or '.join(MESHES)}")
    if mesh == "unstructured" and cell not in SIMPLICES:
        raise MeshError(
            f"an unstructured mesh is made of simplices: use --cell {CELLS[gdim][1]} with it "
            f"({PLURAL[cell]} come as the structured grid only)"
        )


def shape_options(gdim: int, cell: str | None, mesh: str | None) -> dict:
    """The benchmark options {cell, mesh} that differ from the defaults (quadrilaterals or
    hexahedra, structured), checked: the defaults stay out, so today's runs keep their
    options and fingerprints."""
    cell = cell or CELLS[gdim][0]
    mesh = mesh or MESHES[0]
    check_shape(gdim, cell, mesh)
    options = {}
    if cell != CELLS[gdim][0]:
        options["cell"] = cell
    if mesh != MESHES[0]:
        options["mesh"] = mesh
    return options


# The range of E (Pa), rho (kg/m^3) and the load scale s (SPEC 8), and the upper bound of the
# Rayleigh alpha (1/s) and beta (s). Float64 holds 2.2e-308 to 1.8e308; the assembled
# matrices and loads are products of up to three of these values with the mesh's lengths, and
# the solvers' residual norms sum their squares. Within 1e-40 to 1e40, a product of three and
# its square stay within 1e-240 to 1e240: finite, with room for the mesh and the step. Real
# materials lie far inside (soft tissue 1e2 to 1e6 Pa, diamond 1.2e12 Pa; osmium 22,590
# kg/m^3). Larger values overflow (E = 1e308 made inf at the first solve).
SMALLEST, LARGEST = 1e-40, 1e40
WHY_RANGE = "products of E, rho and the load scale, and their squares, must stay finite in float64"

LOAD_SCALE_HELP = "load scale s > 0: the prescribed motion and gravity times s (default 1, SPEC 8)"


def check_load_scale(s: object) -> None:
    """Refuse a load scale that is not a finite positive number (MeshError: bad input)."""
    from tissuebench.meshes.gmshio import MeshError

    if not (isinstance(s, (int, float)) and not isinstance(s, bool) and 0 < s < float("inf")):
        raise MeshError(f"load scale must be a finite number > 0, got {s!r}")
    if not SMALLEST <= s <= LARGEST:
        raise MeshError(
            f"load scale must be within {SMALLEST:g} to {LARGEST:g} ({WHY_RANGE}), got {s:g}"
        )


def fixed(gdim: int) -> Callable[[float], tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The motion of a clamped node: u = v = a = 0."""
    zero = np.zeros(gdim)
    return lambda t: (zero, zero, zero)
