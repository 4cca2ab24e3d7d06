"""MuJoCo (https://mujoco.org): a robotics simulator's volumetric flex body, posing the rod as a
MuJoCo user would: `<flexcomp type="direct" dim="3">` on the exported nodes, with MuJoCo's
continuum `<elasticity>`, run on the CPU in process.

The posed problem (SPEC sections 1, 3, 5, 8)
--------------------------------------------
- Mesh: the exported hexahedra split into six tetrahedra each, exactly as the Newton runner
  splits them (`newton.split_hexahedra`, imported: around each cell's 0-6 diagonal after an
  octant renumbering, conforming); an export of tetrahedra (`--cell tetrahedron`) is taken as
  it is. Flexcomp point i is exported node i, so the displacements compare node by node.
- Elasticity: `<elasticity young=E poisson=nu damping=beta>`, MuJoCo's piecewise linear
  St Venant-Kirchhoff (Green strain, psi = mu tr(E^2) + (lambda/2) tr(E)^2), the Lame constants
  of SPEC section 1 as they are (MuJoCo 4.0 fixed the doubled lambda of 3.x). Its `damping` is
  stiffness-proportional: beta times its stiffness. Measured on rod n = 2 (the test): in the
  small-load limit MuJoCo's step equals backward Euler on linear P1 with K, M_L and
  C = alpha M_L + beta K to 7e-9 (relative, load scale 1e-6), the difference growing in
  proportion to the load: it is SVK's geometric nonlinearity (7.4e-3 at load scale 1 after 1 s).
- Mass: flexcomp gives every point the same mass (`mass` / number of points), so after
  compiling each free vertex's body gets the row-sum lumped P1 mass, rho V_t / 4 from every
  tetrahedron it is a corner of (`newton.lumped_masses`; total rho * volume), and
  `mj_setConst` recomputes what depends on it. Gravity: the export's vector as `<option
  gravity>`, m_i g on each vertex (P1's consistent load, exactly). M_L stands in for the
  reference's consistent M (SPEC's `implicit-lumped` departure).
- Damping: flexcomp has no mass damping; each free vertex's three slide joints get
  `dof_damping` = alpha m_i (N s/m), so that C = alpha M_L + beta K. The flex damping acts on
  the rate of the Green strain, taken as a difference over one step, (E(q + h v) - E(q)) / h:
  beta K_0 v at small strain (to a relative h |grad v| / 2: 1.7e-5 at 1e-3 1/s, h = 1/30 s),
  but objective: a rigid rotation is not damped, where SPEC section 8's beta K_0 v damps
  rotation rates too (the test: no damping force on the rod turned a quarter round about z
  and spinning at 1 rad/s about z, where beta K_0 v reaches 15 N on a node).
- Clamp: `<pin>` on the exported clamped nodes (they stay world vertices, no degrees of
  freedom); no contact (contype = conaffinity = 0, no self-collision, radius 0).
- Integrator: `discrete` (MuJoCo 4.0 refuses 3D flex elasticity under `implicit` and
  `implicitfast`: "set integrator='discrete', or 'Euler' with a small timestep"). It solves
  (M + h D + h^2 K) (v+ - v) / h = f(q, v) - h K v, q+ = q + h v+: one linearised backward
  Euler step, first order and dissipative, in place of SPEC's trapezoidal Newmark (second
  order, no numerical damping). Without constraint rows the step is one solve in that metric
  (matches backward Euler to 7e-9, above). `euler-10` is MuJoCo's `Euler` (symplectic
  Euler: elasticity and the flex damping explicit, the joints' alpha damping implicit,
  (M + h alpha M)(v+ - v) = h f(q, v), q+ = q + h v+; the test checks it against numpy's
  to 1e-5), stable on the rod at h/3 for n = 3, h/10 for n = 6 (h/3 inverts a tetrahedron
  at t = 0.13 s). A variant with substeps runs its step at h / k and keeps every k-th state.
- Output: the displacement (the slide joints' qpos, m) at every t_i = i h on the
  reference's nodes. A run diverges as SPEC sections 3 and 8 say, checked at every t_i: a
  displacement not finite or beyond 100 x the largest extent, an inverted tetrahedron
  (J <= 0), or MuJoCo's own bad-acceleration warning (it resets the state); NaN from there on,
  status "failed".

Departures, measured (rod MP3, h = 1/30 s, 300 steps, MuJoCo 4.0.0 on 2 shared cores): E_n
time mean (max) against our `implicit` (Q1 hexahedra, consistent M, trapezoidal, linear);
the rows before MuJoCo's are linear P1 on the same tetrahedra, solved in numpy, adding one
departure at a time:

                                                  n = 3           n = 6           n = 12
    P1 tetrahedra (consistent M, trapezoidal)     0.142 (0.215)   0.047 (0.075)   0.014 (0.022)
    + row-sum lumped M_L                          0.148 (0.213)   0.049 (0.074)   0.014 (0.022)
    + backward Euler at h (`discrete`, linear)    0.157 (0.897)   0.060 (0.924)   0.027 (0.933)
    + St Venant-Kirchhoff: MuJoCo `discrete`      0.185 (0.897)   0.124 (0.924)   0.117 (0.933)
    MuJoCo `discrete-10`                          0.177 (0.244)   0.114 (0.151)   0.108 (0.144)
    MuJoCo `euler-10`                             0.176 (0.244)   0.114 (0.151)   diverged, t_2

- The tetrahedra: stiffer in bending than Q1 (the Newton runner's split; P1/Q1 static tip
  0.80 on n = 3); the difference shrinks with the mesh.
- Backward Euler: its first step is u_1 = h^2 a_0 where the trapezoidal rule takes about
  h^2 a_0 / 2, so E_n is near 0.9 at t_1 (the max); over the run it adds 0.01 to the mean
  (its numerical damping of the rod's oscillation). Ten substeps remove the first-step gap.
- SVK's geometric nonlinearity at load scale 1 (the tip sags 0.1 m on 0.5 m): `discrete`
  against its own linear limit 0.086 (0.113) on n = 3, 0.100 (0.134) on n = 6 and 0.106
  (0.142) on n = 12, as our own Q1 `implicit+svk` against `implicit`, 0.100 (0.135) on n = 3.
  It does not shrink with the mesh, so MuJoCo stops converging to the linear rod near
  E_n = 0.11. Against our `implicit+svk` (the model MuJoCo poses), `discrete` stands at
  0.153 (0.897) and `discrete-10` at 0.144 (0.218) on n = 3, the tetrahedra's own 0.142 being
  most of it.
- Large deformation (SPEC 8, load scale 3, against `implicit+neo-hookean`): SVK softens in
  compression and the rod's tetrahedra by the clamp collapse. On n = 3 `discrete` inverts one
  at t = 5.57 s, `discrete-10` at 5.2 s, `euler-10` at 5.17 s; on n = 6 all three by
  t = 2.77-2.87 s; our own Q1 `implicit+svk` inverts too, at t = 8.3 s on n = 3: the model's,
  not MuJoCo's (the neo-Hookean reference runs to the end). Up to there, E_i mean (max)
  1.5e-3 (3.2e-3) m^3 on n = 3, 5.6e-4 (1.7e-3) m^3 on n = 6.

E_i max against the truth (SPEC 10, `tissuebench compare truth:rod`; its own error 4.7e-6
m^3) and wall time per simulated second (compile and steps, one thread):

    n (dofs)      `discrete`         `discrete-10`     `euler-10`         our `implicit`
    3 (336)       1.74e-3, 0.020 s   1.74e-3, 0.22 s   1.75e-3, 0.13 s    4.4e-4, 0.009 s
    6 (1,911)     9.8e-4, 0.18 s     9.8e-4, 1.2 s     9.8e-4, 1.1 s      1.4e-4, 0.043 s
    12 (12,675)   9.0e-4, 3.2 s      9.0e-4, 25 s      diverged at t_2    3.7e-5, 0.46 s

(measured beside other runs on the same 2 cores: the n = 12 times may be up to twice a quiet
machine's). `euler-10` needs h/10 from n = 6 on and more at n = 12: MuJoCo's bad-acceleration
reset at t_2, an explicit scheme's stable step shrinking with the element size.

The contact benchmark (SPEC 12) is posed by its adapter, contact/mujoco.py (a one-element slab of
the block with u_z held, the needle a mocap body in frictionless contact).

Not posed: the 2D block with its glued needle (`dof="2d"` would hold z on a one-layer slab,
but the needle is a moving constrained set: a pinned flex vertex follows its body, and a
mocap body, MuJoCo's only kinematic one, is refused for elastic flexes with damping: no
prescribed velocity), and the static procedure (MuJoCo steps dynamics only).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import (
    ExternalRun,
    given,
    installed_version,
    integrated,
)
from tissuebench.workflows.simulators.newton import (
    conforming,
    lumped_masses,
    split_hexahedra,
    tet_volumes,
)

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

NAME = "mujoco"


def _version() -> str:
    """MuJoCo's installed version, without importing it ("" when absent)."""
    return installed_version("mujoco", "mujoco-core")


