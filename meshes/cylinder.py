"""The needle in 3D (SPEC 13): a tissue cylinder of radius R_B = 0.5 m and height H = 1 m, its
axis along z, fixed on its bottom face z = 0, pushed into the centre of its free top face by a
rigid capsule of radius R = 0.1 m on the axis (meshes/tools/capsule.py) in frictionless penalty
contact: c(t) = (0, 0, H + R) + s g(t), g(t) = (0, 0, -0.08 min(t, 2)) m (SPEC 4's needle motion
along -z). No body force. Its continuum solution is axisymmetric (the truth's meridian).

Mesh size n: the cells along the radius (meshes/cylinder_mesh.py: hexahedra in an O-grid by
default, or gmsh's tetrahedra), the top face's centre a node, optionally graded toward it.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np

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
from tissuebench.meshes.contact import check_kappa
from tissuebench.meshes.cylinder_mesh import (
    HEIGHT,
    RADIUS_BODY,
    cylinder_cell_size,
    cylinder_mesh,
    cylinder_nodes,
)
from tissuebench.meshes.gmshio import TaggedMesh
from tissuebench.meshes.regions import Posing, Region, Term, Touching, shortest_edge
from tissuebench.meshes.tools import Capsule

RADIUS = 0.1  # m, the capsule's R (SPEC 13)
KAPPA = 10.0  # SPEC 12's penalty k = kappa E / h_e of our algorithms, by default
SPEED = -0.08  # m/s along z until T_STOP (SPEC 4's needle motion)
T_STOP = 2.0  # s
TOP_CENTRE = (0.0, 0.0, HEIGHT)  # m, where the capsule touches at rest

LAW = (
    "frictionless contact on the top face z = H (free otherwise): the gap g_n, the signed "
    "distance (m, negative inside) from the deformed point x = X + u to S(t), satisfies "
    "g_n >= 0, the contact pressure p >= 0 (Pa) acts along the outward normal of S at the "
    "closest point, p g_n = 0, and there is no tangential traction"
)


def needle_motion(t: float) -> tuple[np.ndarray, np.ndarray]:
    """g(t) = (0, 0, -0.08 min(t, 2)) m and g'(t) (m/s, the right derivative) at load scale 1."""
    return (
        np.array([0.0, 0.0, SPEED * min(t, T_STOP)]),
        np.array([0.0, 0.0, SPEED if t < T_STOP else 0.0]),
    )


def capsule(load_scale: float = 1.0) -> Capsule:
    """The capsule at load scale s: radius R, c(t) = (0, 0, H + R) + s g(t) m."""
    check_load_scale(load_scale)
    return Capsule(
        radius=RADIUS, c0=(0.0, 0.0, HEIGHT + RADIUS), motion=needle_motion, scale=float(load_scale)
    )


def benchmark(
    mesh_size: int = 6,
    load_scale: float = 1.0,
    kappa: float = KAPPA,
    grading: float = 1.0,
    comm: MPI.Comm = MPI.COMM_WORLD,
    msh_path: str | Path | None = None,
    cell: str = "hexahedron",
    mesh: str = "structured",
) -> Benchmark:
    """The cylinder (SPEC 13) of mesh size n, fixed on z = 0, its top face z = H pushed by the
    capsule through the penalty k = kappa E / h_e, h_e the top face's shortest cell edge (m).
    cell: hexahedron (the O-grid, default) or tetrahedron (gmsh's); grading >= 1 toward the top
    centre."""
    check_load_scale(load_scale)
    check_kappa(kappa)
    shape_options(3, cell, mesh)  # checked: the cells SPEC 9 defines in 3D
    tagged: TaggedMesh = cylinder_mesh(mesh_size, comm, msh_path, cell=cell, grading=grading)
    options: dict = {"load_scale": load_scale, "kappa": float(kappa)}
    if grading != 1.0:
        options["grading"] = float(grading)
    options.update(shape_options(3, cell, mesh))
    top = tagged.entities("top")[1]
    return Benchmark(
        name="cylinder",
        tagged=tagged,
        constraints=[Constraint("bottom", *tagged.entities("bottom"), fixed(3))],
        gravity=(0.0, 0.0, 0.0),
        material=ENTRY.material,
        dt=ENTRY.dt,
        end_time=ENTRY.end_time,
        extent=HEIGHT,
        mesh_size=mesh_size,
        probe=TOP_CENTRE,
        options=options,
        contact=Contact(
            facets=top,
            tool=capsule(load_scale),
            kappa=float(kappa),
            edge_size=shortest_edge(tagged.mesh, top),
        ),
    )


def posing(load_scale: float = 1.0, kappa: float = KAPPA, grading: float = 1.0) -> Posing:
    """The cylinder's regions (SPEC 13): its bottom z = 0 fixed, the capsule touching its top
    z = H, at load scale s and penalty kappa (grading is our mesh's, not the posing's)."""
    check_load_scale(load_scale)
    check_kappa(kappa)
    return Posing(
        (Region("bottom", (Term(2, 0.0),), fixed(3)),),
        (0.0, 0.0, 0.0),
        HEIGHT,
        tool=Touching(surface=(Term(2, HEIGHT),), tool=capsule(load_scale), kappa=float(kappa)),
    )


