"""Newton (newton-physics on Warp, CPU) on the needle in 3D (SPEC 13): the exported tissue
cylinder as a VBD soft mesh, pushed into the centre of its top face by the capsule as a
kinematic rigid body that follows c(t), with Newton's own soft-rigid contact.

The posed problem
-----------------
- Mesh: the export's nodes (the same nodes: nodal displacements compare one to one). Its
  hexahedra are split into six tetrahedra each, coned from the hexahedron's lowest-numbered
  corner V over the three faces away from V, each face cut along the diagonal through its own
  lowest-numbered corner (Dompierre et al. 1999's rule: both cells beside a face cut it alike,
  so the split conforms on any mesh of convex hexahedra; `newton.split_hexahedra`'s octant
  rule does not conform on the O-grid, whose outer blocks are turned); exported tetrahedra
  are taken as they are. Each tetrahedron is oriented to a positive volume.
- Elasticity: `add_soft_mesh` with VBD's stable neo-Hookean (Smith et al. 2018) in place of the
  export's model, its Lame parameters the export's: k_mu = mu = E / (2 (1 + nu)), k_lambda =
  lambda = E nu / ((1 + nu)(1 - 2 nu)) (Pa; `newton.tet_parameters`).
- Mass: Newton's lumping, rho V_t / 4 to each corner. The bottom z = 0 (the export's fixed
  set): particles of mass 0, kinematic, which no solver moves. No gravity.
- Rayleigh damping C = alpha M + beta K_0: alpha M as the force -alpha m v on every particle
  before each substep (explicit in the substep, as the rod's); beta K_0 as VBD's k_damp =
  beta mu / 2 (Pa s), which matches beta K_0's shear viscosity 2 beta mu eps_dot; dropped:
  the volumetric part, VBD's bulk viscosity being (2/3) beta mu where beta K_0's is beta
  (lambda + 2 mu / 3), 1/25 of it at nu = 0.47 (MP1).
- The capsule: a kinematic body (`add_body(is_kinematic=True)`) holding Newton's capsule shape
  of radius R along z, the centre of its lower hemisphere at the body's origin and its shaft
  SHAFT m long (a half-infinite cylinder for this body: the tissue stays below c_z + 0.2 m).
  Its pose is set to c(t) at every substep (linear between the export's `motion.c` at the t_i)
  and its velocity to the capsule's; frictionless: mu = 0 on the shape and the model.
- Contact, Newton's particle-shape penalty (VBD's fixed-k default: the force on a particle is
  ke times its depth inside the capsule, the particle's radius 1e-4 m; no damping, kd = 0),
  found by the collision pipeline before every substep (search gap 0.01 m). Our penalty k =
  kappa E / h_e (Pa/m) over a node's share h_e^2 of the top face gives ke = kappa E h_e (N/m),
  with the export's kappa and h_e; a variant's factor multiplies it (a stiff setting is its own
  variant). Vertex contact (`vbd-vertex*`) sees only the particles: the capsule can sink
  between two nodes of the top face. Full-surface contact (`vbd-surface`, Newton's
  `enable_rigid_soft_full_surface_contact`) adds the surface triangles' edges and interiors
  against the capsule's analytic distance, with the same ke per contact record.
- Time: SolverVBD (implicit Euler, vertex block descent, a fixed iteration count per substep)
  at h / substeps; the output is the state at every t_i = i h.
- The force: the tissue's force on the capsule (N), Newton's own report: the CONTACT_F
  observable of SolverVBD (`solver.observables`), one wrench per soft contact record, the force
  on the capsule's body (the reaction to the particle's), evaluated at the end of each step's
  last substep and summed over the records; written by io/tables.py `write_force_csv` (x, y
  and z: the sideways x and y are a symmetry error, 0 for the axisymmetric answer).
- Divergence as the rod's: a displacement not finite or beyond 100 x the extent, or an
  inverted tetrahedron, checked at every t_i; NaN from there on, status "failed".

Measured (cylinder MP1, n = 3 hexahedral O-grid, 287 nodes, 1,152 tetrahedra, h = 1/30 s,
to T = 2.5 s, kappa = 10, ke = 333 N/m; Newton 1.8.0, Warp 1.19.0 on 2 shared CPU cores),
against our `implicit` on the same export (Q1 hexahedra, penalty k = 18,003 Pa/m): F_z and
the sideways |(F_x, F_y)| on the capsule (N) at t = 2 s and 2.5 s, its largest over the steps,
the interpenetration (compare's, the largest -g_n over the top face's deformed facets, m), E_n
time mean, and the wall time of the 75 steps (kernels cached; compiling them cold: 200-220 s
per variant):

    variant           F_z 2 s  F_z 2.5 s  |F_xy| 2 s  max |F_xy|  interpen.  E_n   wall
    ours (implicit)   4.90     4.87       3e-12       3e-12       0.045      -     15.8 s
    vbd-vertex        4.02     1.36       4.86        5.38        0.094      0.78  47-61 s
    vbd-vertex-stiff  5.62     3.02       5.38        11.0        0.082      7.6   59 s
    vbd-surface       17.7     13.9       1.08        1.26        0.013      3.5   44 s

F_z at 2 s against ours: 0.82, 1.15 and 3.61. Vertex contact is not axisymmetric: the top
centre node, alone on the ball's apex, slides off it along x = y (u_x = u_y = -0.044 m at
t = 2 s, u_z -0.112 m against our -0.136 m), the capsule sinks between the nodes (0.094 m of
R = 0.1 m by T) and F_z falls once the tool stops; the stiff penalty overshoots at first
contact (F_z 12.2 N at t = 0.2 s: force error 2.2). Full-surface contact holds the faceted
face off the ball (the centre node 0.02 m below the ball's bottom, every node outside it) and
is symmetric to 1 N, but pushes a wider patch: the linear P1 nodal forces of its top face
at t = 2 s are 11.3 N against 3.9 N for our displacement on the same tetrahedra; the rest of
its 3.6 x is not traced (neo-Hookean, VBD's unconverged iterations, the P1 tetrahedra's
stiffness at nu = 0.47).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators.contact.mujoco import tool
from tissuebench.workflows.simulators.contact.newton import FIELD, GAP, MODELS, SERIES
from tissuebench.workflows.simulators.newton import (
    DIVERGED,
    _builder,
    _import_newton,
    cone_split,
    conforming,
    tet_parameters,
    tet_volumes,
)

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

FORCE = "newton_force.csv"
SHAFT = 1.0  # m: the capsule's shaft above its ball (2 x Newton's half_height)
MESH = (
    "tetrahedra, 6 per hexahedron (coned from its lowest-numbered corner), on the reference's nodes"
)

# name -> (substeps per h, VBD iterations, full-surface contact, factor on ke, one line)
VARIANTS = {
    "vbd-vertex": (
        10,
        10,
        False,
        1.0,
        "contact: SolverVBD (implicit Euler, 10 iterations) at h/10; the capsule a kinematic "
        "body on c(t), frictionless vertex contact (the particles against the capsule), fixed "
        "penalty ke = kappa E h_e per particle (ours over a node's share h_e^2 of the face)",
    ),
    "vbd-vertex-stiff": (
        10,
        10,
        False,
        100.0,
        "contact: SolverVBD (implicit Euler, 10 iterations) at h/10; the capsule a kinematic "
        "body on c(t), frictionless vertex contact, a stiff fixed penalty ke = 100 kappa E h_e "
        "per particle",
    ),
    "vbd-surface": (
        10,
        10,
        True,
        1.0,
        "contact: SolverVBD (implicit Euler, 10 iterations) at h/10; the capsule a kinematic "
        "body on c(t), frictionless full-surface contact (vertices, edges and triangle "
        "interiors of the surface against the capsule's analytic distance), fixed penalty "
        "ke = kappa E h_e per contact record",
    ),
}


def posed(data: Exported) -> str | None:
    """None when this module poses the export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    if tool(data).get("shape", {}).get("kind") != "capsule":
        return "the tool is not SPEC 13's capsule"
    if data.procedure != "dynamic":
        return "Newton integrates in time only; the static procedure has no counterpart"
    if data.dim != 3 or data.cell_type not in ("hexahedron", "tetrahedron"):
        return "posed on 3D hexahedra or tetrahedra only"
    if data.model not in MODELS:
        return f"no Newton counterpart of the {data.model} model"
    if any(np.any(np.abs(np.asarray(x)) > 0) for m in data.motions.values() for x in m):
        return "a moving constrained set has no counterpart in Newton's kinematic particles"
    return None


