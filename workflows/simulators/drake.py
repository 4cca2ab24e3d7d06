"""Drake (https://drake.mit.edu, `pip install drake`): the deformable FEM bodies of its
MultibodyPlant, which robotics users simulate soft objects with, run on the CPU in process.

The posed problem (SPEC sections 1, 3, 5, 8)
--------------------------------------------
- Mesh: the export's hexahedra split into six tetrahedra each exactly as the Newton runner
  does (workflows/simulators/newton.py: split_hexahedra, a conforming split on the reference's
  nodes, positive volumes, which is Drake's vertex order convention), written as a legacy
  ASCII .vtk unstructured grid (17 digits) that Drake reads as its VolumeMesh; Drake keeps the
  vertex order (checked at every run: its reference positions are the export's nodes), so its
  nodal displacements compare one to one with the reference's.
- Element: Drake's linear tetrahedron with its one-point (centroid) quadrature, exact for the
  P1 stiffness. Its mass matrix comes from the same one point: rho V / 16 between every pair
  of a tetrahedron's corners (the consistent P1 mass has rho V / 10 on the diagonal and
  rho V / 20 off it; the row sums, rho V / 4, and the total mass agree). Gravity: the export's
  vector as the plant's gravity field, rho V g / 4 to each corner (exact for constant g).
- Damping: Drake's DampingModel, D = alpha M + beta K with the two Rayleigh coefficients of the
  export (`mass_damping_coefficient`, `stiffness_damping_coefficient`), M Drake's one-point
  mass. K is the stiffness tangent at the current state: K_0 for the linear model (as the
  SPEC), the current tangent for the nonlinear ones (the SPEC keeps beta K_0 for every model).
- Clamp: `SetWallBoundaryCondition`, every vertex in an open half-space held at zero
  displacement; the plane is put halfway between the clamped face and the next layer of nodes
  (axis-aligned, found from the export's node set; an export whose fixed nodes no such plane
  cuts off is not posed).
- Integrator: Drake's only one for deformables, VelocityNewmarkScheme with gamma = 1,
  beta = 1/2 (usual notation; beta_N = 1 in the SPEC's): v_{i+1} = v_i + h a_{i+1},
  u_{i+1} = u_i + (h/2)(v_i + v_{i+1}), the balance at t_{i+1}. First order and dissipative,
  against the SPEC's trapezoidal rule (gamma = 1/2, second order, no numerical dissipation).
  One step of the plant per t_i (time_step = h), no substeps; the initial acceleration is
  zero, which this scheme never uses (its a_i enters with weight 1 - gamma = 0).
- Solve: the linear model takes one exact linear solve per step (skipped when the residual of
  v_{i+1} = v_i is below Drake's absolute tolerance, 1e-6 N); the nonlinear ones Newton with
  conjugate gradients, stopped at a residual of 1e-2 times the first (Drake's default
  relative tolerance, not settable from Python; the SPEC asks 1e-10), or 1e-6 N.

Material models (Drake's MaterialModel; the SPEC's Lame constants mu, lambda of E, nu):
- `linear` (kLinear): small-strain elasticity, sigma = 2 mu eps + lambda tr(eps) I, for the
  linear export.
- `corotated` (kCorotated, fixed corotated of Stomakhin et al. 2012): psi = mu |F - R|^2 +
  (lambda/2)(J - 1)^2, small-strain limit (mu, lambda); for the neo-Hookean and corotational
  exports (the SPEC's corotational has lambda/2 tr(S - I)^2 for the volume term).
- `linear-corotated` (kLinearCorotated, Han et al. 2023, Drake's default and recommended
  model): linear elasticity on the strain sym(R_i^T F) - I with R_i the rotation of each
  element at the start of the step, a linear solve per step: the SPEC's corotational with
  its rotation lagged by one step; for the neo-Hookean and corotational exports.
- `neo-hookean` (kNeoHookean, the stable neo-Hookean of Smith et al. 2018, eq. 13):
  psi = (mu_D/2)(I_C - 3) - mu_D (J - 1) + (lambda_D/2)(J - 1)^2, whose small-strain Lame
  constants are (mu_D, lambda_D - mu_D), read from Drake's neohookean_model.cc and measured
  (below). Drake sets (mu_D, lambda_D) from the config's (E, nu) as the Lame constants, so a
  user passing MP3's E = 7000 Pa, nu = 0.2 gets a material of E = 4375 Pa, nu = -0.25 at small
  strain (rod n = 2, damped to rest: tip 1.33 x the linear one; linear elasticity with
  E = 4375, nu = -0.25: 1.29 x). Posed here with E_D, nu_D chosen so that mu_D = mu,
  lambda_D = lambda + mu (MP3: E_D = 7656.25 Pa, nu_D = 0.3125; tip then 1.037 x the linear
  one, the corotated 1.028 x: geometric nonlinearity); for the neo-Hookean export, whose
  energy (mu/2)(J^(-2/3) I_1 - 3) + (kappa/2)(J - 1)^2 has the same small-strain limit.

A run diverges as SPEC sections 3 and 8 say, checked at every t_i: a displacement not finite or
beyond 100 x the largest extent, for a nonlinear export an inverted tetrahedron (J <= 0), or
Drake's Newton not converging (it raises); NaN from there on, status "failed".

Departures measured (Drake 1.58.0, rod MP3, h = 1/30 s, 300 steps; E_n = |u' - u| / |u| over
all nodal components, time mean (max) over t_1..t_300, the max at the first steps, where |u|
is small; P1 = a trapezoidal Newmark with consistent mass and C = alpha M + beta K on the same
tetrahedra, written in tests/test_external_drake.py, which also reproduces Drake's linear run
to 7e-13 on n = 3 when given its mass and scheme):

                                                         n = 3           n = 6
    integrator: Drake's Newmark vs trapezoidal (P1)     0.0058 (0.061)  0.0057 (0.055)
    mass: one-point vs consistent (P1, trapezoidal)     0.0027 (0.034)  0.0007 (0.0087)
    both: Drake linear vs the P1                        0.0038 (0.032)  0.0051 (0.047)
    the tetrahedra: the P1 vs our `implicit` (Q1)       0.142 (0.215)   0.047 (0.075)
    Drake linear vs our `implicit` (Q1)                 0.144 (0.214)   0.051 (0.074)

So the tetrahedra (stiffer in bending than the hexahedra) are nearly all of Drake's distance
from the reference; its first-order scheme costs about 0.6 % (time mean) on top and does not
shrink with the mesh (halving h halves it: the tests); its mass about 0.3 % on n = 3, shrinking
with the mesh. Wall time (2 shared cores, 1.5 to 2 x slower when busy): linear 1.0 s on
n = 3 (our `implicit` 0.17 s), 24 s on n = 6 (ours 0.5 s), 4 to 6.5 s a step on n = 12
(12675 unknowns; Drake orders and factors its matrix afresh every step), so 20 to 30 min for
300 steps: n = 12 was run for the first second only (E_n 0.024 (0.050) against 0.037 (0.048) on
n = 3 over that second: the first-order scheme's error stays). Rod at load scale 3 against
`implicit+neo-hookean` (Q1; ours 4.1 s on n = 3, 22 s on n = 6), E_n on n = 3 / n = 6:
neo-hookean 0.075 (0.138) / 0.053 (0.095), 3.2 s / 32 s; corotated 0.094 (0.168) / 0.059
(0.084), 6.2 s / 44 s; linear-corotated 0.102 (0.180) / 0.066 (0.096), 0.9 s / 18 s.
At load scale 0.01 the neo-Hookean stays within 6e-4 (E_n max) of the linear P1 on
Drake's own scheme and mass: its loose Newton tolerance costs less than that there.

The contact benchmark (SPEC 12) is posed by its adapter, contact/drake.py (a one-element slab, u_z
projected to zero after each step, the needle a rigid body on a prismatic joint).

Not posed: the 2D block with its glued needle (a one-layer slab needs u_z held on every node
with x and y free, and Drake's boundary conditions hold a vertex in every direction; its
needle's prescribed motion has no counterpart either), moving constrained sets, and the
static procedure (Drake steps its deformable bodies in time only).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators.newton import conforming, split_hexahedra, tet_volumes

if TYPE_CHECKING:
    from tissuebench.solvers.materials import Material
    from tissuebench.workflows.io.exported import Exported

NAME = "drake"


def _version() -> str:
    """Drake's installed version, without importing it ("" when absent)."""
    return installed_version("drake")


