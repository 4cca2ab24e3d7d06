"""Newton (newton-physics on Warp, CPU) on the contact benchmark (SPEC 12): the plane-strain
block as a one-element slab of VBD tetrahedra, pushed by the needle as a kinematic rigid body
(a cylinder and a box) that follows c(t), with Newton's particle-shape contact.

The posed problem
-----------------
- Mesh: the slab of `contact/mujoco.py`'s `slab` (the quadrilaterals extruded by t_z = 1/N m, six
  tetrahedra per hexahedron; export node i is slab node i at z = 0 and N + i at z = t_z),
  `add_soft_mesh` with VBD's stable neo-Hookean (the rod's Lame constants and k_damp =
  beta mu / 2, module `newton`), Newton's lumped mass, the fixed edges' particles of mass 0
  (kinematic).
- Plane strain: a Newton particle is kinematic in all components or free (no per-component
  constraint), so after every substep each particle's z is set back to its rest value and its
  z velocity to zero: a projection, not a constraint the solver sees within its iterations.
- alpha M: the force -alpha m v on every particle before each substep (the rod's).
- The needle: a kinematic body (`add_body(is_kinematic=True)`) with a cylinder of radius R
  along z (the disc) and a box from c_x to c_x + 1 m of half-height R (the strip), its pose
  set to c(t) at every substep (linear between the t_i) and its velocity to the needle's;
  frictionless (mu = 0 on the shapes and the model). Contact is Newton's particle-shape
  contact: a particle (radius 1e-4 m) against the shapes, found by the collision pipeline at
  every substep (gap 0.01 m); the tissue's surface between two particles is not seen, so the
  needle can pass between them (the interpenetration says by how much). Penalty: the model's
  and the shapes' ke = kappa E t_z / 2 (N/m; our penalty k = kappa E / h_e over a surface
  particle's share h_e t_z / 2 of the edge, kappa the export's), kd = 0; VBD raises each
  contact's penalty from there within a step (its augmented stiffness, rigid_vbd_kernels).
- Scheme: `vbd-10`, SolverVBD (implicit Euler, block descent) at h / 10 with 10 iterations.
- Output: the displacement at every t_i on the export's nodes and quadrilaterals (the mean of
  the slab's two layers). No needle force: Newton reports no contact force, and VBD's adapted
  per-contact penalty cannot be rebuilt from the positions (ExternalRun.force is None).
- Divergence as the rod's: a displacement not finite or beyond 100 x the extent, or an
  inverted tetrahedron; NaN from there on, status "failed".

Measured (contact-MP1, Newton 1.8.0, Warp 1.19.0, 2 shared cores), against our implicit on
the same grid (kappa = 10): N = 8 for 1 s, nodal relative error 0.44, 0.35 and 0.38 at
t = 1/3, 2/3 and 1 s; the node at (1, 0.5), alone on the disc's apex, slides off it sideways
(u_y = -0.022 m at t = 1 s, 0 in ours by symmetry: frictionless vertex contact on a curved
tool), its u_x -0.066 m against our -0.070; interpenetration 0.029 m (ours 0.017 m); 4.8 s
for the 30 steps (Warp's kernels cached; compiling them cold takes 13-45 s).
N = 20 for 10 s: E_n time mean 0.23 (max 0.82, at the first steps), E_i max 4.7e-3 m^2,
interpenetration 2.0e-2 m (ours 1.3e-2 m), 148 s wall time (our implicit 3.7 s).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators.contact.mujoco import (
    MESH,
    fixed_nodes,
    planar,
    slab,
    slab_problem,
    tool,
)
from tissuebench.workflows.simulators.newton import (
    DIVERGED,
    PARTICLE_RADIUS,
    _import_newton,
    tet_parameters,
    tet_volumes,
)

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

SERIES = "newton.xdmf"
FIELD = "displacement"
STRIP = 1.0  # m: the needle's strip, from c_x to c_x + STRIP
GAP = 0.01  # m: the collision pipeline's soft-contact search gap

# name -> (substeps per h, VBD iterations, one line)
VARIANTS = {
    "vbd-10": (
        10,
        10,
        "contact: SolverVBD (implicit Euler, 10 iterations) at h/10; a one-element slab of "
        "stable neo-Hookean tetrahedra, u_z projected to 0 after each substep (plane strain), "
        "alpha M as a force; the needle a kinematic cylinder + box on c(t), frictionless "
        "particle-shape contact, ke = kappa E t_z / 2 per particle (VBD raises it per contact)",
    ),
}

MODELS = {
    "linear": "stable neo-Hookean in place of linear elasticity",
    "neo-hookean": "stable neo-Hookean (Smith et al.) in place of the SPEC's",
    "neo-hookean-barrier": "stable neo-Hookean (Smith et al.) in place of the SPEC's",
}


def posed(data: Exported) -> str | None:
    """None when this module poses the contact export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    if data.procedure != "dynamic":
        return "Newton integrates in time only; the static procedure has no counterpart"
    if data.model not in MODELS:
        return f"no Newton counterpart of the {data.model} model"
    return slab_problem(data, "a moving constrained set has no counterpart here")


