"""Drake on the needle in 3D (SPEC 13): the tissue cylinder as one of its deformable FEM bodies,
pushed into the centre of its top face by the capsule as a rigid body on a prismatic joint, with
Drake's own deformable-rigid contact (SAP).

The posed problem
-----------------
- Mesh: the export's hexahedra split into six tetrahedra each on the export's nodes: the rod's
  split (workflows/simulators/drake.py: newton.split_hexahedra) where it conforms, which it
  does not on the O-grid (its four blocks are turned against the core, so neighbours cut a
  shared face along different diagonals: a cracked body); there `cone_split`, each face cut
  through its lowest-numbered node, each cell a cone from its own lowest node (conforming,
  checked; not symmetric about the axis). Or the export's tetrahedra as they are (`--cell
  tetrahedron`; a negatively oriented one gets two vertices swapped). Written as the rod's
  .vtk; Drake keeps the vertex order (checked), so the series is on the export's nodes.
- Element and mass: Drake's linear tetrahedron (one-point quadrature) and its one-point mass
  rho V / 16 between every pair of a tetrahedron's corners (the rod's module docstring).
- Elasticity: `linear` is kLinear, small-strain elasticity with the export's E and nu; for the
  neo-Hookean exports (`neo-hookean`, and `neo-hookean-barrier` with its barrier not posed)
  `neo-hookean` is kNeoHookean (stable neo-Hookean, Smith et al. 2018) with E, nu mapped so
  that its small-strain Lame constants are the export's (drake.drake_elasticity).
- Damping: Drake's D = alpha M + beta K with the export's Rayleigh alpha and beta, M its
  one-point mass, K the current tangent (K_0 for kLinear, as the SPEC; beta K(u) for
  kNeoHookean where the SPEC keeps beta K_0). Nothing of the export's damping is dropped; the
  contact itself has no dissipation (Hunt-Crossley d = 0, set here and Drake's own for
  deformable contact).
- Bottom: Drake's wall condition (drake.wall: the half-space below the plane halfway between
  z = 0 and the next layer of nodes, held at zero displacement): exactly the export's fixed
  nodes. No gravity (the export's is zero).
- Scheme: Drake's only one for deformables, VelocityNewmarkScheme gamma = 1, beta = 1/2 (first
  order, dissipative; the SPEC's is the trapezoidal rule), one plant step of h per t_i,
  Drake's default discrete contact approximation ("lagged", solved by SAP).
- The capsule: a rigid body of 1e6 kg on a prismatic joint along z whose translation and rate
  are set to c(t_{i-1}) - c0 and (c(t_i) - c(t_{i-1})) / h before step i (so it is at c(t_i)
  after it: checked against motion.c to 1e-7 m), its collision geometry Drake's Capsule of
  radius R whose lower hemisphere is centred at c(t): the ball, and a shaft of SHAFT m above it,
  reaching c_z + 1 m >= 1.94 m, far above the top face (the half-infinite cylinder; the
  upper hemisphere never touches). Friction 0 on both geometries (CoulombFriction(0, 0),
  combined 0): SAP's contact is then normal only, frictionless.
- Contact (the variant's suffix; SAP's deformable-rigid contact, no penalty of ours):
  - none (`linear`, `neo-hookean`): the capsule rigid hydroelastic (its surface meshed at
    resolution hint R / 10, sagitta R / 800): Drake's default near-rigid deformable contact,
    whose stiffness is Drake's own and not settable. It chatters here: the force comes in blows
    (no contact at half the steps, 0 to 48 N), at every hint tried (R/4 to R/20).
  - `-compliant`: the capsule compliant hydroelastic with E_h = k R, k the export's penalty
    (contact.penalty.k = kappa E / h_e): Drake's capsule pressure field rises from 0 on its
    surface to E_h on its axis, so the pressure grows by k per metre of depth near the surface,
    as our penalty's p = k <-g_n>: the contact as soft as ours; smooth.
  - `-compliant-x100`: E_h = 100 k R, a hundred times as stiff; smooth.
- Output: the displacement at every t_i on the export's nodes (on the tetrahedra); the force on
  the capsule F = -(the sum over the deformable contacts of ContactResults' F_Ac_W, the force
  on the tissue), N, at the end of each step, written with write_force_csv (time, F_x, F_y,
  F_z). F_x and F_y are Drake's symmetry error (the problem is axisymmetric).
- Divergence as the rod's: a displacement not finite or beyond 100 x the extent, an inverted
  tetrahedron for `neo-hookean`, or Drake raising; NaN from there on, status "failed".

Measured (`export cylinder --mesh-size 3 --end-time 2.5`: MP1, kappa 10, 287 nodes, 1152
tetrahedra, h = 1/30 s; Drake 1.58.0, 2 shared cores, wall times 1.5 to 2.5 x apart between
runs); force on the capsule (N), |F_xy| its sideways part (largest over the steps), the
interpenetration and E_n (time mean) as `tissuebench compare` grades them against our `implicit`:

    variant                F_z(2 s)  F_z(2.5 s)  |F_xy|   interpen.  E_n    wall
    linear                 0 (*)     15.3        8.7      2.8e-3 m   1.64   5-9 s
    linear-compliant       10.6      8.6         0.53     3.4e-2 m   0.54   11-24 s
    linear-compliant-x100  15.4      11.4        1.03     3.7e-3 m   2.24   6 s
    ours: implicit (Q1)    4.90      4.87        < 1e-12  4.5e-2 m   -      9.3 s
    (*) a step without contact; the mean over 1.5-2 s is 14.1 N

With `--models neo-hookean-barrier`: neo-hookean F_z(2 s) 41.0 N (blows, mean 20.2 N over
1.5-2 s), interpenetration 2.7e-3 m; neo-hookean-compliant 12.1 N, 0.56 N sideways,
3.9e-2 m; ours (implicit, the barrier) 5.04 N, 5.1e-2 m, 25.7 s. So on n = 3 Drake's P1
tetrahedra with nu = 0.47 (volumetric locking) push back 2.2 to 3.1 times as hard as our Q1 at
the same depth; the sideways force (0.5 to 1 N, 5 % of F_z, up to 8.7 N in the rigid blows) is
the split's asymmetry, and the top centre node drifts 0.011 m in x and y.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, installed_version, integrated
from tissuebench.workflows.simulators.contact.drake import (
    FIELD,
    FORCE,
    NEEDLE_MASS,
    SERIES,
    model_of,
)
from tissuebench.workflows.simulators.contact.mujoco import tool
from tissuebench.workflows.simulators.drake import (
    DIVERGED,
    MESH,
    drake_elasticity,
    elastic_words,
    wall,
    write_vtk,
)
from tissuebench.workflows.simulators.drake import (
    VARIANTS as ROD_VARIANTS,
)
from tissuebench.workflows.simulators.newton import (
    cone_split,
    conforming,
    split_hexahedra,
    tet_volumes,
)

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

MESH_FILE = "drake_cylinder.vtk"
CONE_MESH = "tetrahedra, 6 per hexahedron (cone_split), on the reference's nodes"
SHAFT = 1.0  # m: the capsule's shaft above its lower hemisphere's centre c(t)
HINT = 0.1  # of R: the resolution hint of the capsule's surface mesh
# the rod's variants posed here, with the export models each suits
MATERIALS = {"linear": ("linear",), "neo-hookean": ("neo-hookean", "neo-hookean-barrier")}
# contact suffix -> (the capsule's hydroelastic modulus E_h in units of k R, k the export's
# penalty (None: rigid hydroelastic), one line of what it is)
CONTACTS = {
    "": (None, "the capsule rigid hydroelastic (hint R/10): Drake's near-rigid deformable "
         "contact (its default), its stiffness Drake's own"),
    "-compliant": (1.0, "the capsule compliant hydroelastic, E_h = k R (k the export's "
                   "penalty): pressure rising by k per m of depth, as soft as our penalty"),
    "-compliant-x100": (100.0, "the capsule compliant hydroelastic, E_h = 100 k R (k the "
                        "export's penalty): 100 times as stiff as our penalty"),
}  # fmt: skip


def posed(data: Exported) -> str | None:
    """None when this module poses the export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    shape = tool(data).get("shape", {})
    if shape.get("kind") != "capsule" or shape.get("axis") != "z":
        return "posed for the capsule along z (SPEC 13) only"
    if data.procedure != "dynamic":
        return "Drake steps its deformable bodies in time only; no static procedure"
    if data.dim != 3 or data.cell_type not in ("hexahedron", "tetrahedron"):
        return "a 3D body of hexahedra or tetrahedra only"
    if not any(model_of(data) in models for models in MATERIALS.values()):
        return f"no Drake counterpart of the {data.model} model posed here"
    if wall(data) is None:
        return (
            "the fixed nodes move or no plane cuts them off: Drake's wall condition holds a "
            "fixed half-space only"
        )
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose the export, name -> one line: the material model, the scheme,
    the contact (rigid or compliant capsule) and the export's E, nu as Drake takes them."""
    if posed(data) is not None:
        return {}
    k = float(tool(data)["penalty"]["k"])
    radius = float(tool(data)["shape"]["radius"])
    out = {}
    for name, models in MATERIALS.items():
        if model_of(data) not in models:
            continue
        for suffix, (factor, words) in CONTACTS.items():
            said = "" if factor is None else f" = {factor * k * radius:.6g} Pa"
            out[name + suffix] = (
                f"contact: {ROD_VARIANTS[name][2]}; the bottom by Drake's wall condition; "
                f"{words}{said}; frictionless capsule on a prismatic joint set to c(t); "
                f"{elastic_words(data.material, name)}"
            )
    return out