TITLE = f"Drake {_version()}".strip()
SERIES = "drake.xdmf"
MESH_FILE = "rod.vtk"
FIELD = "displacement"
MESH = "tetrahedra, 6 per hexahedron, on the reference's nodes"
DIVERGED = 100.0  # SPEC section 3: a nodal displacement beyond 100 x the largest extent
NONLINEAR_EXPORTS = ("neo-hookean", "corotational")
SCHEME = "Drake's Newmark gamma = 1, beta = 1/2 (first order), one step of h"

# name -> (Drake's MaterialModel member, the export models it poses, one-line description)
VARIANTS = {
    "linear": (
        "kLinear",
        ("linear",),
        f"kLinear P1 tetrahedra (6 per hex), one-point mass rho V/16, D = alpha M + beta K; "
        f"{SCHEME}",
    ),
    "corotated": (
        "kCorotated",
        NONLINEAR_EXPORTS,
        f"kCorotated (fixed corotated, Stomakhin 2012) P1 tetrahedra, one-point mass, "
        f"D = alpha M + beta K(u); {SCHEME}, Newton to a 1e-2 relative residual",
    ),
    "linear-corotated": (
        "kLinearCorotated",
        NONLINEAR_EXPORTS,
        f"kLinearCorotated (Drake's default: rotation lagged one step) P1 tetrahedra, "
        f"one-point mass, D = alpha M + beta K; {SCHEME}",
    ),
    "neo-hookean": (
        "kNeoHookean",
        ("neo-hookean",),
        f"kNeoHookean (stable neo-Hookean, Smith 2018) P1 tetrahedra with E, nu mapped to "
        f"mu_D = mu, lambda_D = lambda + mu, one-point mass, D = alpha M + beta K(u); "
        f"{SCHEME}, Newton to a 1e-2 relative residual",
    ),
}