def variants(data: Exported) -> dict[str, str]:
    """The contact variants, name -> one line; empty where skipped() says why."""
    if posed(data) is not None:
        return {}
    return {
        name: f"{line}; {MODELS[data.model]}; k_mu = mu, k_lambda = lambda: the export's "
        f"{given(data.material)}"
        for name, (_, _, line) in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """Why no contact variant poses this export ({} when one does)."""
    why = posed(data)
    return {} if why is None else {"all": why}


def stiffness(data: Exported) -> float:
    """The particle-shape penalty ke (N/m): kappa E t_z / 2, our penalty over a surface
    particle's share of the edge."""
    kappa = float(tool(data).get("penalty", {}).get("kappa", 10.0))
    return kappa * data.material.E / data.mesh_size / 2.0


def _model(data: Exported, nodes: np.ndarray, tets: np.ndarray, thickness: float):
    """(finalised Model, the needle's body index)."""
    wp, newton = _import_newton()
    m = data.material
    builder = newton.ModelBuilder(up_axis="y", gravity=(0.0, 0.0, 0.0))
    k_mu, k_lambda, k_damp = tet_parameters(m, "vbd")
    builder.add_soft_mesh(
        pos=wp.vec3(0.0, 0.0, 0.0),
        rot=wp.quat_identity(),
        scale=1.0,
        vel=wp.vec3(0.0, 0.0, 0.0),
        vertices=nodes.tolist(),
        indices=tets.ravel().tolist(),
        density=m.rho,
        k_mu=k_mu,
        k_lambda=k_lambda,
        k_damp=k_damp,
        particle_radius=PARTICLE_RADIUS,
    )
    held = fixed_nodes(data)
    for i in np.r_[held, held + len(data.nodes)]:
        builder.particle_mass[int(i)] = 0.0
    ke = stiffness(data)
    cfg = newton.ModelBuilder.ShapeConfig(mu=0.0, ke=ke, kd=0.0)
    c0 = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)[0]
    radius = float(tool(data)["shape"]["radius"])
    where = wp.transform(wp.vec3(c0[0], c0[1], thickness / 2), wp.quat_identity())
    body = builder.add_body(xform=where, is_kinematic=True, label="needle")
    builder.add_shape_cylinder(body, radius=radius, half_height=thickness, cfg=cfg)
    strip = wp.transform(wp.vec3(STRIP / 2, 0.0, 0.0), wp.quat_identity())
    builder.add_shape_box(body, xform=strip, hx=STRIP / 2, hy=radius, hz=thickness, cfg=cfg)
    builder.color()
    model = builder.finalize(device="cpu")
    model.soft_contact_ke, model.soft_contact_kd, model.soft_contact_mu = ke, 0.0, 0.0
    return model, body