def skipped(data: Exported) -> dict[str, str]:
    """What is not posed of this export and why, one line each ({} when nothing)."""
    why = posed(data)
    if why is not None:
        return {"all": why}
    if data.model == "neo-hookean-barrier":
        return {
            "barrier": "neo-hookean-barrier's barrier has no Drake counterpart: kNeoHookean alone"
        }
    return {}


def tetrahedra(data: Exported) -> tuple[np.ndarray, str]:
    """((T, 4) positively oriented tetrahedra on the export's nodes, the mesh in words): the
    rod's six-tetrahedra split of its hexahedra where it conforms, else cone_split (the O-grid,
    whose blocks are turned against each other, cracks under the rod's split), or the export's
    own tetrahedra (ValueError for a split that does not conform)."""
    nodes = np.asarray(data.nodes, dtype=np.float64)
    cells = np.asarray(data.cells, dtype=np.int64)
    if data.cell_type == "tetrahedron":
        tets = cells.copy()
        flip = tet_volumes(nodes, tets) < 0
        tets[flip] = tets[flip][:, [0, 1, 3, 2]]
        return tets, "reference"
    tets = split_hexahedra(nodes, cells)
    if conforming(tets, cells):
        return tets, MESH
    tets = cone_split(nodes, cells)
    if not conforming(tets, cells) or tet_volumes(nodes, tets).min() <= 0:
        raise ValueError("no conforming split of these hexahedra into tetrahedra was found")
    return tets, CONE_MESH


