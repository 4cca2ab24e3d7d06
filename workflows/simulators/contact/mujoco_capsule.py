"""MuJoCo on SPEC 13's needle in 3D: the tissue cylinder as a volumetric flex, pushed into the
centre of its top face by the rigid frictionless capsule, a mocap body that follows c(t).

The posed problem
-----------------
- Mesh: the exported cylinder's hexahedra split into six tetrahedra each, as Drake's capsule
  adapter splits them (`drake_capsule.tetrahedra`: the rod's `newton.split_hexahedra` where it
  conforms, else `cone_split`, which conforms on the O-grid, whose turned blocks crack under
  the rod's split), or its tetrahedra as they are; `<flexcomp type="direct" dim="3">` on the
  exported nodes, flex point i = exported node i.
  The bottom's nodes (the export's fixed set) are `<pin>`ned: world vertices, no freedom.
- Elasticity: `<elasticity young=E poisson=nu damping=beta>`, the export's E (Pa) and nu as
  they are: MuJoCo's piecewise linear St Venant-Kirchhoff with SPEC 1's Lame constants
  mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu)(1 - 2 nu)) (module `mujoco`: MuJoCo 4.0
  fixed 3.x's doubled lambda), in place of the export's model (MODELS).
- Mass and damping: as the rod's (module `mujoco`): each free vertex's body the row-sum
  lumped P1 mass rho V_t / 4 from each tetrahedron it is a corner of (kg), its three slide
  joints' damping alpha m_i (N s/m, set after compiling), the flex's stiffness-proportional
  `damping` beta (s) on the rate of the Green strain. So C = alpha M_L + beta K at small
  strain; dropped: only the part of SPEC 8's beta K_0 v that damps rigid rotations (MuJoCo's
  is objective). No gravity (SPEC 13).
- The capsule: a mocap body at c(t), carrying a capsule geom of radius R whose lower
  hemisphere is centred at c and whose shaft reaches SHAFT = 1 m above it (the half-infinite
  cylinder, cut far above the body, whose top is at most 0.16 m below c). Its position is
  moved linearly in c between the export's c(t_i) at every substep.
- Contact: MuJoCo collides each tetrahedron of the flex (its convex hull, radius 0) with the
  capsule: frictionless (`condim="1"`), its soft constraint with solref (time constant s,
  damping ratio) and solimp (d0, dwidth, width m), MuJoCo's compliance, not a penalty k.
  A variant's solref time constant is one MuJoCo accepts at its substep: it raises any below
  2 substeps to 2 substeps (refsafe), so the stiff variant takes exactly that, with the
  substeps to make it small.
- Integrator: `discrete` (linearised backward Euler; MuJoCo 4.0 needs it, or `Euler` at a
  small step, for 3D flex elasticity) or `Euler` (symplectic: elasticity, flex damping and
  contact explicit, the joints' alpha damping implicit), at h / substeps, every substeps-th
  state kept.
- Output: the displacement (m) at every t_i on the export's nodes and the posed tetrahedra;
  the force the tissue exerts on the capsule, F = the sum over the capsule's contacts of
  mj_contactForce's normal force along the contact frame's normal (+z when the tissue pushes
  the capsule up; x and y a symmetry error), averaged over the step's substeps, in N.
- Divergence as the rod's (SPEC 3, 8), checked at every t_i: a displacement not finite or
  beyond 100 x the extent, an inverted tetrahedron (J <= 0), or MuJoCo's bad-acceleration
  warning: NaN from there on, the force written up to the last good step, status "failed".

Measured (cylinder-MP1, linear, h = 1/30 s, T = 2.5 s, MuJoCo 4.0.0, one thread of 2 shared
cores; the times are upper bounds on a loaded machine). F_z the force on the capsule (N) at
t = 2 s (n = 4: at the last step before it diverged) and at the end; sideways |F_x, F_y| at
that time; the interpenetration compare measures on the deformed top faces (max over the
steps, m); against our `implicit` on the same export (Q1, consistent M, trapezoidal, penalty
kappa = 10):

    n  variant             F_z(2 s)      F_z(end)  sideways  interpenetration  wall
    3  discrete-10         10.00         6.40      0.89      3.0e-3            7.3 s
    3  discrete-30-stiff    9.91         6.80      0.92      3.4e-4            24.7 s
    3  euler-10             9.97         6.41      0.89      2.7e-3            2.3 s
    3  ours (implicit)      4.90         4.87      3e-12     4.5e-2            10.2 s
    4  discrete-10          6.93 (1.9 s) diverged  0.16      3.2e-3            28.7 s
    4  discrete-30-stiff    6.57 (1.83)  diverged  0.15      3.4e-4            98.1 s
    4  euler-10             6.79 (1.87)  diverged  0.16      2.9e-3            3.8 s
    4  ours (implicit)      4.70         4.71      2e-13     3.7e-2            26.2 s

(n = 3 again through `tissuebench external` on a quieter machine: discrete-10 5.6 s,
euler-10 0.56 s, ours 5.5 s.)

- MuJoCo's force is 2.0 x ours at t = 2 s on n = 3 and 1.25 x at t = 1.5 s on n = 4 (1.81 on
  n = 3): the faceted top face cannot wrap the ball and is carried down as a pyramid, its
  centre node 0.029 m below the capsule's tip at t = 2 s on n = 3 (u_z = -0.189 m; ours
  -0.136 m, its penalty 0.024 m inside), a wider dent than the continuum's; it shrinks with
  the mesh. The stiff contact changes the force by 1 % but cuts the interpenetration tenfold
  and turns two impacts into spikes: the first step (9.2 N, default 4.1 N: the capsule starts
  at 0.08 m/s and the contact brings the touched nodes to its speed at once; ours 0.02 N) and
  the contact regained at t = 2.27 s (20.6 N; default 11.5 N at 2.23 s) after the tissue,
  still moving down when the capsule stops at t = 2 s, left it for 0.1-0.2 s (F = 0 at
  t = 2.1 s; ours stays in contact). `euler-10` poses the same as `discrete-10` (force within
  0.3 %) in a third (n = 3) to a seventh (n = 4) of the time.
- The sideways force, zero for the axisymmetric answer, is 0.09 of the axial one at t = 2 s on
  n = 3 and 0.02 on n = 4 (up to 0.5 at the regained contact): the split's asymmetry.
- n = 4 diverges at t = 1.87-1.93 s (0.15 m deep) in every variant: the two tetrahedra under
  the top centre node are crushed (J -> 0, then inverted), the pyramid's apex 0.022 m below
  the tip (u_z = -0.174 m at t = 1.9 s; ours -0.150 m) on St Venant-Kirchhoff, which softens
  in compression (as the rod's and the 2D needle's, module `mujoco` and contact/mujoco.py);
  the integrator does not change it. Our own Q1 `implicit+svk` on the same mesh runs to the
  end (its soft penalty does not drive the face below the tip).
- E_i max against ours: 3.7e-3 m^3 on n = 3, 1.3e-3 m^3 on n = 4 (to the divergence).
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators.contact.drake_capsule import tetrahedra
from tissuebench.workflows.simulators.contact.mujoco import MODELS, SOLIMP, SOLREF, tool
from tissuebench.workflows.simulators.mujoco import (
    DIVERGED,
    FIELD,
    SERIES,
    clamped_nodes,
    displacement,
)
from tissuebench.workflows.simulators.newton import lumped_masses, tet_volumes

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

FORCE = "mujoco_force.csv"
SHAFT = 1.0  # m: the capsule's shaft above c, the half-infinite cylinder cut far above the body
STIFF_SOLIMP = (0.95, 0.99, 0.001)  # the probe's stiffer impedance (d0, dwidth, width in m)
# MuJoCo's integrators in words
SCHEMES = {
    "discrete": "linearised backward Euler",
    "Euler": "symplectic: elasticity, beta damping and contact explicit, alpha damping implicit",
}


@dataclasses.dataclass(frozen=True)
class Variant:
    """A contact variant: MuJoCo's integrator, substeps per h, solref (time constant in s, or
    None for 2 substeps: the stiffest MuJoCo accepts; damping ratio) and solimp."""

    integrator: str
    substeps: int
    timeconst: float | None
    dampratio: float
    solimp: tuple[float, float, float]

    def solref(self, h: float) -> tuple[float, float]:
        """(time constant s, damping ratio) at step h (s)."""
        tc = 2.0 * h / self.substeps if self.timeconst is None else self.timeconst
        return tc, self.dampratio

    def words(self, h: float) -> str:
        tc, ratio = self.solref(h)
        imp = " ".join(f"{x:g}" for x in self.solimp)
        return (
            f"contact: integrator {self.integrator} ({SCHEMES[self.integrator]}), "
            f"{self.substeps} substeps of h/{self.substeps}; St Venant-Kirchhoff P1 tetrahedra "
            "(6 per hexahedron), row-sum lumped mass, C = alpha M_L + beta K, the bottom pinned; "
            "the capsule a mocap body on c(t), frictionless (condim 1), MuJoCo's soft contact "
            f"with solref {tc:.4g} s, {ratio:g} and solimp {imp}"
        )


VARIANTS = {
    # MuJoCo's default contact
    "discrete-10": Variant("discrete", 10, SOLREF[0], SOLREF[1], SOLIMP),
    # the stiffest time constant MuJoCo takes at the substep: 2 h / 30 = 0.0022 s
    "discrete-30-stiff": Variant("discrete", 30, None, 1.0, STIFF_SOLIMP),
    # the default contact under the explicit integrator, as the 2D needle's adapter runs it
    "euler-10": Variant("Euler", 10, SOLREF[0], SOLREF[1], SOLIMP),
}


def posed(data: Exported) -> str | None:
    """None when this module poses the export, else why not (one line)."""
    if data.contact is None:
        return "not a contact benchmark"
    if tool(data).get("shape", {}).get("kind") != "capsule":
        return "the needle's shape is not the capsule"
    if data.procedure != "dynamic":
        return "MuJoCo steps dynamics only; the static procedure has no counterpart"
    if data.model not in MODELS:
        return f"no MuJoCo counterpart of the {data.model} model"
    if data.dim != 3 or data.cell_type not in ("hexahedron", "tetrahedron"):
        return "posed on a 3D mesh of hexahedra or tetrahedra only"
    if any(np.any(np.abs(np.asarray(x)) > 0) for m in data.motions.values() for x in m):
        return "a moving constrained set has no counterpart in a flex's pinned vertices"
    return None


def variants(data: Exported) -> dict[str, str]:
    """The contact variants, name -> one line (the integrator, the contact's solref and
    solimp, how SVK stands to the export's model and the export's E and nu); empty where
    skipped() says why."""
    if posed(data) is not None:
        return {}
    elastic = f"<elasticity young poisson>: the export's {given(data.material)}"
    return {
        name: f"{v.words(data.h)}; {MODELS[data.model]}; {elastic}" for name, v in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """What is not posed of this export and why, one line each: {"all": why} when no variant
    poses it, else the export's model where MuJoCo's St Venant-Kirchhoff stands in for it ({}
    for an svk export)."""
    why = posed(data)
    if why is not None:
        return {"all": why}
    if data.model != "svk":
        return {
            "model": f"MuJoCo's flex elasticity is St Venant-Kirchhoff only: {MODELS[data.model]}"
        }
    return {}


# --- posing -----------------------------------------------------------------------------------


def mjcf(data: Exported, tets: np.ndarray, variant: str) -> str:
    """The MJCF text: the flexcomp on the exported nodes and tetrahedra with the export's E, nu
    and beta, the bottom pinned, the capsule a mocap body at c(t_0) with the variant's contact,
    no gravity, the integrator at h / substeps. Masses and alpha damping are set after
    compiling (compile_model)."""
    v = VARIANTS[variant]
    m = data.material
    radius = float(tool(data)["shape"]["radius"])
    c0 = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)[0]
    tc, ratio = v.solref(data.h)
    soft = (
        f'condim="1" solref="{tc:.17g} {ratio:g}" solimp="{" ".join(f"{x:g}" for x in v.solimp)}"'
    )
    points = " ".join(f"{x:.17g}" for x in np.asarray(data.nodes, dtype=np.float64).ravel())
    pinned = " ".join(str(int(i)) for i in clamped_nodes(data))
    pin = f'\n      <pin id="{pinned}"/>' if pinned else ""
    return f"""<mujoco model="tissuebench {data.benchmark} {data.mesh_size}">
  <option timestep="{data.h / v.substeps:.17g}" integrator="{v.integrator}" solver="Newton"
          gravity="0 0 0"/>
  <worldbody>
    <body name="needle" mocap="true" pos="{c0[0]:.17g} {c0[1]:.17g} {c0[2]:.17g}">
      <geom name="capsule" type="capsule" size="{radius:.17g}"
            fromto="0 0 0 0 0 {SHAFT:.17g}" {soft}/>
    </body>
    <flexcomp name="body" type="direct" dim="3" radius="0" mass="{m.rho:.17g}"
              point="{points}"
              element="{" ".join(str(int(i)) for i in tets.ravel())}">
      <contact {soft} selfcollide="none"/>
      <elasticity young="{m.E:.17g}" poisson="{m.nu:.17g}" damping="{m.beta:.17g}"/>{pin}
    </flexcomp>
  </worldbody>