TITLE = f"MuJoCo {_version()}".strip()
SERIES = "mujoco.xdmf"
FIELD = "displacement"
DIVERGED = 100.0  # SPEC section 3: a nodal displacement beyond 100 x the largest extent
SPLIT = "tetrahedra, 6 per hexahedron, on the reference's nodes"

# name -> (MuJoCo integrator, substeps per h, one line of what the variant is)
VARIANTS = {
    "discrete": (
        "discrete",
        1,
        "integrator discrete (linearised backward Euler, first order), one step of h; "
        "St Venant-Kirchhoff P1 tetrahedra, row-sum lumped mass, C = alpha M_L + beta K",
    ),
    "discrete-10": (
        "discrete",
        10,
        "integrator discrete (linearised backward Euler), 10 substeps of h/10; "
        "St Venant-Kirchhoff P1 tetrahedra, row-sum lumped mass, C = alpha M_L + beta K",
    ),
    "euler-10": (
        "Euler",
        10,
        "integrator Euler (symplectic: elasticity and beta damping explicit, alpha damping "
        "implicit), 10 substeps of h/10; St Venant-Kirchhoff P1 tetrahedra, row-sum lumped "
        "mass, C = alpha M_L + beta K",
    ),
}

# the export's model -> how MuJoCo's St Venant-Kirchhoff stands to it
MODELS = {
    "linear": "SVK in place of linear elasticity (geometric nonlinearity)",
    "svk": "SVK: the export's model",
    "neo-hookean": "SVK in place of neo-Hookean",
    "corotational": "SVK in place of corotational",
}


