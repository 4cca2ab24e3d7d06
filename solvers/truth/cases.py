"""The truth cases of SPEC 10 on the benchmarks' grids.

The rod's levels are its uniform 2n x n x n grids, but rod-MP2's, graded toward the clamped
face's edges as the blocks' toward the needle's (graded_rod, nested likewise). The linear
blocks' are their N x N grids with the grid lines moved toward the
needle's ends (1, 0.5 -/+ w/2), where the displacement is singular (a bonded punch's edge):
x = phi(xi) and y = psi(eta) of the uniform grid's xi, eta, each a square-power grading toward
the needle's end lines (x = 1; y = 0.5 -/+ w/2, from both sides) that keeps 0, 0.5 -/+ w/2,
0.5 and 1 in place. The cells stay rectangles, a level's grid lines are the last level's plus
one between each two (the levels nest, as uniform refinement does), and the needle's segment
is the same set of right-edge nodes as on the uniform grid. Measured on the static block at
t = 2 s, MP1, N = 10, 20, 40, 80: the E_i between levels falls with order 2.0 graded and
1.1-1.4 uniform (MP2: 2.0 and 1.4-1.7).

The cylinder's cases (SPEC 13) are computed on its meridian, not on the 3D benchmark's mesh:
their levels (MERIDIAN_LEVELS) are axisymmetric.meridian_mesh's n x n quadrilaterals on
[0, R_B] x [0, H] graded toward the top face's centre (an evenly fine zone of MERIDIAN_FINE m
from the axis and from the top face), posed by meridian_benchmark with the capsule's meridian
(a half-stadium along +z) and u_r = 0 on the axis (benchmark_problem's `axisymmetric`).
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.meshes import get_entry
from tissuebench.meshes.benchmark import Benchmark, Constraint, Contact, fixed
from tissuebench.meshes.gmshio import TaggedMesh
from tissuebench.solvers.materials import Material, get_material
from tissuebench.solvers.truth import axisymmetric as axi
from tissuebench.solvers.truth.solver import Boundary, ContactLaw, Problem, Truth

# case -> (benchmark, material, model, load scale s, needle width w in m or None)
CASES = {
    "rod": ("rod", "MP3", "linear", 1.0, None),
    "rod-nh-s1": ("rod", "MP3", "neo-hookean", 1.0, None),
    # SPEC 8: large loads take the barrier law, whose energy grows without bound as J -> 0
    "rod-nhb-s3": ("rod", "MP3", "neo-hookean-barrier", 3.0, None),
    "rod-MP2": ("rod", "MP2", "linear", 1.0, None),  # SPEC 11: nearly incompressible, 3D
    "block-MP1-w0.2": ("block", "MP1", "linear", 1.0, 0.2),
    "block-MP2-w0.2": ("block", "MP2", "linear", 1.0, 0.2),
    # SPEC 12: the needle as contact
    "contact-MP1": ("contact", "MP1", "linear", 1.0, None),
    "contact-MP2": ("contact", "MP2", "linear", 1.0, None),
    "contact-MP1-nhb": ("contact", "MP1", "neo-hookean-barrier", 1.0, None),
    # SPEC 13: the needle in 3D, its truth on the cylinder's meridian
    "cylinder-MP1": ("cylinder", "MP1", "linear", 1.0, None),
    "cylinder-MP2": ("cylinder", "MP2", "linear", 1.0, None),
    "cylinder-MP1-nhb": ("cylinder", "MP1", "neo-hookean-barrier", 1.0, None),
}
# SPEC 12's Hertz check: the benchmark whose tool is pushed statically (solvers/truth/hertz.py)
HERTZ = "contact"


def register_case(
    case: str,
    benchmark: str,
    material: str,
    model: str = "linear",
    load_scale: float = 1.0,
    needle_width: float | None = None,
) -> None:
    """Add a truth case of a registered benchmark (meshes.register) to CASES, on its uniform
    grids at its h."""
    if case in CASES:
        raise ValueError(f"truth case {case!r} exists")
    CASES[case] = (benchmark, material, model, load_scale, needle_width)


def remove_case(case: str) -> None:
    """Take a case that register_case added out of CASES."""
    del CASES[case]


GRADING = 2.0  # the power of the block grid's grading toward the needle's ends
# the cases on graded grids: the linear blocks (toward the needle's ends) and rod-MP2 (toward
# its clamped face's edges, where the nearly incompressible rod is singular: uniform levels
# n = 2, 4, 8 converged with order 1.5 there, graded with 2.2, measured to T = 2 s at h/2)
GRADED = {
    "block-MP1-w0.2": lambda x: graded_block(x, 0.2),
    "block-MP2-w0.2": lambda x: graded_block(x, 0.2),
    "rod-MP2": lambda x: graded_rod(x, get_entry("rod").box),
    "contact-MP1": lambda x: graded_contact(x),
    "contact-MP2": lambda x: graded_contact(x),
    "contact-MP1-nhb": lambda x: graded_contact(x),
}
# SPEC 12: the truth's penalty k = TRUTH_KAPPA E / h_min, h_min the contact edge's smallest
# facet on the level (SPEC 12's limit: the finest level again with 10 k, compared)
TRUTH_KAPPA = 1e3
# the share of the contact block's rows of cells in the band |y - 0.5| <= 1.5 R that the needle
# sweeps (the rest outside it), and the power of the columns' grading toward x = 1
CONTACT_BAND = (0.35, 0.65)
CONTACT_BAND_SHARE = 0.6
CONTACT_X_GRADING = 1.5
# the truth's time step is the benchmark's h / STEP_DIVISOR (sampled at the steps of h): the
# linear blocks' own error is otherwise mostly in time, and the needle's stop at t = 2 s makes
# them first order in time (N = 20: E_i max between h/k and h/2k for k = 1, 2, 4, 8: MP1
# 1.32e-5, 6.65e-6, 3.35e-6, 1.68e-6 m^2; MP2 6.89e-5, 3.65e-5, 1.77e-5, 8.05e-6)
STEP_DIVISOR = {"block-MP1-w0.2": 4, "block-MP2-w0.2": 16, "rod-MP2": 4}
# SPEC 13: the cases computed on the cylinder's meridian, case -> (levels, quick levels): n x n
# graded meridian grids (axisymmetric.meridian_mesh), each level twice the last
MERIDIAN_LEVELS = {
    "cylinder-MP1": ((10, 20, 40), (4, 8, 16)),
    "cylinder-MP2": ((10, 20, 40), (4, 8, 16)),
    "cylinder-MP1-nhb": ((10, 20, 40), (4, 8, 16)),
}
# m: the meridian's evenly fine zone at the top face's centre, 1.5 R (SPEC 12's band): the
# capsule at s = 1 is 0.16 m deep, its ball's rim (r = R = 0.1 m) and shaft in the tissue
MERIDIAN_FINE = 0.15


def _toward(xi: np.ndarray, a: float, b: float, end: float) -> np.ndarray:
    """xi in [a, b] (m) moved toward its end `end` (a or b) by the power GRADING: the cell
    sizes fall as the distance to that end, the ends stay in place."""
    s = (xi - a) / (b - a)
    if end == a:
        return a + (b - a) * s**GRADING
    return b - (b - a) * (1 - s) ** GRADING


def graded_block(x: np.ndarray, width: float) -> None:
    """Move the uniform block grid's points x (rows x, y[, z], m) in place toward the needle's
    ends: x toward 1; y toward 0.5 - w/2 and 0.5 + w/2 from both sides."""
    low, high = 0.5 - width / 2, 0.5 + width / 2
    x[:, 0] = _toward(x[:, 0], 0.0, 1.0, 1.0)
    y = x[:, 1].copy()
    for a, b, end in ((0.0, low, low), (low, 0.5, low), (0.5, high, high), (high, 1.0, high)):
        inside = (y >= a) & (y <= b)
        x[inside, 1] = _toward(y[inside], a, b, end)


def graded_contact(x: np.ndarray) -> None:
    """Move the uniform contact block grid's points x (rows x, y, m) in place: x toward the
    right edge by the power CONTACT_X_GRADING; y piecewise linearly, CONTACT_BAND_SHARE of
    the rows in the band CONTACT_BAND the needle sweeps, the rest spread below and above it.
    The map is the same on every level, so that the levels nest."""
    s = 1.0 - x[:, 0]
    x[:, 0] = 1.0 - s**CONTACT_X_GRADING
    (low, high), share = CONTACT_BAND, CONTACT_BAND_SHARE
    eta = np.array([0.0, (1 - share) / 2, (1 + share) / 2, 1.0])
    x[:, 1] = np.interp(x[:, 1], eta, [0.0, low, high, 1.0])


def graded_rod(x: np.ndarray, size: tuple[float, ...]) -> None:
    """Move the uniform rod grid's points x (rows x, y, z, m) in place toward the clamped face's
    edges: x toward 0; y toward 0 and the height, z toward 0 and the depth, from the middle."""
    length, height, depth = size
    x[:, 0] = _toward(x[:, 0], 0.0, length, 0.0)
    for j, extent in ((1, height), (2, depth)):
        y = x[:, j].copy()
        low = y <= extent / 2
        x[low, j] = _toward(y[low], 0.0, extent / 2, 0.0)
        x[~low, j] = _toward(y[~low], extent / 2, extent, extent)


def _constraint_nodes(V: fem.FunctionSpace, dim: int, entities: np.ndarray) -> np.ndarray:
    """The nodes of V on the mesh entities (dim, entities); for vertices, also the nodes of
    the boundary facets whose vertices are all in the set (a Q2 edge's midpoint)."""
    mesh = V.mesh
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(dim, tdim)
    nodes = [fem.locate_dofs_topological(V, dim, entities)]
    if dim == 0:  # collective (connectivities, dofs): on every rank, one without entities too
        mesh.topology.create_connectivity(tdim - 1, tdim)
        mesh.topology.create_connectivity(tdim - 1, 0)
        inside = np.zeros(
            mesh.topology.index_map(0).size_local + mesh.topology.index_map(0).num_ghosts, bool
        )
        inside[entities] = True
        f2v = mesh.topology.connectivity(tdim - 1, 0)
        facets = np.array(
            [
                f
                for f in dolfinx.mesh.exterior_facet_indices(mesh.topology)
                if inside[f2v.links(f)].all()
            ],
            dtype=np.int32,
        )
        nodes.append(fem.locate_dofs_topological(V, tdim - 1, facets))
    return np.unique(np.concatenate(nodes)).astype(np.int32)


def _contact_law(benchmark: Benchmark, E: float, penalty: float) -> ContactLaw | None:
    """The benchmark's contact (SPEC 12) with the truth's penalty: penalty x TRUTH_KAPPA x E /
    the shortest facet of the contact edge on this (graded) mesh; None without contact."""
    c = benchmark.contact
    if c is None:
        return None
    mesh = benchmark.mesh
    ends = mesh.geometry.x[dolfinx.mesh.entities_to_geometry(mesh, 1, c.facets)[:, :2]]
    lengths = np.linalg.norm(ends[:, 0] - ends[:, 1], axis=1)
    shortest = mesh.comm.allreduce(float(lengths.min()) if len(lengths) else np.inf, op=MPI.MIN)
    k = penalty * TRUTH_KAPPA * E / shortest
    return ContactLaw(facets=c.facets, tool=c.tool, k=k)


def benchmark_problem(
    benchmark: Benchmark,
    material: Material | str,
    model: str = "linear",
    penalty: float = 1.0,
    axisymmetric: bool = False,
) -> Problem:
    """The truth Problem of a benchmark (meshes.benchmark.Benchmark, built with its load scale
    and needle width) with a material (solvers.materials.Material or name): its constraints on
    every Q2 node of the constrained entities, gravity rho g (N/m^3), its probe, and its
    contact (SPEC 12) with the truth's penalty times `penalty`. `axisymmetric`: the benchmark
    is a meridian (meridian_benchmark): u_r = 0 on the Q2 nodes of its "axis" edges, and the
    Problem axisymmetric (SPEC 13)."""
    mat = get_material(material)
    rho = mat.rho
    gravity = np.asarray(benchmark.gravity, dtype=float)

    def boundaries(V):
        out = []
        if axisymmetric:  # first: the fixed bottom's corner node keeps both components fixed
            dim, axis = benchmark.tagged.entities("axis")
            out.append(
                Boundary(_constraint_nodes(V, dim, axis), lambda t, x: (0.0, 0.0, 0.0), (0,))
            )
        for c in benchmark.constraints:
            motion = c.motion
            out.append(
                Boundary(_constraint_nodes(V, c.dim, c.entities), lambda t, x, m=motion: m(t))
            )
        return out

    return Problem(
        mesh=benchmark.mesh,
        mu=mat.mu,
        lmbda=mat.lmbda,
        rho=rho,
        alpha=mat.alpha,
        beta=mat.beta,
        model=model,
        body_force=lambda x, t: rho * ufl.as_vector([float(g) for g in gravity]),
        boundaries=boundaries,
        probe=benchmark.probe,
        contact=_contact_law(benchmark, mat.E, penalty),
        axisymmetric=axisymmetric,
    )


def meridian_benchmark(
    name: str, mesh_size: int, load_scale: float = 1.0, comm: MPI.Comm = MPI.COMM_WORLD
) -> Benchmark:
    """The benchmark `name` (the cylinder, SPEC 13) posed on its meridian (r, z) in m: the
    graded n x n grid of axisymmetric.meridian_mesh (n = mesh_size, fine zone MERIDIAN_FINE),
    its bottom edge fixed, its top edge in contact with the entry's tool at `load_scale` on
    the meridian (the capsule's half-stadium along +z; penalty set by benchmark_problem), the
    entry's h and T, no probe. Its physical groups are axisymmetric.TAGS's edges (the axis
    among them: benchmark_problem(..., axisymmetric=True) holds u_r = 0 there). Collective."""
    entry = get_entry(name)
    radius, height = entry.body["radius"], entry.body["height"]
    if (radius, height) != (axi.R_B, axi.H):
        raise ValueError(f"the meridian truth is SPEC 13's body, not {radius} x {height} m")
    meridian = axi.meridian_mesh(mesh_size, fine=MERIDIAN_FINE, comm=comm)
    tags = {group: (1, meridian.edges) for group in axi.TAGS}
    tagged = TaggedMesh(mesh=meridian.mesh, tags=tags, groups=dict(axi.TAGS))
    # the ignores: the cylinder's entry has a tool, a Capsule; no check here, the truth's cache
    # key hashes this code
    tool = entry.tool(load_scale=load_scale)  # type: ignore[misc]
    return Benchmark(
        name=name,
        tagged=tagged,
        constraints=[Constraint("bottom", *tagged.entities("bottom"), fixed(2))],
        gravity=(0.0, 0.0),
        material=entry.material,
        dt=entry.dt,
        end_time=entry.end_time,
        extent=height,
        mesh_size=mesh_size,
        probe=None,
        options={"load_scale": load_scale, "meridian": True},
        contact=Contact(
            facets=tagged.entities("top")[1],
            tool=tool.meridian(),  # type: ignore[union-attr]
            kappa=TRUTH_KAPPA,
            edge_size=meridian.h_near,
        ),
    )


def case_truth(
    case: str, mesh_size: int, comm: MPI.Comm = MPI.COMM_WORLD, penalty: float = 1.0
) -> tuple[Truth, Benchmark]:
    """(Truth, Benchmark) of a SPEC 10 case on the benchmark's grid of `mesh_size` (the
    linear block's graded toward the needle's ends: graded_block; the cylinder's cases on its
    graded meridian: meridian_benchmark); a contact case's penalty is the truth's times
    `penalty`."""
    from tissuebench.meshes import get_benchmark

    name, material, model, scale, width = CASES[case]
    if case in MERIDIAN_LEVELS:
        bench = meridian_benchmark(name, mesh_size, scale, comm)
        return Truth(benchmark_problem(bench, material, model, penalty, axisymmetric=True)), bench
    options = {"load_scale": scale}
    if width is not None:
        options["needle_width"] = width
    bench = get_benchmark(name, mesh_size=mesh_size, comm=comm, **options)
    if case in GRADED:
        GRADED[case](bench.mesh.geometry.x)
    return Truth(benchmark_problem(bench, material, model, penalty)), bench