def contact_export(
    mesh_size: int, load_scale: float = 1.0, kappa: float = KAPPA, grading: float = 1.0
) -> dict:
    """The capsule as the export states it (the JSON's `contact` object, SI units): its shape,
    its centre's motion c(t) = c0 + s g(t), the contact law, our penalty k = kappa E / h_e and
    what is graded."""
    tool = capsule(load_scale)
    return {
        "what": "the needle as a rigid capsule in frictionless contact with the cylinder's top "
        "face: nothing is attached to it; it pushes the face only where the tissue touches it",
        "shape": tool.shape(),
        "motion": {
            "centre": "c(t) = c0 + s g(t)",
            "c0": [float(v) for v in tool.centre(0.0)],
            "load_scale": float(load_scale),
            "g": "g(t) = (0, 0, v_z min(t, t_stop)): along the axis, stopping at t_stop",
            "v_z": SPEED,
            "t_stop": T_STOP,
            "touching": "at t = 0 the capsule touches the top face at its centre (0, 0, H) "
            "only, with no force",
        },
        "law": {
            "words": LAW,
            "friction": "none",
            "surface": Term(2, HEIGHT).text,
            "gap": "g_n(X, t) = g(X + u(X, t)) at every point X of the surface, g the signed "
            "distance to S(t) with c = c(t) (m, negative inside)",
            "conditions": "g_n >= 0, p >= 0, p g_n = 0 (p the contact pressure, Pa, acting on "
            "the tissue along n at the closest point of S), no tangential traction",
            "methods": "a solver may impose this law by any contact method (penalty, "
            "Lagrange multipliers, augmented Lagrangian, Nitsche, an active set); ours is the "
            "penalty below",
        },
        "penalty": {
            "ours": "the energy (k/2) int_surface <-g_n>^2 dS (J, <z> = max(z, 0)) added to "
            "the elastic energy: the pressure p = k <-g_n> (Pa) on the tissue along n; Newton "
            "takes its exact tangent (the active set may change within a step)",
            "k_formula": "k = kappa E / h_e (Pa/m), E the material's Young's modulus",
            "kappa": float(kappa),
            "h_e": cylinder_cell_size(mesh_size) / grading,
            "h_e_meaning": "about our top face's smallest cell size, R_B / (n grading) m (our "
            "runs take the shortest edge of the top face's cells)",
        },
        "graded": {
            "displacement": "E_n, E_s and E_i as `metrics` says, against our reference",
            "force": "F(t) = -int_surface p n dS (N): the force that the tissue exerts on the "
            "capsule, x, y and z components, at every t_i; its error is max over the steps of "
            "|F_z - F_z,ref| / max |F_z,ref|; x and y are a symmetry error (0 for the exact, "
            "axisymmetric answer)",
            "interpenetration": "the largest -g_n over the deformed top face (m, 0 where the "
            "tissue does not pass into the capsule), at every t_i and over the steps",
        },
        "units": {
            "shape.radius": "m",
            "motion.c0": "m",
            "motion.c": "m",
            "motion.v_z": "m/s",
            "motion.t_stop": "s",
            "motion.load_scale": "1",
            "penalty.kappa": "1",
            "penalty.h_e": "m",
            "penalty.k": "Pa/m",
            "graded.force": "N",
            "graded.interpenetration": "m",
        },
    }


def options_text(option) -> str:
    """The capsule and the penalty's kappa in words, from option(name, default)."""
    grading = option("grading", 1.0)
    graded = f", graded x {grading:g} toward the top centre" if grading != 1.0 else ""
    return f", rigid capsule R = {RADIUS:g} m, kappa = {option('kappa', KAPPA):g}{graded}"


ENTRY = Entry(
    build=benchmark,
    gdim=3,
    material="MP1",
    mesh_size=6,
    dt=1 / 30,
    end_time=10.0,
    nodes=lambda n: cylinder_nodes(n, "hexahedron"),
    cell_size=cylinder_cell_size,
    materials=("MP1", "MP2"),
    study_sizes=(3, 6, 12),
    options={
        "load_scale": LOAD_SCALE_HELP,
        "kappa": f"the contact penalty k = kappa E / h_e, h_e the top face's shortest cell edge "
        f"(default {KAPPA:g}, SPEC 12)",
        "grading": "cells at the top face's centre about this many times smaller (>= 1, "
        "default 1: uniform)",
    },
    probe=TOP_CENTRE,
    probe_label="top centre (0, 0, 1) m",
    body={
        "domain": "cylinder",
        "words": "{x^2 + y^2 <= R_B^2, 0 <= z <= H}: a cylinder on the z axis",
        "radius": RADIUS_BODY,
        "height": HEIGHT,
        "axes": ["x", "y", "z"],
        "extents": [[-RADIUS_BODY, RADIUS_BODY], [-RADIUS_BODY, RADIUS_BODY], [0.0, HEIGHT]],
    },
    posing=posing,
    tool=lambda load_scale=1.0, **options: capsule(load_scale),
    contact_export=contact_export,
    contact_surface="top",
    title="Tissue cylinder and rigid capsule (3D contact)",
    size_name="n",
    size_words="n cells along the radius, h = 0.5/n m: an O-grid of hexahedra (a square core "
    "and four blocks to the circle, 2n layers), or gmsh's tetrahedra (--cell tetrahedron)",
    options_text=options_text,
    studied=False,
)
