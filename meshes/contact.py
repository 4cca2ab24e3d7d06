"""The needle as contact (SPEC section 12): the rigid half-stadium needle and the block's mesh
graded toward the part of its right edge that the needle touches.

The needle S(t) is the disc of radius R = 0.1 m centred at c(t), with the strip
{x >= c_x(t), |y - 0.5| <= R} to its right; c(0) = (1 + R, 0.5) m, so that it touches the
block's right edge at (1, 0.5) at rest, and c(t) = c(0) + s g(t) with g the needle motion of
SPEC 4 (block.needle_motion) and s the load scale. Its signed distance is the distance to the
ray {c + (r, 0), r >= 0} minus R (negative inside), smooth except on that ray.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes.benchmark import (
    LOAD_SCALE_HELP,
    Benchmark,
    Constraint,
    Contact,
    Entry,
    check_load_scale,
    fixed,
    shape_options,
)
from tissuebench.meshes.block import LENGTH, NEEDLE, block_mesh, needle_motion
from tissuebench.meshes.gmshio import MeshError, TaggedMesh, gmsh_options, start_gmsh, to_dolfinx
from tissuebench.meshes.regions import Posing, Region, Term, Touching
from tissuebench.meshes.tools import HalfStadium

RADIUS = 0.1  # m, R of SPEC 12 (w = 2R = 0.2 m)
KAPPA = 10.0  # SPEC 12: the penalty k = kappa E / h_e of our algorithms, by default
# the band of the right edge |y - 0.5| <= SWEPT that the truth's grids are graded toward (SPEC
# 12: 1.5 R, m)
SWEPT = 1.5 * RADIUS

LAW = (
    "frictionless contact on the right edge x = 1 (free otherwise): the gap g_n, the signed "
    "distance (m, negative inside) from the deformed point x = X + u to S(t), satisfies "
    "g_n >= 0, the contact pressure p >= 0 (Pa) acts along the outward normal of S at the "
    "closest point, p g_n = 0, and there is no tangential traction"
)


def needle(load_scale: float = 1.0) -> HalfStadium:
    """The needle (SPEC 12) at load scale s: the half-stadium of radius R whose centre moves as
    c(t) = (1 + R, 0.5) + s g(t) m, g the block's needle motion (SPEC 4)."""
    check_load_scale(load_scale)
    return HalfStadium(
        radius=RADIUS,
        c0=(NEEDLE[0] + RADIUS, NEEDLE[1]),
        motion=lambda t: needle_motion(t)[:2],
        scale=float(load_scale),
    )


def check_kappa(kappa: object) -> None:
    """Refuse a penalty kappa that is not a number within 0 < kappa < 1e12 (MeshError)."""
    if not (isinstance(kappa, (int, float)) and not isinstance(kappa, bool) and 0 < kappa < 1e12):
        raise MeshError(f"the penalty kappa must be a number > 0 (and below 1e12), got {kappa!r}")