def variants(data: Exported) -> dict[str, str]:
    """The contact variants, name -> one line (law, contact model and its parameters, how the
    export's E and nu become Newton's); empty where skipped() says why."""
    if posed(data) is not None:
        return {}
    k_mu, k_lambda, k_damp = tet_parameters(data.material, "vbd")
    return {
        name: f"{spec[4]} = {stiffness(data, name):.4g} N/m; {MODELS[data.model]}; "
        f"k_mu = mu = {k_mu:.5g} Pa, k_lambda = lambda = {k_lambda:.5g} Pa, k_damp = beta mu/2 "
        f"= {k_damp:.5g} Pa s of the export's {given(data.material)}"
        for name, spec in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """What no variant poses, one line each ({} when every variant poses the export)."""
    why = posed(data)
    return {} if why is None else {"all": why}


def stiffness(data: Exported, variant: str) -> float:
    """The particle-shape penalty ke (N/m) of variant: its factor x kappa E h_e, our penalty
    k = kappa E / h_e (Pa/m) over a node's share h_e^2 of the top face."""
    penalty = tool(data).get("penalty", {})
    kappa = float(penalty.get("kappa", 10.0))
    h_e = float(penalty.get("h_e", 0.5 / data.mesh_size))
    return VARIANTS[variant][3] * kappa * data.material.E * h_e


# --- posing -----------------------------------------------------------------------------------


def tetrahedra(data: Exported) -> np.ndarray:
    """Positively oriented tetrahedra (T, 4) on the export's nodes: each hexahedron (VTK order)
    coned from its lowest-numbered corner V over the three faces away from V, each cut along
    the diagonal through its own lowest-numbered corner, so that both cells beside a face cut
    it alike (module docstring); the exported tetrahedra as they are."""
    nodes = np.asarray(data.nodes, dtype=np.float64)
    cells = np.asarray(data.cells, dtype=np.int64)
    if data.cell_type == "hexahedron":
        return cone_split(nodes, cells)
    tets = cells.copy()
    negative = tet_volumes(nodes, tets) < 0
    tets[negative] = tets[negative][:, [0, 1, 3, 2]]
    return tets


def _model(data: Exported, variant: str, tets: np.ndarray):
    """(finalised Model on the CPU, the capsule's body index): the soft mesh and its fixed
    bottom as the rod's (`newton._builder`), the capsule at c(t_0)."""
    wp, newton = _import_newton()
    builder = _builder(data, "vbd", tets)
    ke = stiffness(data, variant)
    cfg = newton.ModelBuilder.ShapeConfig(mu=0.0, ke=ke, kd=0.0)
    c0 = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)[0]
    where = wp.transform(wp.vec3(*c0), wp.quat_identity())
    body = builder.add_body(xform=where, is_kinematic=True, label="capsule")
    radius = float(tool(data)["shape"]["radius"])
    shaft = wp.transform(wp.vec3(0.0, 0.0, SHAFT / 2), wp.quat_identity())
    builder.add_shape_capsule(body, xform=shaft, radius=radius, half_height=SHAFT / 2, cfg=cfg)
    builder.color()
    model = builder.finalize(device="cpu")
    model.soft_contact_ke, model.soft_contact_kd, model.soft_contact_mu = ke, 0.0, 0.0
    return model, body