def build(data: Exported, variant: str, mesh_file: Path):
    """(simulator, plant, plant context, deformable model, body id, capsule joint)."""
    from pydrake.geometry import (
        AddCompliantHydroelasticProperties,
        AddContactMaterial,
        AddRigidHydroelasticProperties,
        Capsule,
        GeometryInstance,
        Mesh,
        ProximityProperties,
    )
    from pydrake.math import RigidTransform
    from pydrake.multibody.fem import DeformableBodyConfig, MaterialModel
    from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    name = next(m for m in MATERIALS if variant.startswith(m))
    factor = CONTACTS[variant[len(name) :]][0]
    E, nu = drake_elasticity(data.material, name)
    config = DeformableBodyConfig()
    for setter, value in (
        (config.set_youngs_modulus, E),
        (config.set_poissons_ratio, nu),
        (config.set_mass_density, data.material.rho),
        (config.set_mass_damping_coefficient, data.material.alpha),
        (config.set_stiffness_damping_coefficient, data.material.beta),
    ):
        setter(float(value))
    config.set_material_model(getattr(MaterialModel, ROD_VARIANTS[name][0]))
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=float(data.h)), builder)

    def frictionless() -> ProximityProperties:
        props = ProximityProperties()
        AddContactMaterial(dissipation=0.0, friction=CoulombFriction(0.0, 0.0), properties=props)
        return props

    geometry = GeometryInstance(RigidTransform(), Mesh(str(mesh_file)), "tissue")
    geometry.set_proximity_properties(frictionless())
    model = plant.mutable_deformable_model()
    body = model.RegisterDeformableBody(geometry, config, 1.0)  # the hint is for primitives
    plane = wall(data)
    assert plane is not None  # posed() refused an export without one
    point, normal = plane
    model.SetWallBoundaryCondition(body, point, normal)
    contact = tool(data)
    radius = float(contact["shape"]["radius"])
    rigid = frictionless()
    if factor is not None:
        modulus = factor * float(contact["penalty"]["k"]) * radius
        AddCompliantHydroelasticProperties(HINT * radius, modulus, rigid)
    else:
        AddRigidHydroelasticProperties(HINT * radius, rigid)
    inertia = SpatialInertia(NEEDLE_MASS, np.zeros(3), UnitInertia(1, 1, 1))
    capsule = plant.AddRigidBody("capsule", inertia)
    slide = plant.AddJoint(
        PrismaticJoint("slide", plant.world_frame(), capsule.body_frame(), np.array([0.0, 0, 1]))
    )
    c0 = np.asarray(contact["motion"]["c"][0], dtype=np.float64)
    where = RigidTransform(c0 + [0.0, 0.0, SHAFT / 2.0])  # Drake's capsule: centred, along z
    plant.RegisterCollisionGeometry(capsule, where, Capsule(radius, SHAFT), "capsule", rigid)
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(data.gravity, dtype=float))
    plant.Finalize()
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyContextFromRoot(context)
    simulator = Simulator(diagram, context)
    simulator.Initialize()
    return simulator, plant, plant_context, model, body, slide