def available() -> str | None:
    """None when MuJoCo can be imported here, else what to install."""
    try:
        import mujoco
    except ImportError as err:
        return f"MuJoCo is not installed ({err}): pip install 'mujoco>=4.0'"
    major = int(str(mujoco.__version__).split(".")[0])
    if major < 4:  # 3.x doubled lambda in 3D flex elasticity (changelog of 4.0.0)
        return f"MuJoCo {mujoco.__version__} is too old (4.0 or later): pip install 'mujoco>=4.0'"
    return None


def _posed(data: Exported) -> bool:
    """Whether the export is one this runner poses: the dynamic 3D rod on hexahedra or
    tetrahedra, with fixed constrained sets and a model MuJoCo's SVK can stand in for."""
    if data.procedure != "dynamic" or data.dim != 3 or data.model not in MODELS:
        return False
    if data.cell_type not in ("hexahedron", "tetrahedron"):
        return False
    return not any(np.any(np.abs(np.asarray(x)) > 0) for m in data.motions.values() for x in m)


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose this export, name -> one line (with how SVK stands to the
    export's model); empty where skipped() says why."""
    if not _posed(data):
        return {}
    elastic = f"<elasticity young poisson>: the export's {given(data.material)}"
    return {
        name: f"{line}; {MODELS[data.model]}; {elastic}" for name, (_, _, line) in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """Why no variant poses this export, when none does."""
    if data.procedure != "dynamic":
        return {"all": "MuJoCo steps dynamics only; the static procedure has no counterpart"}
    if data.dim != 3:
        why = "the block's needle moves: a pinned flex vertex follows its body, and MuJoCo "
        return {"all": why + "refuses mocap (kinematic) bodies for elastic flexes with damping"}
    if data.model not in MODELS:
        return {"all": f"no MuJoCo counterpart of the {data.model} model"}
    if not _posed(data):
        return {"all": "a moving constrained set has no counterpart in a flex's pinned vertices"}
    return {}


# --- posing -----------------------------------------------------------------------------------


def tetrahedra(data: Exported) -> np.ndarray:
    """The posed tetrahedra (T, 4) on the exported nodes, positively oriented: the hexahedra
    split as newton.split_hexahedra does, or the exported tetrahedra."""
    nodes = np.asarray(data.nodes, dtype=np.float64)
    if data.cell_type == "hexahedron":
        return split_hexahedra(nodes, data.cells)
    tets = np.array(data.cells, dtype=np.int64)
    negative = tet_volumes(nodes, tets) < 0
    tets[negative] = tets[negative][:, [0, 1, 3, 2]]
    return tets


def clamped_nodes(data: Exported) -> np.ndarray:
    """The nodes of the (fixed) constrained sets, sorted: MuJoCo's pinned points."""
    sets = [np.asarray(s, dtype=np.int64) for s in data.effective_sets().values()]
    return np.unique(np.concatenate(sets)) if sets else np.zeros(0, dtype=np.int64)


def mjcf(data: Exported, tets: np.ndarray, substeps: int = 1, integrator: str = "discrete") -> str:
    """The MJCF text of the posed rod: one flexcomp on the exported nodes and tetrahedra, SVK
    elasticity with the export's E, nu and beta, the clamped nodes pinned, gravity the
    export's, no contact, the integrator ("discrete" or "Euler") at h / substeps. The masses
    and the alpha damping are set after compiling (compile_model)."""
    m = data.material
    gravity = np.zeros(3)
    gravity[: data.dim] = data.gravity
    points = " ".join(f"{x:.17g}" for x in np.asarray(data.nodes, dtype=np.float64).ravel())
    elements = " ".join(str(int(i)) for i in tets.ravel())
    pinned = " ".join(str(int(i)) for i in clamped_nodes(data))
    pin = f'\n      <pin id="{pinned}"/>' if pinned else ""
    return f"""<mujoco model="tissuebench {data.benchmark} {data.mesh_size}">
  <option timestep="{data.h / substeps:.17g}" integrator="{integrator}" solver="Newton"
          gravity="{gravity[0]:.17g} {gravity[1]:.17g} {gravity[2]:.17g}"/>
  <worldbody>
    <flexcomp name="body" type="direct" dim="3" radius="0" mass="{m.rho:.17g}"
              point="{points}"
              element="{elements}">
      <contact contype="0" conaffinity="0" selfcollide="none"/>
      <elasticity young="{m.E:.17g}" poisson="{m.nu:.17g}" damping="{m.beta:.17g}"/>{pin}
    </flexcomp>
  </worldbody>
</mujoco>
"""


def compile_model(
    data: Exported,
    tets: np.ndarray,
    substeps: int = 1,
    alpha: float | None = None,
    integrator: str = "discrete",
):
    """(mjModel, qpos address of each node's x (N,), -1 for a pinned one): the MJCF compiled,
    each free vertex's body mass set to its row-sum lumped P1 mass (kg) and its three slide
    joints' damping to alpha m_i (N s/m; alpha defaults to the material's), mj_setConst
    rerun."""
    import mujoco

    nodes = np.asarray(data.nodes, dtype=np.float64)
    alpha = data.material.alpha if alpha is None else alpha
    model = mujoco.MjModel.from_xml_string(mjcf(data, tets, substeps, integrator))
    masses = lumped_masses(nodes, tets, data.material.rho)
    bodies = np.asarray(model.flex_vertbodyid, dtype=np.int64)
    address = np.full(len(nodes), -1, dtype=np.int64)
    for i, b in enumerate(bodies):
        if b <= 0:  # pinned: a world vertex
            continue
        model.body_mass[b] = masses[i]
        dof = model.body_dofadr[b]
        model.dof_damping[dof : dof + 3] = alpha * masses[i]
        address[i] = model.jnt_qposadr[model.body_jntadr[b]]
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return model, address


def displacement(qpos: np.ndarray, address: np.ndarray) -> np.ndarray:
    """Nodal displacements (N, 3) m from qpos: the free vertices' slide joints (x, y, z from
    each body's first joint on), zero on the pinned ones."""
    U = np.zeros((len(address), 3))
    free = address >= 0
    U[free] = qpos[address[free][:, None] + np.arange(3)]
    return U


def integrate(
    data: Exported,
    tets: np.ndarray,
    substeps: int,
    steps: int,
    model=None,
    integrator: str = "discrete",
) -> dict:
    """Compile (unless model = (mjModel, address) is given) and step the posed rod: {"U"
    (steps + 1, N, 3) m with NaN from a divergence on, "diverged" (step or None), "reason",
    "wall_time_s" (compile, when done here, to the last step), "compile_s"}. Divergence as SPEC
    sections 3 and 8 say, checked at every t_i (module docstring)."""
    import mujoco

    nodes = np.asarray(data.nodes, dtype=np.float64)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    start = time.perf_counter()
    if model is None:
        model = compile_model(data, tets, substeps, integrator=integrator)
    mj, address = model
    compile_s = time.perf_counter() - start
    d = mujoco.MjData(mj)
    bad = int(mujoco.mjtWarning.mjWARN_BADQACC)
    U = np.full((steps + 1, len(nodes), 3), np.nan)
    U[0] = 0.0
    diverged, reason = None, None
    # MuJoCo writes its warnings to MUJOCO_LOG.TXT in the current folder (the user's): a
    # divergence is read from d.warning instead, and the text goes nowhere
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)
    try:
        for i in range(1, steps + 1):
            for _ in range(substeps):
                mujoco.mj_step(mj, d)
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
                    inverted = int(np.sum(J <= 0))
                    diverged, reason = (
                        i,
                        f"{inverted} tetrahedra inverted (J down to {J.min():.3g})",
                    )
            if diverged is not None:
                break
            U[i] = u
    finally:
        mujoco.set_mju_user_warning(previous)
    wall = time.perf_counter() - start
    return {
        "U": U,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": wall,
        "compile_s": compile_s,
    }


def simulate(data: Exported, variant: str, steps: int | None = None) -> dict:
    """Run variant on the export: integrate()'s dict with "tets" added."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown MuJoCo variant {variant!r}: use one of {', '.join(VARIANTS)}")
    steps = data.steps if steps is None else steps
    tets = tetrahedra(data)
    integrator, substeps, _ = VARIANTS[variant]
    return {**integrate(data, tets, substeps, steps, integrator=integrator), "tets": tets}


def not_run(data: Exported, reason: str) -> ExternalRun:
    """A variant that stopped before writing a series, with why."""
    mesh = SPLIT if data.cell_type == "hexahedron" else "reference"
    return ExternalRun(
        None, None, data.nodes.size, mesh=mesh, status="failed", reason=reason, version=_version()
    )


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in workdir: mujoco.xml (the posed MJCF; masses and alpha
    damping are set after compiling, module docstring) and mujoco.xdmf, the displacement (m)
    on the posed tetrahedra at every t_i = i h, NaN from a divergence on (status "failed")."""
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    if variant not in variants(data):
        return not_run(
            data,
            f"MuJoCo variant {variant!r} does not pose this export "
            f"(posed: {', '.join(variants(data)) or 'none'})",
        )
    tets = tetrahedra(data)
    if data.cell_type == "hexahedron" and not conforming(tets, data.cells):
        return not_run(data, "the six-tetrahedra split of these hexahedra does not conform")
    integrator, substeps, _ = VARIANTS[variant]
    (workdir / "mujoco.xml").write_text(mjcf(data, tets, substeps, integrator))
    try:
        result = simulate(data, variant)
    except Exception as err:  # MuJoCo refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return not_run(data, f"MuJoCo raised {type(err).__name__}: {first}")
    path = workdir / SERIES
    points = np.asarray(data.nodes, dtype=np.float64)
    write_series(path, ((points, tets, "tetrahedron"), {FIELD: result["U"]}), data.times)
    timing = (
        f"time.perf_counter from compiling the MJCF (masses and damping set, mj_setConst: "
        f"{result['compile_s']:.2f} s) to the last of {data.steps} steps x {substeps} "
        f"mj_step, one thread, float64"
    )
    mesh = SPLIT if data.cell_type == "hexahedron" else "reference"
    return integrated(
        path, result["wall_time_s"], data.nodes.size, FIELD, mesh, result["diverged"],
        result["reason"], data.h, timing, _version(),
    )  # fmt: skip