def _broken(u: np.ndarray, nodes: np.ndarray, tets: np.ndarray, volumes: np.ndarray) -> str | None:
    """Why the displacement u (N, 3) m has diverged (SPEC sections 3 and 8), None if not."""
    if not np.all(np.isfinite(u)):
        return "a displacement is not finite"
    extent = float(np.max(np.ptp(nodes, axis=0)))
    if np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
        return f"a displacement exceeds {DIVERGED:g} x the domain's extent"
    J = tet_volumes(nodes + u, tets) / volumes
    if J.min() <= 0:
        return f"{int(np.sum(J <= 0))} tetrahedra inverted (J down to {J.min():.3g})"
    return None


def integrate(data: Exported, variant: str, steps: int | None = None) -> dict:
    """Pose and step the export: {"U" (steps + 1, N, 3) m, "force" (steps + 1, 3) N on the
    capsule (0 at t = 0), both NaN from a divergence on; "tets"; "diverged" (step or None);
    "reason"; "wall_time_s" (finalisation to the last step; Warp's kernels compiled or loaded
    by a first step of h, not counted); "compile_s"}."""
    wp, newton = _import_newton()
    steps = data.steps if steps is None else steps
    substeps, iterations, surface, _, _ = VARIANTS[variant]
    tets = tetrahedra(data)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    alpha, dt = data.material.alpha, data.h / substeps

    def stepped(count: int) -> tuple[np.ndarray, np.ndarray, int | None, str | None]:
        model, body = _model(data, variant, tets)
        solver = newton.solvers.SolverVBD(model, iterations=iterations)
        pipeline = newton.CollisionPipeline(
            model, soft_contact_gap=GAP, enable_rigid_soft_full_surface_contact=surface
        )
        contacts = pipeline.contacts()
        kind = solver.ObservableKind.CONTACT_F
        observed = solver.observables({kind}, contacts=contacts)
        states, control = (model.state(), model.state()), model.control()
        mass = model.particle_mass.numpy().astype(np.float64)[:, None]
        rest = model.particle_q.numpy().astype(np.float64)
        U = np.full((count + 1, len(rest), 3), np.nan)
        F = np.full((count + 1, 3), np.nan)
        U[0], F[0] = 0.0, 0.0
        for i in range(1, count + 1):
            velocity = (centres[i] - centres[i - 1]) / data.h
            for j in range(1, substeps + 1):
                c = centres[i - 1] + (centres[i] - centres[i - 1]) * (j / substeps)
                for state in states:
                    q, qd = state.body_q.numpy(), state.body_qd.numpy()
                    q[body] = [*c, 0.0, 0.0, 0.0, 1.0]
                    qd[body] = [*velocity, 0.0, 0.0, 0.0]
                    state.body_q.assign(q)
                    state.body_qd.assign(qd)
                state_in, state_out = states
                state_in.clear_forces()
                force = state_in.particle_f.numpy()  # a view of Warp's CPU array
                force[:] = -alpha * mass * state_in.particle_qd.numpy()
                pipeline.collide(state_in, contacts)
                last = observed if j == substeps else None
                solver.step(state_in, state_out, control, contacts, dt, observables=last)
                states = state_out, state_in
            u = states[0].particle_q.numpy().astype(np.float64) - rest
            why = _broken(u, nodes, tets, volumes)
            if why is not None:
                return U, F, i, why
            U[i] = u
            count_soft = int(contacts.soft_contact_count.numpy()[0])
            wrench = observed.contact_f.numpy()[contacts.rigid_contact_max :][:count_soft]
            F[i] = wrench[:, :3].astype(np.float64).sum(axis=0)
        return U, F, None, None

    start = time.perf_counter()
    stepped(1)  # Warp compiles (or loads) its kernels
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    U, F, diverged, reason = stepped(steps)
    return {
        "U": U,
        "force": F,
        "tets": tets,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": time.perf_counter() - start,
        "compile_s": compile_s,
    }


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in workdir: newton.xdmf, the displacement (m) at every t_i on
    the export's nodes and the posed tetrahedra, NaN from a divergence on, and newton_force.csv,
    the force (N) the tissue exerts on the capsule at every t_i up to the last good step
    (io/tables.py)."""
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series

    version = installed_version("newton")
    workdir = Path(workdir)
    dofs = 3 * len(data.nodes)

    def failed(reason: str) -> ExternalRun:
        return ExternalRun(
            None, None, dofs, mesh=MESH, status="failed", reason=reason, version=version
        )

    if variant not in variants(data):
        return failed(f"Newton variant {variant!r} does not pose this export: {posed(data)}")
    if data.cell_type == "hexahedron" and not conforming(tetrahedra(data), data.cells):
        return failed("the split of these hexahedra into tetrahedra does not conform")
    try:
        result = integrate(data, variant)
    except Exception as err:  # Newton or Warp refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return failed(f"Newton raised {type(err).__name__}: {first}")
    path = workdir / SERIES
    points = np.asarray(data.nodes, dtype=np.float64)
    write_series(path, ((points, result["tets"], "tetrahedron"), {FIELD: result["U"]}), data.times)
    kept = np.all(np.isfinite(result["force"]), axis=1)
    force = workdir / FORCE
    write_force_csv(force, data.times[kept], result["force"][kept])
    substeps = VARIANTS[variant][0]
    timing = (
        f"time.perf_counter from Newton's model finalisation to the last of {data.steps} steps "
        f"x {substeps} substeps (collision, VBD step, the force observable on each step's last "
        f"substep), Warp on the CPU, float32; kernel compilation (or cache load) excluded: "
        f"{result['compile_s']:.1f} s"
    )
    out = integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h, timing, version,
    )  # fmt: skip
    out.force = force
    return out
