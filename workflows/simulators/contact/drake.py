"""Drake on the contact benchmark (SPEC 12): the plane-strain block as a one-element slab of a
deformable FEM body, pushed by the needle as a rigid body on a prismatic joint, with Drake's
deformable-rigid contact (SAP).

The posed problem
-----------------
- Mesh: the slab of `contact/mujoco.py`'s `slab` (the quadrilaterals extruded by t_z = 1/N m, six
  tetrahedra per hexahedron; export node i is slab node i at z = 0 and N + i at z = t_z),
  written as the rod's .vtk; Drake's linear P1 tetrahedra (`kLinear`; the other models as the
  rod's), its one-point mass, D = alpha M + beta K, its VelocityNewmarkScheme at h (module
  `drake`).
- Fixed edges: Drake's wall condition holds one half-space only (a second call replaced the
  first: the bottom edge moved 0.03 m, measured), so the left, bottom and top edges are
  fixed constraints (`AddFixedConstraint`: every vertex inside a box around the edge) to a
  rigid body of 1e9 kg on a prismatic joint whose position and rate are set back to zero
  before every step (a welded body is refused: "a clique with zero number of velocities");
  measured, the edges then stay within 3e-8 m.
- Plane strain: Drake holds a vertex in all components or none, so after every step each
  vertex's z and z velocity are set back to rest and zero (SetPositionsAndVelocities): a
  projection between steps, not a constraint within them.
- The needle: a rigid body of 1e6 kg on a prismatic joint along x, its translation and rate
  set to c(t_i) and (c(t_{i+1}) - c(t_i)) / h before each step; its collision geometry a
  cylinder of radius R along z (the disc) and a box from c_x to c_x + 1 m of height 2R (the
  strip), both rigid hydroelastic (resolution hint R / 20) with friction 0; Drake computes
  their contact with the deformable's surface (its own contact stiffness, no penalty k set
  here).
- Output: the displacement at every t_i on the export's nodes and quadrilaterals (the mean of
  the slab's two layers); the needle force F = -(the sum of the deformable contacts' forces on
  the tissue, ContactResults' F_Ac_W) / t_z (N/m), at the end of each step.
- Divergence as the rod's: a displacement not finite or beyond 100 x the extent, an inverted
  tetrahedron for a nonlinear model, or Drake raising; NaN from there on, status "failed".

Measured (contact-MP1, Drake 1.58.0, 2 shared cores), against our implicit on the same grid
(kappa = 10): N = 20, 10 s: E_n time mean 0.53 (max 1.4, at the first steps), E_i max
1.3e-2 m^2; F_x(2 s) 42.8 N/m against our 34.5, F_x(10 s) 31.2 against 29.6, F_y up to
4.5 N/m (the split's asymmetry; the tip node drifts 0.013 m in y); interpenetration 4.3e-3 m
(ours 1.3e-2 m); 41-61 s wall time (our implicit 3.7 s), two runs on the shared cores.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, installed_version, integrated
from tissuebench.workflows.simulators.contact.mujoco import (
    MESH,
    planar,
    slab,
    slab_problem,
    tool,
)
from tissuebench.workflows.simulators.drake import (
    DIVERGED,
    drake_elasticity,
    write_vtk,
)
from tissuebench.workflows.simulators.drake import (
    VARIANTS as ROD_VARIANTS,
)
from tissuebench.workflows.simulators.newton import tet_volumes

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

SERIES = "drake.xdmf"
FORCE = "drake_force.csv"
MESH_FILE = "drake_slab.vtk"
FIELD = "displacement"
STRIP = 1.0  # m: the needle's strip, from c_x to c_x + STRIP
NEEDLE_MASS = 1e6  # kg: the needle's body, its joint state set before every step
FRAME_MASS = 1e9  # kg: the body the fixed edges are constrained to, reset before every step
HOLD = 4.0  # m: the boxes around the fixed edges, this long along them and in z


def model_of(data: Exported) -> str:
    """The rod variants' model name for the export's (neo-hookean-barrier: the neo-Hookean
    variants, its barrier not posed)."""
    return "neo-hookean" if data.model == "neo-hookean-barrier" else data.model


def posed(data: Exported) -> str | None:
    """None when this module poses the contact export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    if data.procedure != "dynamic":
        return "Drake steps its deformable bodies in time only; no static procedure"
    if not any(model_of(data) in spec[1] for spec in ROD_VARIANTS.values()):
        return f"no Drake counterpart of the {data.model} model"
    return slab_problem(data, "a moving constrained set has no counterpart here")