def integrate(data: Exported, variant: str, steps: int | None = None) -> dict:
    """Pose and step the contact export: {"U" (steps + 1, 2N, 2) m per slab node, NaN from a
    divergence on; "diverged"; "reason"; "wall_time_s" (finalisation to the last step, Warp's
    kernels compiled or loaded by a first step of h not counted); "compile_s"}."""
    wp, newton = _import_newton()
    steps = data.steps if steps is None else steps
    substeps, iterations, _ = VARIANTS[variant]
    nodes, tets, thickness = slab(data)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    alpha, dt = data.material.alpha, data.h / substeps

    def stepped(count: int) -> tuple[np.ndarray, int | None, str | None]:
        model, body = _model(data, nodes, tets, thickness)
        solver = newton.solvers.SolverVBD(model, iterations=iterations)
        pipeline = newton.CollisionPipeline(model, soft_contact_gap=GAP)
        states, control, contacts = (model.state(), model.state()), model.control(), None
        contacts = pipeline.contacts()
        newton.eval_fk(model, model.joint_q, model.joint_qd, states[0])
        mass = model.particle_mass.numpy().astype(np.float64)[:, None]
        rest = model.particle_q.numpy().astype(np.float64)
        U = np.full((count + 1, len(rest), 2), np.nan)
        U[0] = 0.0
        for i in range(1, count + 1):
            velocity = (centres[i] - centres[i - 1]) / data.h
            for j in range(1, substeps + 1):
                c = centres[i - 1] + (centres[i] - centres[i - 1]) * (j / substeps)
                state_in, state_out = states
                for state in states:
                    q, qd = state.body_q.numpy(), state.body_qd.numpy()
                    q[body, :3] = [c[0], c[1], thickness / 2]
                    qd[body] = 0.0
                    qd[body, :2] = velocity
                    state.body_q.assign(q)
                    state.body_qd.assign(qd)
                force = state_in.particle_f.numpy()  # a view of Warp's CPU array
                force[:] = -alpha * mass * state_in.particle_qd.numpy()
                pipeline.collide(state_in, contacts)
                solver.step(state_in, state_out, control, contacts, dt)
                x, v = state_out.particle_q.numpy(), state_out.particle_qd.numpy()
                x[:, 2], v[:, 2] = rest[:, 2], 0.0  # plane strain: u_z = 0, projected
                state_out.particle_q.assign(x)
                state_out.particle_qd.assign(v)
                states = state_out, state_in
            u = states[0].particle_q.numpy()[:, :2].astype(np.float64) - rest[:, :2]
            if not np.all(np.isfinite(u)):
                return U, i, "a displacement is not finite"
            if np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
                return U, i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
            J = tet_volumes(np.c_[nodes[:, :2] + u, nodes[:, 2]], tets) / volumes
            if J.min() <= 0:
                return U, i, f"{int(np.sum(J <= 0))} tetrahedra inverted (J down to {J.min():.3g})"
            U[i] = u
        return U, None, None

    start = time.perf_counter()
    stepped(1)  # Warp compiles (or loads) its kernels
    compile_s = time.perf_counter() - start
    start = time.perf_counter()
    U, diverged, reason = stepped(steps)
    return {
        "U": U,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": time.perf_counter() - start,
        "compile_s": compile_s,
    }


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one contact variant serially in workdir: newton.xdmf, the displacement (m) at
    every t_i on the export's quadrilaterals, NaN from a divergence on; no force file."""
    version = installed_version("newton")
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    dofs = 2 * 2 * len(data.nodes)
    try:
        result = integrate(data, variant)
    except Exception as err:  # Newton or Warp refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return ExternalRun(
            None, None, dofs, mesh=MESH, status="failed",
            reason=f"Newton raised {type(err).__name__}: {first}", version=version,
        )  # fmt: skip
    path = workdir / SERIES
    points = np.c_[np.asarray(data.nodes, dtype=np.float64), np.zeros(len(data.nodes))]
    cells = np.asarray(data.cells, dtype=np.int64)
    write_series(path, ((points, cells, "quadrilateral"), {FIELD: planar(result["U"])}), data.times)
    substeps = VARIANTS[variant][0]
    timing = (
        f"time.perf_counter from Newton's model finalisation to the last of {data.steps} steps "
        f"x {substeps} substeps (collision, VBD step, the z projection), Warp on the CPU, "
        f"float32; kernel compilation (or cache load) excluded: {result['compile_s']:.1f} s"
    )
    return integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h, timing, version,
    )  # fmt: skip