def graded_block(
    h_near: float,
    h_far: float = 0.05,
    band: float = SWEPT,
    grow: float = 0.3,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> TaggedMesh:
    """The block [0, 1] x [0, 1] m in gmsh's Frontal-Delaunay triangles, of size h_near (m)
    on the right edge's band |y - 0.5| <= band (m), growing linearly with the distance from
    it to h_far (m) at `grow` (m). Physical groups "left", "right", "bottom", "top" (edges)."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    if not (0 < h_near <= h_far <= LENGTH and 0 < band < LENGTH / 2 and grow > 0):
        raise MeshError(
            f"a graded block needs 0 < h_near <= h_far <= 1 m and 0 < band < 0.5 m, got "
            f"h_near {h_near!r}, h_far {h_far!r}, band {band!r}"
        )
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add("contact-block")
        geo = gmsh.model.geo
        y0, y1 = NEEDLE[1] - band, NEEDLE[1] + band
        p = [
            geo.addPoint(x, y, 0.0, h_far)
            for x, y in [(0, 0), (1, 0), (1, y0), (1, y1), (1, 1), (0, 1)]
        ]
        bottom = geo.addLine(p[0], p[1])
        right_low, contact, right_high = (geo.addLine(p[i], p[i + 1]) for i in (1, 2, 3))
        top = geo.addLine(p[4], p[5])
        left = geo.addLine(p[5], p[0])
        loop = geo.addCurveLoop([bottom, right_low, contact, right_high, top, left])
        surface = geo.addPlaneSurface([loop])
        geo.synchronize()
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "CurvesList", [contact])
        field.setNumber(distance, "Sampling", max(200, int(2 * band / h_near)))
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", h_near)
        field.setNumber(threshold, "SizeMax", h_far)
        field.setNumber(threshold, "DistMin", 0.0)
        field.setNumber(threshold, "DistMax", grow)
        field.setAsBackgroundMesh(threshold)
        gmsh.model.addPhysicalGroup(2, [surface], 1, name="block")
        gmsh.model.addPhysicalGroup(1, [left], 1, name="left")
        gmsh.model.addPhysicalGroup(1, [right_low, contact, right_high], 2, name="right")
        gmsh.model.addPhysicalGroup(1, [bottom], 3, name="bottom")
        gmsh.model.addPhysicalGroup(1, [top], 4, name="top")
        sizes = ("MeshSizeFromPoints", "MeshSizeFromCurvature", "MeshSizeExtendFromBoundary")
        options = {f"Mesh.{name}": 0.0 for name in sizes} | {"Mesh.Algorithm": 6.0}  # Frontal
        with gmsh_options(options):  # the size from the field alone, Frontal-Delaunay
            gmsh.model.mesh.generate(2)
    return to_dolfinx(comm, gdim=2)


def benchmark(
    mesh_size: int = 20,
    load_scale: float = 1.0,
    kappa: float = KAPPA,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "quadrilateral",
    mesh: str = "structured",
) -> Benchmark:
    """The block of SPEC 4 (N x N cells, fixed left, bottom and top edges) with the needle as
    contact (SPEC 12): nothing is attached to the needle, whose half-stadium moves by s g(t)
    and pushes the right edge through the penalty k = kappa E / h_e, h_e = 1/N m the right
    edge's cell size."""
    check_load_scale(load_scale)
    check_kappa(kappa)
    tagged = block_mesh(mesh_size, comm, msh_path, cell, mesh)
    options = {"load_scale": load_scale, "kappa": float(kappa)}
    options.update(shape_options(2, cell, mesh))
    constraints = [
        Constraint(edge, *tagged.entities(edge), fixed(2)) for edge in ("left", "bottom", "top")
    ]
    return Benchmark(
        name="contact",
        tagged=tagged,
        constraints=constraints,
        gravity=(0.0, 0.0),
        material=ENTRY.material,
        dt=ENTRY.dt,
        end_time=ENTRY.end_time,
        extent=LENGTH,
        mesh_size=mesh_size,
        options=options,
        contact=Contact(
            facets=tagged.entities("right")[1],
            tool=needle(load_scale),
            kappa=float(kappa),
            edge_size=LENGTH / mesh_size,
        ),
    )


def posing(load_scale: float = 1.0, kappa: float = KAPPA) -> Posing:
    """The contact block's regions (SPEC 12): the fixed left, bottom and top edges, and the
    needle as a tool touching the right edge x = 1, at load scale s and penalty kappa."""
    check_load_scale(load_scale)
    check_kappa(kappa)
    return Posing(
        (
            Region("left", (Term(0, 0.0),), fixed(2)),
            Region("bottom", (Term(1, 0.0),), fixed(2)),
            Region("top", (Term(1, LENGTH),), fixed(2)),
        ),
        (0.0, 0.0),
        LENGTH,
        tool=Touching(surface=(Term(0, NEEDLE[0]),), tool=needle(load_scale), kappa=float(kappa)),
    )


def contact_export(mesh_size: int, load_scale: float = 1.0, kappa: float = KAPPA) -> dict:
    """The needle as the export states it (the JSON's `contact` object, SI units): its shape,
    its centre's motion c(t) = c0 + s g(t) with g's parameters, the contact law, our penalty
    k = kappa E / h_e (h_e = 1/N m, our right edge's cell size) and what is graded."""
    check_load_scale(load_scale)
    check_kappa(kappa)
    speed = needle_motion(0.0)[1]  # m/s, g's velocity until it stops
    depth = needle_motion(float("inf"))[0]  # m, g where it stops
    tool = needle(load_scale)
    c0 = tool.centre(0.0)
    return {
        "what": "the needle as a rigid tool in frictionless contact with the block's right "
        "edge: nothing is attached to it; it pushes the edge only where the tissue touches it",
        "shape": tool.shape(),
        "motion": {
            "centre": "c(t) = c0 + s g(t)",
            "c0": [float(v) for v in c0],
            "load_scale": float(load_scale),
            "g": "g(t) = (v_x min(t, t_stop), 0): the block benchmark's needle motion, "
            "stopping at t_stop",
            "v_x": float(speed[0]),
            "t_stop": float(depth[0] / speed[0]),
            "touching": "at t = 0 the needle touches the right edge at (1, 0.5) only, with no "
            "force",
        },
        "law": {
            "words": LAW,
            "friction": "none",
            "surface": Term(0, NEEDLE[0]).text,
            "gap": "g_n(X, t) = g(X + u(X, t)) at every point X of the surface, g the signed "
            "distance to S(t) with c = c(t) (m, negative inside)",
            "conditions": "g_n >= 0, p >= 0, p g_n = 0 (p the contact pressure, Pa, acting on "
            "the tissue along n at the closest point of S), no tangential traction",
            "methods": "a solver may impose this law by any contact method (penalty, "
            "Lagrange multipliers, augmented Lagrangian, Nitsche, an active set); ours is the "
            "penalty below",
        },
        "penalty": {
            "ours": "the energy (k/2) int_surface <-g_n>^2 dS (J/m, <z> = max(z, 0)) added to "
            "the elastic energy: the pressure p = k <-g_n> (Pa) on the tissue along n; Newton "
            "takes its exact tangent (the active set may change within a step)",
            "k_formula": "k = kappa E / h_e (Pa/m), E the material's Young's modulus",
            "kappa": float(kappa),
            "h_e": LENGTH / mesh_size,
            "h_e_meaning": "our right edge's smallest cell size, 1/N m",
        },
        "graded": {
            "displacement": "E_n, E_s and E_i as `metrics` says, against our reference",
            "force": "F(t) = -int_surface p n dS (N/m): the force per unit thickness that the "
            "tissue exerts on the needle, x and y components, at every t_i; its error is "
            "max over the steps of |F - F_ref| / max |F_ref|",
            "interpenetration": "the largest -g_n over the deformed surface (m, 0 where the "
            "tissue does not pass into the needle), at every t_i and over the steps; ours "
            "samples each deformed edge between two nodes at 9 points",
        },
        "units": {
            "shape.radius": "m",
            "motion.c0": "m",
            "motion.c": "m",
            "motion.v_x": "m/s",
            "motion.t_stop": "s",
            "motion.load_scale": "1",
            "penalty.kappa": "1",
            "penalty.h_e": "m",
            "penalty.k": "Pa/m",
            "graded.force": "N/m",
            "graded.interpenetration": "m",
        },
    }


def options_text(option) -> str:
    """The penalty's kappa in words, from option(name, default)."""
    return f", rigid needle R = {RADIUS:g} m, kappa = {option('kappa', KAPPA):g}"


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
        "load_scale": LOAD_SCALE_HELP,
        "kappa": f"the contact penalty k = kappa E / h_e, h_e = 1/N m (default {KAPPA:g}, SPEC 12)",
    },
    box=(LENGTH, LENGTH),
    posing=posing,
    tool=lambda load_scale=1.0, **options: needle(load_scale),
    contact_export=contact_export,
    contact_surface="right",
    graded=graded_block,
    title="Block and rigid needle (contact)",
    size_name="N",
    grid=((1, 1), "quadrilaterals", "N even"),
    options_text=options_text,
    truth_levels=(10, 20, 40),
    quick_truth_levels=(4, 8, 16),
    quick_truth_seconds=30.0,
    studied=False,
)