def variants(data: Exported) -> dict[str, str]:
    """The rod's Drake variants that suit the export's model, as contact variants."""
    if posed(data) is not None:
        return {}
    from tissuebench.workflows.simulators.drake import elastic_words

    return {
        name: f"contact: {spec[2]}; a one-element slab, u_z projected to 0 after each step "
        f"(plane strain); the needle a rigid cylinder + box on a prismatic joint set to c(t), "
        f"frictionless, Drake's deformable-rigid contact (rigid hydroelastic, hint R/20); "
        f"{elastic_words(data.material, name)}"
        for name, spec in ROD_VARIANTS.items()
        if model_of(data) in spec[1]
    }


def skipped(data: Exported) -> dict[str, str]:
    """Why no contact variant poses this export ({} when one does)."""
    why = posed(data)
    return {} if why is None else {"all": why}


def build(data: Exported, variant: str, mesh_file: Path, nodes: np.ndarray, thickness: float):
    """(simulator, plant, plant context, deformable model, body id, needle joint, frame joint)."""
    from pydrake.geometry import (
        AddContactMaterial,
        AddRigidHydroelasticProperties,
        Box,
        Cylinder,
        GeometryInstance,
        Mesh,
        ProximityProperties,
    )
    from pydrake.math import RigidTransform
    from pydrake.multibody.fem import DeformableBodyConfig, MaterialModel
    from pydrake.multibody.plant import (
        AddMultibodyPlant,
        CoulombFriction,
        MultibodyPlantConfig,
    )
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    m = data.material
    E, nu = drake_elasticity(m, variant)
    config = DeformableBodyConfig()
    config.set_youngs_modulus(E)
    config.set_poissons_ratio(nu)
    config.set_mass_density(float(m.rho))
    config.set_mass_damping_coefficient(float(m.alpha))
    config.set_stiffness_damping_coefficient(float(m.beta))
    config.set_material_model(getattr(MaterialModel, ROD_VARIANTS[variant][0]))
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=float(data.h)), builder)

    def frictionless() -> ProximityProperties:
        props = ProximityProperties()
        AddContactMaterial(friction=CoulombFriction(0.0, 0.0), properties=props)
        return props

    geometry = GeometryInstance(RigidTransform(), Mesh(str(mesh_file)), "tissue")
    geometry.set_proximity_properties(frictionless())
    model = plant.mutable_deformable_model()
    body = model.RegisterDeformableBody(geometry, config, 1.0)
    frame = plant.AddRigidBody(
        "frame", SpatialInertia(FRAME_MASS, np.zeros(3), UnitInertia(1, 1, 1))
    )
    hold = plant.AddJoint(
        PrismaticJoint("hold", plant.world_frame(), frame.body_frame(), np.array([0.0, 0.0, 1.0]))
    )
    xs, ys = nodes[:, 0], nodes[:, 1]
    hx, hy = xs[xs > 1e-9].min() / 2.0, ys[ys > 1e-9].min() / 2.0
    top = ys.max()
    for centre, size in (
        ((0.0, 0.5 * top, 0.0), (2 * hx, HOLD, HOLD)),
        ((0.5, 0.0, 0.0), (HOLD, 2 * hy, HOLD)),
        ((0.5, top, 0.0), (HOLD, 2 * hy, HOLD)),
    ):
        where = RigidTransform(np.array(centre, dtype=float))
        model.AddFixedConstraint(body, frame, RigidTransform(), Box(*size), where)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    radius = float(tool(data)["shape"]["radius"])
    inertia = SpatialInertia(NEEDLE_MASS, np.zeros(3), UnitInertia(1, 1, 1))
    needle = plant.AddRigidBody("needle", inertia)
    slide = plant.AddJoint(
        PrismaticJoint("slide", plant.world_frame(), needle.body_frame(), np.array([1.0, 0.0, 0.0]))
    )
    rigid = frictionless()
    AddRigidHydroelasticProperties(radius / 20.0, rigid)
    c0 = np.array([centres[0, 0], centres[0, 1], thickness / 2.0])
    plant.RegisterCollisionGeometry(
        needle, RigidTransform(c0), Cylinder(radius, 2 * thickness), "disc", rigid
    )
    strip = RigidTransform(c0 + [STRIP / 2.0, 0.0, 0.0])
    plant.RegisterCollisionGeometry(
        needle, strip, Box(STRIP, 2 * radius, 2 * thickness), "strip", rigid
    )
    plant.mutable_gravity_field().set_gravity_vector(np.zeros(3))
    plant.Finalize()
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyContextFromRoot(context)
    simulator = Simulator(diagram, context)
    simulator.Initialize()
    return simulator, plant, plant_context, model, body, slide, hold