def integrate(data: Exported, variant: str, workdir: Path, steps: int | None = None) -> dict:
    """Pose and step the export: {"U" (steps + 1, N, 3) m and "force" (steps + 1, 3) N on the
    capsule, NaN from a divergence on; "tets"; "diverged" (step or None); "reason";
    "wall_time_s" (s, from building the plant to the last step)}."""
    steps = data.steps if steps is None else steps
    nodes = np.asarray(data.nodes, dtype=np.float64)
    tets, mesh = tetrahedra(data)
    mesh_file = Path(workdir) / MESH_FILE
    write_vtk(mesh_file, nodes, tets)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    start = time.perf_counter()
    simulator, plant, context, model, body, slide = build(data, variant, mesh_file)
    rest = model.GetPositions(context, body).T.copy()
    if not np.allclose(rest, nodes, rtol=0.0, atol=1e-12):
        raise RuntimeError("Drake's reference positions are not the export's nodes")
    U = np.full((steps + 1, len(nodes), 3), np.nan)
    F = np.full((steps + 1, 3), np.nan)
    U[0], F[0] = 0.0, 0.0
    diverged, reason = None, None
    for i in range(1, steps + 1):
        slide.set_translation(context, centres[i - 1, 2] - centres[0, 2])
        slide.set_translation_rate(context, (centres[i, 2] - centres[i - 1, 2]) / data.h)
        try:
            simulator.AdvanceTo(i * data.h)
        except Exception as err:  # Drake's solver failing: a divergence
            first = (str(err).strip().splitlines() or [""])[0]
            diverged, reason = i, f"Drake raised {type(err).__name__}: {first}"[:300]
            break
        if abs(slide.get_translation(context) - (centres[i, 2] - centres[0, 2])) > 1e-7:
            raise RuntimeError(f"the capsule is not at c(t_{i})")
        u = model.GetPositions(context, body).T - rest
        if not np.all(np.isfinite(u)):
            diverged, reason = i, "a displacement is not finite"
        elif np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
            diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
        elif data.model != "linear":
            J = tet_volumes(nodes + u, tets) / volumes
            if J.min() <= 0:
                diverged, reason = i, f"{int(np.sum(J <= 0))} tetrahedra inverted"
        if diverged is not None:
            break
        results = plant.get_contact_results_output_port().Eval(context)
        on_tissue = np.zeros(3)
        for k in range(results.num_deformable_contacts()):
            on_tissue += results.deformable_contact_info(k).F_Ac_W().translational()
        U[i], F[i] = u, -on_tissue
    return {
        "U": U,
        "force": F,
        "tets": tets,
        "mesh": mesh,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": time.perf_counter() - start,
    }


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in workdir: drake.xdmf (the displacement, m, at every t_i on
    the export's nodes, on Drake's tetrahedra, NaN from a divergence on) and drake_force.csv
    (the force the tissue exerts on the capsule, N: x, y, z, up to the last good step)."""
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series

    version = installed_version("drake")
    workdir = Path(workdir)
    dofs = 3 * len(data.nodes)
    mesh = MESH if data.cell_type == "hexahedron" else "reference"
    offered = variants(data)
    if variant not in offered:
        why = f"Drake variant {variant!r} does not pose this export (posed: "
        why += f"{', '.join(offered) or 'none'})"
        return ExternalRun(None, None, dofs, mesh=mesh, status="failed", reason=why)
    try:
        result = integrate(data, variant, workdir)
    except Exception as err:  # Drake refusing the model: a failed run, not a crash
        first = (str(err).strip().splitlines() or [""])[0]
        return ExternalRun(
            None, None, dofs, mesh=mesh, status="failed",
            reason=f"Drake raised {type(err).__name__}: {first}"[:300], version=version,
        )  # fmt: skip
    path = workdir / SERIES
    nodes = np.asarray(data.nodes, dtype=np.float64)
    write_series(path, ((nodes, result["tets"], "tetrahedron"), {FIELD: result["U"]}), data.times)
    kept = np.all(np.isfinite(result["force"]), axis=1)
    force = workdir / FORCE
    write_force_csv(force, data.times[kept], result["force"][kept])
    timing = (
        f"time.perf_counter from building the plant (the .vtk read, the FEM model) to the last "
        f"of {data.steps} steps (contact results included), one thread; writing the .vtk excluded"
    )
    done = integrated(
        path, result["wall_time_s"], dofs, FIELD, result["mesh"], result["diverged"],
        result["reason"],
        data.h, timing, version,
    )  # fmt: skip
    return dataclasses.replace(done, force=force)