def available() -> str | None:
    """None when Drake (pydrake) can be imported here, else what to install."""
    try:
        import pydrake.multibody.plant  # noqa: F401
    except ImportError as err:
        return f"Drake is not installed ({err}): pip install drake"
    return None


def wall(data: Exported) -> tuple[np.ndarray, np.ndarray] | None:
    """(point Q (m), outward normal n) of an axis-aligned plane whose open half-space
    n . (x - Q) < 0 holds exactly the export's constrained nodes, halfway between them and the
    nearest other node along n; None when the constrained sets move or no such plane exists."""
    if any(np.any(np.asarray(x) != 0) for motion in data.motions.values() for x in motion):
        return None
    sets = [np.asarray(s, dtype=np.int64) for s in data.effective_sets().values()]
    held = np.unique(np.concatenate(sets)) if sets else np.zeros(0, dtype=np.int64)
    if len(held) == 0 or len(held) == len(data.nodes) or data.dim != 3:
        return None
    free = np.setdiff1d(np.arange(len(data.nodes)), held)
    for axis in range(3):
        for sign in (1.0, -1.0):
            values = sign * data.nodes[:, axis]
            inside, outside = values[held].max(), values[free].min()
            if inside < outside:
                point = np.zeros(3)
                point[axis] = sign * (inside + outside) / 2.0
                normal = np.zeros(3)
                normal[axis] = sign
                return point, normal
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose this export, name -> one line: `linear` for the linear model,
    the nonlinear ones for the neo-Hookean (and, but `neo-hookean`, the corotational) model;
    none for the static procedure, 2D, or constrained nodes that no wall holds."""
    if data.procedure != "dynamic" or data.dim != 3 or data.cell_type != "hexahedron":
        return {}
    if wall(data) is None:
        return {}
    return {
        name: f"{spec[2]}; {elastic_words(data.material, name)}"
        for name, spec in VARIANTS.items()
        if data.model in spec[1]
    }


def elastic_words(material: Material, variant: str) -> str:
    """How the variant's DeformableBodyConfig takes the export's E and nu, with values."""
    E, nu = drake_elasticity(material, variant)
    if variant != "neo-hookean":
        return f"set_youngs_modulus, set_poissons_ratio: the export's {given(material)}"
    return f"E_D = {E:.6g} Pa, nu_D = {nu:.6g} of the export's {given(material)}"


def skipped(data: Exported) -> dict[str, str]:
    """What is not posed of this export and why ({} when some variant poses it)."""
    if data.procedure != "dynamic":
        return {"all": "Drake steps its deformable bodies in time only: no static procedure"}
    if data.dim != 3 or data.cell_type != "hexahedron":
        return {"all": "Drake's boundary conditions hold a vertex in every direction: a "
                "one-layer slab of a 2D benchmark cannot hold only its z motion"}  # fmt: skip
    if wall(data) is None:
        return {"all": "the constrained nodes move or no plane cuts them off: Drake's wall "
                "boundary condition holds a fixed half-space only"}  # fmt: skip
    if not variants(data):
        return {"all": f"no Drake material model is posed for the {data.model} model"}
    return {}


# --- the posed body ---------------------------------------------------------------------------


def drake_elasticity(material: Material, variant: str) -> tuple[float, float]:
    """(E in Pa, nu) for Drake's DeformableBodyConfig: the export's, except for `neo-hookean`,
    whose Drake energy has the small-strain Lame constants (mu_D, lambda_D - mu_D): there
    mu_D = mu, lambda_D = lambda + mu (module docstring)."""
    if variant != "neo-hookean":
        return float(material.E), float(material.nu)
    mu, lam = material.mu, material.lmbda + material.mu
    nu = lam / (2.0 * (lam + mu))
    return 2.0 * mu * (1.0 + nu), nu


def write_vtk(path: Path, nodes: np.ndarray, tets: np.ndarray) -> None:
    """A legacy ASCII .vtk unstructured grid of tetrahedra (VTK cell type 10): nodes (N, 3) m
    with 17 significant digits, tets (T, 4) as given."""
    lines = ["# vtk DataFile Version 3.0", "tissuebench", "ASCII", "DATASET UNSTRUCTURED_GRID"]
    lines.append(f"POINTS {len(nodes)} double")
    lines += [" ".join(f"{v:.17g}" for v in x) for x in nodes]
    lines.append(f"CELLS {len(tets)} {5 * len(tets)}")
    lines += ["4 " + " ".join(str(int(i)) for i in t) for t in tets]
    lines.append(f"CELL_TYPES {len(tets)}")
    lines += ["10"] * len(tets)
    Path(path).write_text("\n".join(lines) + "\n")


def build(data: Exported, variant: str, mesh_file: Path):
    """The posed rod in Drake (module docstring): (simulator, plant context, deformable model,
    body id, rest positions (N, 3) m)."""
    from pydrake.geometry import GeometryInstance, Mesh, ProximityProperties
    from pydrake.math import RigidTransform
    from pydrake.multibody.fem import DeformableBodyConfig, MaterialModel
    from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
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
    config.set_material_model(getattr(MaterialModel, VARIANTS[variant][0]))

    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(MultibodyPlantConfig(time_step=float(data.h)), builder)
    geometry = GeometryInstance(RigidTransform(), Mesh(str(mesh_file)), "body")
    geometry.set_proximity_properties(ProximityProperties())  # Drake's driver asks for it
    model = plant.mutable_deformable_model()
    body = model.RegisterDeformableBody(geometry, config, 1.0)  # the hint is for primitives
    found = wall(data)
    assert found is not None  # variants() offers none where no wall holds the nodes
    point, normal = found
    model.SetWallBoundaryCondition(body, point, normal)
    plant.mutable_gravity_field().set_gravity_vector(np.asarray(data.gravity, dtype=float))
    plant.Finalize()
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    plant_context = plant.GetMyContextFromRoot(context)
    rest = model.GetPositions(plant_context, body).T.copy()
    simulator = Simulator(diagram, context)
    simulator.Initialize()
    return simulator, plant_context, model, body, rest


def simulate(data: Exported, variant: str, workdir: Path, steps: int | None = None) -> dict:
    """Run variant on the export in workdir (its .vtk mesh goes there): {"U": (steps + 1, N, 3)
    m with NaN from a divergence on, "tets", "diverged" (step or None), "reason",
    "wall_time_s"}: s, from building the plant (reading the .vtk and the FEM model included)
    to the last step."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown Drake variant {variant!r}: use one of {', '.join(VARIANTS)}")
    steps = data.steps if steps is None else steps
    nodes = np.asarray(data.nodes, dtype=np.float64)
    tets = split_hexahedra(nodes, data.cells)
    mesh_file = Path(workdir) / MESH_FILE
    write_vtk(mesh_file, nodes, tets)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    nonlinear = data.model != "linear"  # SPEC section 8: an inverted element diverges
    start = time.perf_counter()
    simulator, context, model, body, rest = build(data, variant, mesh_file)
    if not np.array_equal(rest, nodes):  # Drake must keep the export's vertex order
        raise RuntimeError("Drake's reference positions are not the export's nodes")
    U = np.full((steps + 1, len(nodes), 3), np.nan)
    U[0] = 0.0
    diverged, reason = None, None
    for i in range(1, steps + 1):
        try:
            simulator.AdvanceTo(i * data.h)
        except Exception as err:  # Drake's Newton failing to converge: a divergence
            first = (str(err).strip().splitlines() or [""])[0]
            diverged, reason = i, f"Drake raised {type(err).__name__}: {first}"[:300]
            break
        taken = simulator.get_num_unrestricted_updates() + simulator.get_num_discrete_updates()
        if taken != i:  # the plant's step is an update event, one per time_step
            raise RuntimeError(f"Drake took {taken} steps to t_{i}")
        u = model.GetPositions(context, body).T - rest
        if not np.all(np.isfinite(u)):
            diverged, reason = i, "a displacement is not finite"
        elif np.linalg.norm(u, axis=1).max() > DIVERGED * extent:
            diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
        elif nonlinear:
            J = tet_volumes(nodes + u, tets) / volumes
            if J.min() <= 0:
                diverged, reason = i, f"{int(np.sum(J <= 0))} tetrahedra inverted"
        if diverged is not None:
            break
        U[i] = u
    wall_time = time.perf_counter() - start
    return {
        "U": U,
        "tets": tets,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": wall_time,
    }