def integrate(data: Exported, variant: str, workdir: Path, steps: int | None = None) -> dict:
    """Pose and step the contact export: {"U" (steps + 1, 2N, 2) m per slab node and "force"
    (steps + 1, 2) N/m, NaN from a divergence on; "diverged"; "reason"; "wall_time_s" (from
    building the plant to the last step)}."""
    steps = data.steps if steps is None else steps
    nodes, tets, thickness = slab(data)
    mesh_file = Path(workdir) / MESH_FILE
    write_vtk(mesh_file, nodes, tets)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    start = time.perf_counter()
    simulator, plant, context, model, body, slide, hold = build(
        data, variant, mesh_file, nodes, thickness
    )
    rest = model.GetPositions(context, body).T.copy()
    if not np.allclose(rest, nodes, rtol=0.0, atol=1e-12):
        raise RuntimeError("Drake's reference positions are not the slab's nodes")
    U = np.full((steps + 1, len(nodes), 2), np.nan)
    F = np.full((steps + 1, 2), np.nan)
    U[0], F[0] = 0.0, 0.0
    diverged, reason = None, None
    for i in range(1, steps + 1):
        slide.set_translation(context, centres[i - 1, 0] - centres[0, 0])
        slide.set_translation_rate(context, (centres[i, 0] - centres[i - 1, 0]) / data.h)
        hold.set_translation(context, 0.0)
        hold.set_translation_rate(context, 0.0)
        try:
            simulator.AdvanceTo(i * data.h)
        except Exception as err:  # Drake's solver failing: a divergence
            first = (str(err).strip().splitlines() or [""])[0]
            diverged, reason = i, f"Drake raised {type(err).__name__}: {first}"[:300]
            break
        q = model.GetPositions(context, body).T.copy()
        v = model.GetVelocities(context, body).T.copy()
        q[:, 2], v[:, 2] = rest[:, 2], 0.0  # plane strain: u_z = 0, projected
        model.SetPositionsAndVelocities(context, body, q.T, v.T)
        u = q[:, :2] - rest[:, :2]
        if not np.all(np.isfinite(u)):
            diverged, reason = i, "a displacement is not finite"
        elif np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
            diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
        elif data.model != "linear":
            J = tet_volumes(np.c_[nodes[:, :2] + u, nodes[:, 2]], tets) / volumes
            if J.min() <= 0:
                diverged, reason = i, f"{int(np.sum(J <= 0))} tetrahedra inverted"
        if diverged is not None:
            break
        results = plant.get_contact_results_output_port().Eval(context)
        on_tissue = np.zeros(3)
        for k in range(results.num_deformable_contacts()):
            on_tissue += results.deformable_contact_info(k).F_Ac_W().translational()
        U[i] = u
        F[i] = -on_tissue[:2] / thickness
    return {
        "U": U,
        "force": F,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": time.perf_counter() - start,
    }


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one contact variant serially in workdir: drake.xdmf (the displacement, m, at every
    t_i on the export's quadrilaterals, NaN from a divergence on) and drake_force.csv (the
    needle force, N/m, up to the last good step)."""
    version = installed_version("drake")
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    dofs = 2 * 2 * len(data.nodes)
    try:
        result = integrate(data, variant, workdir)
    except Exception as err:  # Drake refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return ExternalRun(
            None, None, dofs, mesh=MESH, status="failed",
            reason=f"Drake raised {type(err).__name__}: {first}"[:300], version=version,
        )  # fmt: skip
    path = workdir / SERIES
    points = np.c_[np.asarray(data.nodes, dtype=np.float64), np.zeros(len(data.nodes))]
    cells = np.asarray(data.cells, dtype=np.int64)
    write_series(path, ((points, cells, "quadrilateral"), {FIELD: planar(result["U"])}), data.times)
    kept = np.all(np.isfinite(result["force"]), axis=1)
    force = workdir / FORCE
    write_force_csv(force, data.times[kept], result["force"][kept])
    timing = (
        f"time.perf_counter from building the plant (the .vtk read, the FEM model) to the last "
        f"of {data.steps} steps (the z projection and contact results included), one thread"
    )
    done = integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h, timing, version,
    )  # fmt: skip
    return dataclasses.replace(done, force=force)
