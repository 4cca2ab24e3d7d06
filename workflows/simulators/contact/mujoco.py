"""MuJoCo on the contact benchmark (SPEC 12): the plane-strain block as a one-element slab of
a volumetric flex, pushed by the rigid half-stadium needle as a mocap body that follows c(t).

The posed problem
-----------------
- Mesh: the exported quadrilaterals extruded one element thick (t_z = 1/N m, the grid's own
  size, so the hexahedra are cubes), each hexahedron split into six tetrahedra as the rod's
  (`newton.split_hexahedra`, conforming). Node i of the export is the slab's node i (z = 0)
  and node N + i (z = t_z).
- Plane strain: every free node is a body with two slide joints (x, y) and no z joint, so
  u_z = 0 everywhere; a raw `<flex dim="3">` over these bodies with `<elasticity young=E
  poisson=nu damping=beta>` (MuJoCo's piecewise linear St Venant-Kirchhoff, the rod's). The
  nodes of the fixed edges (left, bottom, top) are bodies without joints. Mass: the row-sum
  lumped P1 mass per body (rho V / 4 from each tetrahedron), alpha damping alpha m_i on each
  slide joint (set after compiling, as the rod's: MuJoCo refuses joint damping in the MJCF
  of a flex vertex).
- The needle: a mocap body carrying a cylinder of radius R (axis z, longer than the slab is
  thick: the disc) and a box from c_x to c_x + 1 m of half-height R (the strip), placed at
  c(t) and moved linearly in c between the t_i at every substep. MuJoCo collides each
  tetrahedron of the flex with these geoms (the element's convex hull, radius 0).
- Contact: frictionless (`condim="1"`), MuJoCo's soft constraint with its default solref
  (time constant 0.02 s, damping ratio 1) and solimp (0.9, 0.95, 0.001): its own compliance,
  not a penalty k. A stiffer time constant (2 x the substep, 0.0067 s) made the force spike
  to 1e5 N/m at N = 8 (measured), so the default is kept.
- Integrator: `euler-10`, MuJoCo's `Euler` (symplectic: elasticity, flex damping and
  contact forces explicit, the joints' alpha damping implicit) at h / 10. The rod's
  `discrete` integrator is not offered here: with contact it holds the tissue still at
  N >= 16 while reporting contact forces of 1e4-1e5 N/m, and lets the needle pass through
  (interpenetration 0.1 m = R at N = 20; measured at N = 12 it still worked, 17.5 N/m at
  t = 1 s against our 24.4).
- Output: the displacement at every t_i on the export's nodes and quadrilaterals, the mean
  of the slab's two layers (they differ by the split's asymmetry, up to 6e-3 m in y at
  N = 8); the needle force per unit thickness F = -(the sum of the contact forces on the
  tissue's joints, qfrc_constraint, the contact being the model's only constraint) / t_z
  (N/m, +x when the needle pushes the tissue in -x), averaged over the step's substeps.
- Divergence as the rod's (SPEC 3, 8): a displacement not finite or beyond 100 x the extent,
  an inverted tetrahedron (J <= 0), or MuJoCo's bad-acceleration warning: NaN from there
  on, the force written up to the last good step, status "failed".

Measured (contact-MP1, MuJoCo 4.0.0, 2 shared cores): St Venant-Kirchhoff softens in
compression and a tetrahedron at the needle's tip inverts before the needle stops: at
t = 1.9 s (step 57) on N = 8 and t = 1.2 s (step 36) on N = 20. Our own Q1 `implicit+svk`
inverts too (step 50 on N = 20): the model's, not MuJoCo's. Up to there, against our `implicit`
on the same grid (Q1, linear, penalty kappa = 10, the case; kappa = 100 in brackets):

    N = 8:  E_n time mean 0.36 [0.36], E_i max 5.1e-3 m^2; F_x(1 s) 23.2 N/m [ours 30.3]
    N = 20: E_n time mean 0.37 [0.32], E_i max 1.6e-3 [2.2e-3] m^2; F_x(1.17 s) 11.8 N/m
            [ours 24.2]; wall 1.7 s to the inversion at 1.2 s (all 10 s unchecked: 7.8 s)

MuJoCo's force is half to three quarters of ours and its F_y is not zero (-2 to -4 N/m: the
split's asymmetry); its interpenetration stays at 3e-3 m (ours 1.3e-2 m at kappa = 10, 2.7e-3
at kappa = 100, N = 20). See the module `mujoco` for the flex's other departures (SVK for
linear, lumped mass, first-order scheme).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators.newton import (
    conforming,
    lumped_masses,
    split_hexahedra,
    tet_volumes,
)

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

SERIES = "mujoco.xdmf"
FORCE = "mujoco_force.csv"
FIELD = "displacement"
DIVERGED = 100.0  # SPEC section 3: a nodal displacement beyond 100 x the largest extent
STRIP = 1.0  # m: the needle's strip, from c_x to c_x + STRIP (the block is 1 m wide)
SOLREF = (0.02, 1.0)  # MuJoCo's default contact time constant (s) and damping ratio
SOLIMP = (0.9, 0.95, 0.001)  # MuJoCo's default impedance (d0, dwidth, width in m)
SAMPLES = 9  # interpenetration: points per deformed surface edge, as ours samples
MESH = "a one-element slab of tetrahedra (6 per extruded quadrilateral), its two layers averaged"

# name -> (MuJoCo integrator, substeps per h, one line of what the variant is)
VARIANTS = {
    "euler-10": (
        "Euler",
        10,
        "contact: integrator Euler (symplectic: elasticity, beta damping and contact explicit, "
        "alpha damping implicit), 10 substeps of h/10; a one-element slab of St Venant-Kirchhoff "
        "P1 tetrahedra with u_z = 0 (plane strain), row-sum lumped mass, C = alpha M_L + beta K; "
        "the needle a mocap cylinder + box on c(t), frictionless (condim 1), MuJoCo's soft "
        f"contact with solref {SOLREF[0]:g} s, {SOLREF[1]:g} and solimp "
        f"{' '.join(f'{x:g}' for x in SOLIMP)}",
    ),
}

# the export's model -> how MuJoCo's St Venant-Kirchhoff stands to it
MODELS = {
    "linear": "SVK in place of linear elasticity (geometric nonlinearity)",
    "svk": "SVK: the export's model",
    "neo-hookean": "SVK in place of neo-Hookean",
    "neo-hookean-barrier": "SVK in place of neo-Hookean (with its barrier)",
    "corotational": "SVK in place of corotational",
}


def tool(data: Exported) -> dict:
    """The export's `contact` block (ValueError for an export without one)."""
    if data.contact is None:
        raise ValueError(f"the {data.benchmark} export has no rigid tool in contact")
    return data.contact