def not_run(dofs: int, reason: str) -> ExternalRun:
    """A variant that stopped before writing a series, with why."""
    return ExternalRun(
        None, None, dofs, mesh=MESH, status="failed", reason=reason, version=_version()
    )


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in workdir and write drake.xdmf there: the displacement
    (vertex position - reference position, m) on the tetrahedra at every t_i = i h; NaN from a
    divergence on (status "failed")."""
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    dofs = 3 * len(nodes)
    if variant not in variants(data):
        return not_run(
            dofs,
            f"Drake variant {variant!r} does not pose this export "
            f"(posed: {', '.join(variants(data)) or 'none'})",
        )
    if not conforming(split_hexahedra(nodes, data.cells), data.cells):
        return not_run(dofs, "the six-tetrahedra split of these hexahedra does not conform")
    try:
        result = simulate(data, variant, workdir)
    except Exception as err:  # Drake refusing the model: a failed run, not a crash
        first = (str(err).strip().splitlines() or [""])[0]
        return not_run(dofs, f"Drake raised {type(err).__name__}: {first}"[:300])
    path = workdir / SERIES
    write_series(path, ((nodes, result["tets"], "tetrahedron"), {FIELD: result["U"]}), data.times)
    return integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h,
        f"time.perf_counter from building Drake's plant (reading the .vtk, the FEM model) "
        f"to the last of {data.steps} steps, in process; writing the .vtk excluded",
        _version(),
    )  # fmt: skip