</mujoco>
"""


def compile_model(data: Exported, tets: np.ndarray, variant: str):
    """(mjModel, qpos address of each node's x (N,), -1 for a pinned one): each free vertex's
    body mass its row-sum lumped P1 mass (kg), its slide joints' damping alpha m_i (N s/m),
    mj_setConst rerun."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(mjcf(data, tets, variant))
    masses = lumped_masses(np.asarray(data.nodes, dtype=np.float64), tets, data.material.rho)
    address = np.full(len(masses), -1, dtype=np.int64)
    for i, b in enumerate(np.asarray(model.flex_vertbodyid, dtype=np.int64)):
        if b > 0:  # 0: pinned, a world vertex
            model.body_mass[b] = masses[i]
            dof = model.body_dofadr[b]
            model.dof_damping[dof : dof + 3] = data.material.alpha * masses[i]
            address[i] = model.jnt_qposadr[model.body_jntadr[b]]
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return model, address


def capsule_force(model, d, geom: int) -> np.ndarray:
    """The force (3,) N that the flex exerts on the capsule geom: each of its contacts'
    mj_contactForce normal force along the contact frame's first axis (which points from
    geom1 to geom2: the push on geom2), signed for the capsule's side."""
    import mujoco

    total, f6 = np.zeros(3), np.zeros(6)
    for k in range(d.ncon):
        contact = d.contact[k]
        if geom not in (contact.geom[0], contact.geom[1]):
            continue
        mujoco.mj_contactForce(model, d, k, f6)
        world = contact.frame.reshape(3, 3).T @ f6[:3]
        total += world if contact.geom[1] == geom else -world
    return total


def integrate(data: Exported, variant: str, steps: int | None = None) -> dict:
    """Pose and step the export: {"U" (steps + 1, N, 3) m, NaN from a divergence on; "force"
    (steps + 1, 3) N on the capsule, NaN likewise; "diverged" (step or None); "reason";
    "wall_time_s" (compile to the last step); "compile_s"; "tets"}."""
    import mujoco

    steps = data.steps if steps is None else steps
    v = VARIANTS[variant]
    nodes = np.asarray(data.nodes, dtype=np.float64)
    tets, _ = tetrahedra(data)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    centres = np.asarray(tool(data)["motion"]["c"], dtype=np.float64)
    start = time.perf_counter()
    model, address = compile_model(data, tets, variant)
    compile_s = time.perf_counter() - start
    geom = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, "capsule")
    d = mujoco.MjData(model)
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    U = np.full((steps + 1, len(nodes), 3), np.nan)
    F = np.full((steps + 1, 3), np.nan)
    U[0], F[0] = 0.0, 0.0
    diverged, reason = None, None
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)  # read from d.warning, never a log file
    try:
        for i in range(1, steps + 1):
            pushed = np.zeros(3)
            for j in range(1, v.substeps + 1):
                d.mocap_pos[0] = centres[i - 1] + (centres[i] - centres[i - 1]) * (j / v.substeps)
                mujoco.mj_step(model, d)
                pushed += capsule_force(model, d, geom)
            u = displacement(d.qpos, address)
            if d.warning[bad].number > 0:
                diverged, reason = i, "MuJoCo reset the state: bad acceleration (mjWARN_BADQACC)"
            elif not np.all(np.isfinite(u)):
                diverged, reason = i, "a displacement is not finite"
            elif np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
                diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
            else:
                J = tet_volumes(nodes + u, tets) / volumes
                if J.min() <= 0:
                    diverged = i
                    reason = f"{int(np.sum(J <= 0))} tetrahedra inverted (J down to {J.min():.3g})"
            if diverged is not None:
                break
            U[i] = u
            F[i] = pushed / v.substeps
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
    }


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one contact variant serially in workdir: mujoco.xml (the posed MJCF, masses and
    damping set after compiling), mujoco.xdmf (the displacement, m, at every t_i on the
    export's nodes and the posed tetrahedra, NaN from a divergence on) and mujoco_force.csv
    (the force on the capsule, N, up to the last good step)."""
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series

    version = installed_version("mujoco", "mujoco-core")
    workdir = Path(workdir)
    dofs = data.nodes.size

    def failed(reason: str, mesh: str = "reference") -> ExternalRun:
        return ExternalRun(
            None, None, dofs, mesh=mesh, status="failed", reason=reason, version=version
        )

    if variant not in variants(data):
        offered = ", ".join(variants(data)) or "none"
        return failed(f"MuJoCo variant {variant!r} does not pose this export (posed: {offered})")
    try:
        tets, mesh = tetrahedra(data)
    except ValueError as err:  # no conforming split of these hexahedra
        return failed(str(err))
    (workdir / "mujoco.xml").write_text(mjcf(data, tets, variant))
    try:
        result = integrate(data, variant)
    except Exception as err:  # MuJoCo refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return failed(f"MuJoCo raised {type(err).__name__}: {first}", mesh)
    path = workdir / SERIES
    points = np.asarray(data.nodes, dtype=np.float64)
    write_series(path, ((points, tets, "tetrahedron"), {FIELD: result["U"]}), data.times)
    kept = np.all(np.isfinite(result["force"]), axis=1)
    force = workdir / FORCE
    write_force_csv(force, data.times[kept], result["force"][kept])
    substeps = VARIANTS[variant].substeps
    timing = (
        f"time.perf_counter from compiling the MJCF (masses and damping set, mj_setConst: "
        f"{result['compile_s']:.2f} s) to the last of {data.steps} steps x {substeps} "
        f"mj_step, one thread, float64"
    )
    done = integrated(
        path, result["wall_time_s"], dofs, FIELD, mesh, result["diverged"], result["reason"],
        data.h, timing, version,
    )  # fmt: skip
    return dataclasses.replace(done, force=force)