def slab_problem(data: Exported, moving: str) -> str | None:
    """Why a contact export cannot be posed as the one-element slab of its block that MuJoCo,
    Newton and Drake pose (one line; `moving`: the simulator's words for a moving constrained
    set), None when it can."""
    if data.dim != 2 or data.plane != "strain" or data.cell_type != "quadrilateral":
        return "posed as a one-element slab of the plane-strain quadrilateral block only"
    if tool(data).get("shape", {}).get("kind") != "half-stadium":
        return "the needle's shape is not the half-stadium"
    if any(np.any(np.abs(np.asarray(x)) > 0) for m in data.motions.values() for x in m):
        return moving
    return None


def posed(data: Exported) -> str | None:
    """None when this module poses the contact export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    if data.procedure != "dynamic":
        return "MuJoCo steps dynamics only; the static procedure has no counterpart"
    if data.model not in MODELS:
        return f"no MuJoCo counterpart of the {data.model} model"
    return slab_problem(
        data, "a moving constrained set has no counterpart in a flex's jointless bodies"
    )


def variants(data: Exported) -> dict[str, str]:
    """The contact variants, name -> one line (with how SVK stands to the export's model and
    the export's E and nu); empty where skipped() says why."""
    if posed(data) is not None:
        return {}
    elastic = f"<elasticity young poisson>: the export's {given(data.material)}"
    return {
        name: f"{line}; {MODELS[data.model]}; {elastic}" for name, (_, _, line) in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """Why no contact variant poses this export ({} when one does)."""
    why = posed(data)
    return {} if why is None else {"all": why}


# --- posing -----------------------------------------------------------------------------------


def slab(data: Exported) -> tuple[np.ndarray, np.ndarray, float]:
    """(nodes (2N, 3) m, tetrahedra (T, 4), thickness t_z m): the quadrilaterals extruded by
    t_z = 1 / mesh size, node i at z = 0 and N + i at z = t_z, six tetrahedra per hexahedron."""
    flat = np.asarray(data.nodes, dtype=np.float64)
    n = len(flat)
    thickness = 1.0 / data.mesh_size
    nodes = np.vstack([np.c_[flat, np.zeros(n)], np.c_[flat, np.full(n, thickness)]])
    quads = np.asarray(data.cells, dtype=np.int64)
    hexes = np.hstack([quads, quads + n])
    tets = split_hexahedra(nodes, hexes)
    if not conforming(tets, hexes):
        raise ValueError("the six-tetrahedra split of the extruded quadrilaterals does not conform")
    return nodes, tets, thickness


def fixed_nodes(data: Exported) -> np.ndarray:
    """The export's fixed nodes (sorted, 2D numbering)."""
    sets = [np.asarray(s, dtype=np.int64) for s in data.effective_sets().values()]
    return np.unique(np.concatenate(sets)) if sets else np.zeros(0, dtype=np.int64)


def mjcf(
    data: Exported, nodes: np.ndarray, tets: np.ndarray, thickness: float, variant: str
) -> str:
    """The MJCF text: a body per slab node (two slide joints, none on the fixed edges), the raw
    flex over them with the export's E, nu and beta, the needle as a mocap body at c(0), the
    integrator at h / substeps. Masses and alpha damping are set after compiling."""
    integrator, substeps, _ = VARIANTS[variant]
    m = data.material
    held = set(fixed_nodes(data).tolist())
    n = len(data.nodes)
    bodies = []
    for i, x in enumerate(nodes):
        where = f'name="v{i}" pos="{x[0]:.17g} {x[1]:.17g} {x[2]:.17g}"'
        if i % n in held:
            bodies.append(f"    <body {where}/>")
        else:
            bodies.append(
                f'    <body {where}><inertial pos="0 0 0" mass="1" diaginertia="1e-9 1e-9 1e-9"/>'
                '<joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 1 0"/></body>'
            )
    c0 = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)[0]
    radius = float(tool(data)["shape"]["radius"])
    soft = (
        f'condim="1" solref="{SOLREF[0]:g} {SOLREF[1]:g}" '
        f'solimp="{" ".join(f"{x:g}" for x in SOLIMP)}"'
    )
    names = " ".join(f"v{i}" for i in range(len(nodes)))
    return f"""<mujoco model="tissuebench {data.benchmark} {data.mesh_size}">
  <option timestep="{data.h / substeps:.17g}" integrator="{integrator}" solver="Newton"
          gravity="0 0 0"/>
  <worldbody>
{chr(10).join(bodies)}
    <body name="needle" mocap="true" pos="{c0[0]:.17g} {c0[1]:.17g} {thickness / 2:.17g}">
      <geom name="disc" type="cylinder" size="{radius:.17g} {thickness:.17g}" {soft}/>
      <geom name="strip" type="box" pos="{STRIP / 2:.17g} 0 0"
            size="{STRIP / 2:.17g} {radius:.17g} {thickness:.17g}" {soft}/>
    </body>
  </worldbody>
  <deformable>
    <flex name="body" dim="3" radius="0" body="{names}"
          vertex="{" ".join("0 0 0" for _ in nodes)}"
          element="{" ".join(str(int(i)) for i in tets.ravel())}">
      <contact {soft} selfcollide="none"/>
      <elasticity young="{m.E:.17g}" poisson="{m.nu:.17g}" damping="{m.beta:.17g}"/>
    </flex>
  </deformable>
</mujoco>
"""


def compile_model(
    data: Exported, nodes: np.ndarray, tets: np.ndarray, thickness: float, variant: str
):
    """(mjModel, qpos address of each slab node's x joint (2N,), -1 for a fixed one): masses
    the row-sum lumped P1 masses (kg), each joint's damping alpha m_i (N s/m)."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf(data, nodes, tets, thickness, variant))
    masses = lumped_masses(nodes, tets, data.material.rho)
    address = np.full(len(nodes), -1, dtype=np.int64)
    for i in range(len(nodes)):
        b = model.body(f"v{i}").id
        if model.body_jntnum[b] == 0:
            continue
        model.body_mass[b] = masses[i]
        dof = model.body_dofadr[b]
        model.dof_damping[dof : dof + 2] = data.material.alpha * masses[i]
        address[i] = model.jnt_qposadr[model.body_jntadr[b]]
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return model, address


def gap(x: np.ndarray, centre: np.ndarray, radius: float) -> np.ndarray:
    """The signed distance (m, negative inside) from points x (P, 2) to the half-stadium of
    centre c and radius R (the export's `shape.signed_distance`)."""
    right = x[:, 0] >= centre[0]
    return np.where(
        right, np.abs(x[:, 1] - centre[1]) - radius, np.linalg.norm(x - centre, axis=1) - radius
    )


def interpenetration(data: Exported, U: np.ndarray) -> np.ndarray:
    """The largest -g_n (m, 0 where none) over the deformed surface at each t_i, for slab
    layers U (steps + 1, 2N, 2) m: each layer's deformed surface edges sampled at SAMPLES
    points, as ours samples them."""
    flat = np.asarray(data.nodes, dtype=np.float64)
    n = len(flat)
    surface = np.asarray(tool(data)["law"]["surface_nodes"], dtype=np.int64)
    surface = surface[np.argsort(flat[surface, 1])]
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    radius = float(tool(data)["shape"]["radius"])
    s = np.linspace(0.0, 1.0, SAMPLES)[None, :, None]
    out = np.zeros(len(U))
    for k in range(len(U)):
        if not np.all(np.isfinite(U[k])):
            out[k] = np.nan
            continue
        for layer in (0, n):
            x = flat[surface] + U[k, surface + layer]
            points = (x[:-1, None, :] * (1 - s) + x[1:, None, :] * s).reshape(-1, 2)
            out[k] = max(out[k], float(-gap(points, centres[k], radius).min()))
    return out


def integrate(data: Exported, variant: str, steps: int | None = None) -> dict:
    """Pose and step the contact export: {"U" (steps + 1, 2N, 2) m per slab node, NaN from a
    divergence on; "force" (steps + 1, 2) N/m, NaN likewise; "diverged" (step or None);
    "reason"; "wall_time_s" (compile to the last step); "compile_s"; "tets"; "thickness"}."""
    import mujoco

    steps = data.steps if steps is None else steps
    integrator, substeps, _ = VARIANTS[variant]
    nodes, tets, thickness = slab(data)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    start = time.perf_counter()
    model, address = compile_model(data, nodes, tets, thickness, variant)
    compile_s = time.perf_counter() - start
    d = mujoco.MjData(model)
    free = address >= 0
    xs, ys = address[free], address[free] + 1
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    U = np.full((steps + 1, len(nodes), 2), np.nan)
    F = np.full((steps + 1, 2), np.nan)
    U[0], F[0] = 0.0, 0.0
    diverged, reason = None, None
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)  # read from d.warning, never a log file
    try:
        for i in range(1, steps + 1):
            pushed = np.zeros(2)
            for j in range(1, substeps + 1):
                c = centres[i - 1] + (centres[i] - centres[i - 1]) * (j / substeps)
                d.mocap_pos[0] = [c[0], c[1], thickness / 2]
                mujoco.mj_step(model, d)
                pushed += [d.qfrc_constraint[xs].sum(), d.qfrc_constraint[ys].sum()]
            u = np.zeros((len(nodes), 2))
            u[free, 0], u[free, 1] = d.qpos[xs], d.qpos[ys]
            if d.warning[bad].number > 0:
                diverged, reason = i, "MuJoCo reset the state: bad acceleration (mjWARN_BADQACC)"
            elif not np.all(np.isfinite(u)):
                diverged, reason = i, "a displacement is not finite"
            elif np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
                diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
            else:
                J = tet_volumes(np.c_[nodes[:, :2] + u, nodes[:, 2]], tets) / volumes
                if J.min() <= 0:
                    inverted = int(np.sum(J <= 0))
                    diverged = i
                    reason = f"{inverted} tetrahedra inverted (J down to {J.min():.3g})"
            if diverged is not None:
                break
            U[i] = u
            F[i] = -pushed / substeps / thickness
    finally:
        mujoco.set_mju_user_warning(previous)
    return {
        "U": U,
        "force": F,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": time.perf_counter() - start,
        "compile_s": compile_s,
        "tets": tets,
        "thickness": thickness,
    }


def planar(U: np.ndarray) -> np.ndarray:
    """The export's displacement (steps + 1, N, 3) m from slab layers (steps + 1, 2N, 2): the
    mean of the two layers, u_z = 0."""
    n = U.shape[1] // 2
    out = np.zeros((U.shape[0], n, 3))
    out[:, :, :2] = 0.5 * (U[:, :n] + U[:, n:])
    return out


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one contact variant serially in workdir: mujoco.xml (the posed MJCF, masses and
    damping set after compiling), mujoco.xdmf (the displacement, m, at every t_i on the
    export's quadrilaterals, NaN from a divergence on) and mujoco_force.csv (the needle force,
    N/m, up to the last good step)."""
    version = installed_version("mujoco", "mujoco-core")
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    dofs = 2 * 2 * len(data.nodes)
    nodes, tets, thickness = slab(data)
    (workdir / "mujoco.xml").write_text(mjcf(data, nodes, tets, thickness, variant))
    try:
        result = integrate(data, variant)
    except Exception as err:  # MuJoCo refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return ExternalRun(
            None, None, dofs, mesh=MESH, status="failed",
            reason=f"MuJoCo raised {type(err).__name__}: {first}", version=version,
        )  # fmt: skip
    path = workdir / SERIES
    points = np.c_[np.asarray(data.nodes, dtype=np.float64), np.zeros(len(data.nodes))]
    cells = np.asarray(data.cells, dtype=np.int64)
    write_series(path, ((points, cells, "quadrilateral"), {FIELD: planar(result["U"])}), data.times)
    kept = np.all(np.isfinite(result["force"]), axis=1)
    force = workdir / FORCE
    write_force_csv(force, data.times[kept], result["force"][kept])
    _, substeps, _ = VARIANTS[variant]
    timing = (
        f"time.perf_counter from compiling the MJCF (masses and damping set, mj_setConst: "
        f"{result['compile_s']:.2f} s) to the last of {data.steps} steps x {substeps} "
        f"mj_step, one thread, float64"
    )
    done = integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h, timing, version,
    )  # fmt: skip
    return dataclasses.replace(done, force=force)
