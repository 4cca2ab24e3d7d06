"""Kratos Multiphysics (StructuralMechanicsApplication) as an outside simulator: the rod and
the block posed as a Kratos user would, with its small-displacement solid elements and its
implicit dynamic solver, run in a child Python process (its own OpenMP, logger and global
state; one thread).

The posed problem (SPEC sections 1-5)
-------------------------------------
- Mesh: the exported nodes (Kratos node i + 1 is node i). The rod: either the exported
  hexahedra as `SmallDisplacementElement3D8N` (Q1, 2x2x2 Gauss: our own grid and element,
  compared node for node with our `implicit`) or each hexahedron split into six tetrahedra
  exactly as newton.py splits it (`split_hexahedra`, imported) as
  `SmallDisplacementElement3D4N` (P1). The block: the exported quadrilaterals as
  `SmallDisplacementElement2D4N` (Q1, 2x2 Gauss), THICKNESS 1 m, in 2D (domain_size 2): no
  slab needed.
- Material: `LinearElastic3DLaw` (3D), `LinearElasticPlaneStrain2DLaw` or
  `LinearElasticPlaneStress2DLaw` (2D, as the export says) with E, nu, rho.
- Mass: Kratos's consistent mass by default (checked on one tetrahedron: rho V / 20 (1 +
  delta_ij), exactly P1's; the hexahedra's 2x2x2 Gauss is exact for Q1); the `-lumped`
  variant sets COMPUTE_LUMPED_MASS_MATRIX on the properties, which gives V / 8 (V / 4) to each
  corner: the SPEC's row-sum M_L on these cells. Kratos's element damping is then alpha M_L +
  beta K: the SPEC's `implicit-lumped`.
- Damping: the solver's `rayleigh_alpha` = alpha, `rayleigh_beta` = beta: C = alpha M + beta K
  element by element, K the linear stiffness (K_0): the SPEC's form exactly.
- Gravity: VOLUME_ACCELERATION on every node (the element's body force rho g, integrated with
  its shape functions).
- Constrained sets (a node follows the last set that names it): DISPLACEMENT fixed, and set to
  the prescribed u at t_i before each step's prediction. Kratos's scheme derives a fixed
  dof's VELOCITY and ACCELERATION from its u by the Newmark formulas (for the needle's ramp
  under the trapezoidal rule: v alternating 0, 2 g', 0, ...), so the prescribed v and a are
  set after the prediction (the free rows then get the SPEC's M_fc a_c + C_fc v_c) and again
  after the solve (the state the next step starts from).
- Solver: "Dynamic", `analysis_type` "linear" (ResidualBasedLinearStrategy: one solve per
  step, the matrix built and factorised every step), LinearSolversApplication's sparse_lu
  (Eigen's SparseLU: the fastest direct solver Kratos finds in these wheels, which have no
  Pardiso, so its default too), `move_mesh_flag` false.
- Schemes (StructuralMechanicsBossakScheme): `newmark` is alpha_m = 0, beta = 1/4, gamma = 1/2,
  the trapezoidal rule of the SPEC's `implicit`; `bossak` is Kratos's default dynamic scheme,
  alpha_m = -0.3, so beta = (1 - alpha_m)^2 / 4 = 0.4225, gamma = 1/2 - alpha_m = 0.8 (second
  order, unconditionally stable, spectral radius (1 + alpha_m) / (1 - alpha_m) = 0.54 at
  infinite frequency: it damps the high modes the trapezoidal rule keeps).
- Time: the loop steps t by Kratos's AdvanceInTime (a running sum: 300 steps of 1/30 s end at
  9.99999999999998 s; Kratos's AnalysisStage runs `while time < end_time`, so an end time of
  T takes 301 steps, checked, and a project file must say T - h/2). Here the loop runs exactly
  `steps` steps and the output is the displacement at every t_i = i h.

Departures from the SPEC, measured (largest nodal difference over the largest displacement,
unless E_n / E_i is said; tests/test_external_kratos.py checks the identities)
-------------------------------------------------------------------------------------------
- Initial acceleration: Kratos alone starts from a_0 = 0, not from the equation of motion at
  t = 0 as the SPEC decides (checked: on the rod its u_1 is exactly half ours, h^2/4 S^-1 f
  against h^2/2 S^-1 f with S = M + hC/2 + h^2 K/4). Posed here: before the first step the
  child solves M_ff a_f = f_f - K_fc u_c - C_fc v_c - M_fc a_c with Kratos's own element
  mass, damping and stiffness matrices and right-hand sides (sparse LU) and sets
  ACCELERATION. Left out (SPEC_INITIAL_ACCELERATION = False), the rod lacks the velocity
  h a_0 / 2 throughout: 3.2 % over the first second on n = 3, 0.62 % over 10 s, 6.7e-5 at
  t = 10 s (alpha = 1/s damps it); the block MP1 N = 20: 0.30 % (the needle's C_fc v_c).
- The needle's v and a: left to Kratos (SPEC_CONSTRAINED_RATES = False), the block MP1 N = 20
  departs by 0.49 % over 10 s (0.35 % before the needle stops at t = 2 s); both left to
  Kratos, 0.49 %.
- With both set, `hex8-newmark` and `quad4-newmark` are our `implicit` to round-off (E_n max
  1.8e-14 on the rod n = 3, 8.3e-15 on the block N = 20) and the `-lumped` variants our
  `implicit-lumped` (6e-15 relative, rod n = 2 and block N = 4): no departure left.
- `bossak`: its dissipation and alpha_m-weighted inertia (checked against an independent
  Bossak-Newmark solve to round-off): E_n max 0.018, E_i max 3.4e-7 against `implicit` on
  the rod n = 3 over 10 s; 0.072 and 1.2e-6 on the block MP1 N = 20.
- `tet4`: the P1 element on the same nodes, stiffer in bending than Q1 (static tip 0.69 of
  Q1's on n = 2, 0.80 on n = 3, newton.py): E_n max 0.215, E_i max 1.2e-3 against our Q1
  `implicit` on n = 3; against a dense P1 trapezoidal (and Bossak) solve on the same
  tetrahedra it is round-off.
- `-lumped`: M_L for M, in the inertia and in alpha M: E_n max 0.072 against `implicit` on
  the rod n = 3, 0.119 on the block MP1 N = 20 (what our `implicit-lumped` departs by).

Measured (Kratos 10.4.4 on 2 shared CPU cores, at nice 10 beside other jobs), rod MP3, h = 1/30 s,
T = 10 s, 300 steps (`tissuebench external kratos rod --mesh-size n`): E_n max / E_i max
against our `implicit` on the same nodes, and wall time per simulated second (our `implicit`
reference in the same runs: 0.013, 0.046 and 0.48 s at n = 3, 6, 12):

    variant              n = 3 (336 dofs)         n = 6 (1,911 dofs)       n = 12 (12,675 dofs)
    hex8-newmark         1.3e-14 / 6.9e-17 0.48 s 4.3e-14 / 2.5e-16 4.6 s  2.4e-13 / 1.4e-15 111 s
    hex8-newmark-lumped  0.072 / 9.0e-5    0.39 s 0.027 / 2.4e-5    2.9 s  not run
    hex8-bossak          0.018 / 3.4e-7    0.63 s 0.021 / 3.3e-7    3.8 s  not run
    tet4-newmark         0.215 / 1.2e-3    0.32 s 0.075 / 4.4e-4    3.1 s  0.022 / 1.3e-4    42 s
    tet4-bossak          0.215 / 1.2e-3    0.30 s 0.075 / 4.4e-4    2.9 s  not run

Against the truth rod (SPEC 10, `tissuebench compare truth:rod`), E_n max / E_i max at n = 3, 6,
12: hex8-newmark 0.095 / 4.4e-4, 0.022 / 1.4e-4, 0.0060 / 3.7e-5 (our implicit's, being the
same numbers); tet4-newmark 0.26 / 1.6e-3, 0.093 / 5.6e-4, 0.027 / 1.7e-4 (P1 converges to the
same limit about one refinement behind Q1).

Kratos's cost per step is its assembly and a fresh SparseLU factorisation (COLAMD ordering) of
the 3D system at every step: at n = 12 the hexahedra took 18 minutes here (the tetrahedra 7),
so only the trapezoidal hexahedra and tetrahedra were run there.

The rod's neo-hookean and svk (SPEC 8): TotalLagrangian elements, Kratos's hyperelastic laws
and its Newton loop, kratos_nonlinear.py (Kratos's neo-Hookean is the ln J form, not the
SPEC's). Not posed: the static procedure, the other models.

A run diverges as SPEC section 3 says (a displacement not finite or beyond 100 x the largest
extent, checked at every t_i): NaN from there on, status "failed". Kratos raising (a singular
system, a refused setting) or its child process dying is "failed" with its last error line.
"""

from __future__ import annotations

import os
import sys
import time
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated
from tissuebench.workflows.simulators import kratos_nonlinear as kn

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

NAME = "kratos"
# The contact benchmark (SPEC 12) is not posed (no contact adapter): why, in one line.
CONTACT_NOTE = (
    "not posed yet: Kratos's contact is its ContactStructuralMechanicsApplication (PyPI wheel "
    "10.4.4 for cp312, installed and imported here: mortar penalty and ALM frictionless "
    "contact between two meshed bodies), which needs the needle meshed as a body whose nodes "
    "all follow c(t), both surfaces as line conditions, and the contact solver and process in "
    "this runner's child script; not written in the session that posed the others"
)


def _version() -> str:
    """Kratos's installed version, without importing it ("" when absent)."""
    return installed_version("KratosMultiphysics")


TITLE = f"Kratos {_version()}".strip()
FIELD = "displacement"
SERIES = "kratos.xdmf"
DIVERGED = 100.0  # SPEC section 3: a nodal displacement beyond 100 x the largest extent
TIMEOUT = 3600.0  # s: a child run beyond this is stopped and recorded as failed
BOSSAK_ALPHA_M = -0.3  # Kratos's default damp_factor_m
# set the SPEC's a_0 (M a_0 = f) before the first step; False: Kratos's own a_0 = 0
SPEC_INITIAL_ACCELERATION = True
# set the constrained nodes' prescribed v and a every step; False: Kratos's own, derived from
# the prescribed u by the scheme's Newmark formulas
SPEC_CONSTRAINED_RATES = True
MESHES = {
    "hex8": ("SmallDisplacementElement3D8N", "reference"),
    "tet4": (
        "SmallDisplacementElement3D4N",
        "tetrahedra, 6 per hexahedron, on the reference's nodes",
    ),
    "quad4": ("SmallDisplacementElement2D4N", "reference"),
}
SCHEMES = {  # scheme name -> (Kratos scheme_type, damp_factor_m, how the description says it)
    "newmark": ("newmark", 0.0, "newmark beta = 1/4, gamma = 1/2 (trapezoidal)"),
    "bossak": (
        "bossak",
        BOSSAK_ALPHA_M,
        "bossak alpha_m = -0.3 (beta = 0.4225, gamma = 0.8: dissipative, rho_inf = 0.54)",
    ),
}
ELEMENTS = {  # element key -> what the description says of it
    "hex8": "SmallDisplacementElement3D8N (Q1) on our hexahedra",
    "tet4": "SmallDisplacementElement3D4N (P1) on 6 tetrahedra per hexahedron",
    "quad4": "SmallDisplacementElement2D4N (Q1) on our quadrilaterals",
}


def _variant(element: str, scheme: str, lumped: bool) -> tuple:
    """(element key, scheme_type, damp_factor_m, lumped, one-line description)."""
    kind, damp, said = SCHEMES[scheme]
    mass = (
        "lumped mass (COMPUTE_LUMPED_MASS_MATRIX: the row sums; C = alpha M_L + beta K)"
        if lumped
        else "consistent mass"
    )
    exact = ": our implicit" if scheme == "newmark" and element != "tet4" else ""
    exact = ": our implicit-lumped" if exact and lumped else exact
    return (element, kind, damp, lumped, f"{ELEMENTS[element]}, {mass}, {said}{exact}; "
            "the SPEC's a_0 set")  # fmt: skip


# name -> (element key, scheme_type, damp_factor_m, lumped mass, one-line description)
VARIANTS = {
    f"{element}-{scheme}{'-lumped' if lumped else ''}": _variant(element, scheme, lumped)
    for element, scheme, lumped in (
        ("hex8", "newmark", False),
        ("hex8", "newmark", True),
        ("hex8", "bossak", False),
        ("tet4", "newmark", False),
        ("tet4", "bossak", False),
        ("quad4", "newmark", False),
        ("quad4", "newmark", True),
        ("quad4", "bossak", False),
    )
}


def available() -> str | None:
    """None when Kratos and its two applications are installed here, else what to install."""
    for package in (
        "KratosMultiphysics",
        "KratosStructuralMechanicsApplication",
        "KratosLinearSolversApplication",
        "scipy",  # the SPEC's a_0: a sparse solve with Kratos's element matrices
    ):
        try:
            metadata.version(package)
        except metadata.PackageNotFoundError:
            return (
                f"{package} is not installed: pip install KratosMultiphysics "
                "KratosStructuralMechanicsApplication KratosLinearSolversApplication scipy"
            )
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose this export, name -> one line: hex8 and tet4 for the 3D
    hexahedral export, quad4 for the 2D quadrilateral one (plane strain or stress), each for
    the linear model's dynamic procedure; none for a contact export (CONTACT_NOTE)."""
    if data.contact is not None:
        return {}
    if data.procedure != "dynamic" or data.model not in ("linear", *kn.LAWS):
        return {}
    if data.model in kn.LAWS:
        return {} if kn.skipped(data, VARIANTS).get("all") else kn.variants(data, VARIANTS)
    element = {"hexahedron": ("hex8", "tet4"), "quadrilateral": ("quad4",)}.get(data.cell_type, ())
    elastic = f"YOUNG_MODULUS, POISSON_RATIO: the export's {given(data.material)}"
    return {name: f"{spec[4]}; {elastic}" for name, spec in VARIANTS.items() if spec[0] in element}


def skipped(data: Exported) -> dict[str, str]:
    """Why no variant poses this export, when none does (module docstring)."""
    if data.contact is not None:
        return {"all": CONTACT_NOTE}
    if data.procedure != "dynamic":
        return {"all": "posed here with Kratos's dynamic solver only; the static procedure is not"}
    if data.model in kn.LAWS:
        return kn.skipped(data, VARIANTS)
    if data.model != "linear":
        return {"all": f"the {data.model} model is not posed in Kratos here (linear, "
                f"{', '.join(kn.LAWS)} only)"}  # fmt: skip
    if not variants(data):
        return {"all": f"no Kratos element posed here for {data.cell_type} cells"}
    return {}


# --- the posed problem, handed to the child -----------------------------------------------------


def posed_mesh(data: Exported, variant: str) -> tuple[np.ndarray, str]:
    """(cells as node indices, cell type) of variant: the exported cells, or newton.py's
    six-tetrahedra split of the hexahedra."""
    from tissuebench.workflows.simulators.newton import split_hexahedra

    if VARIANTS[variant][0] != "tet4":
        return np.asarray(data.cells, dtype=np.int64), data.cell_type
    return split_hexahedra(np.asarray(data.nodes, dtype=np.float64), data.cells), "tetrahedron"


def constrained(data: Exported) -> tuple[np.ndarray, np.ndarray]:
    """(constrained nodes (K,), their prescribed motion (steps + 1, K, 3, d): u m, v m/s,
    a m/s^2 at every t_i), each node following the last set that names it (SPEC section 3)."""
    owner: dict[int, str] = {}
    for name, nodes in data.effective_sets().items():
        for i in np.asarray(nodes, dtype=np.int64):
            owner[int(i)] = name
    nodes = np.array(sorted(owner), dtype=np.int64)
    motion = np.zeros((data.steps + 1, len(nodes), 3, data.dim))
    for k, i in enumerate(nodes):
        motion[:, k] = np.stack([np.asarray(x) for x in data.motions[owner[int(i)]]], axis=1)
    return nodes, motion


def write_input(
    data: Exported,
    variant: str,
    path: Path,
    cells: np.ndarray,
    initial_acceleration_set: bool = True,
    rates_set: bool = True,
) -> None:
    """The posed problem as an .npz for the child (SI units); initial_acceleration_set False
    leaves Kratos's own a_0 = 0, rates_set False Kratos's own v and a on the constrained nodes
    (the measured departures)."""
    element_key, scheme, damp, lumped, _ = VARIANTS[variant]
    m = data.material
    nodes = np.asarray(data.nodes, dtype=np.float64)
    fixed, motion = constrained(data)
    law, element, newton = "LinearElastic3DLaw", MESHES[element_key][0], [0.0, 0.0, 0.0]
    if data.model in kn.LAWS:  # rtol, atol (N), iterations: kratos_nonlinear.py
        law, element = kn.LAWS[data.model][0], kn.ELEMENTS[element_key]
        floor = kn.newton_floor(nodes, np.asarray(cells), m.E, m.nu)
        newton = [kn.NEWTON_RTOL, floor, float(kn.NEWTON_MAX_IT)]
    elif data.dim == 2:
        law = "LinearElasticPlaneStress2DLaw" if data.plane == "stress" else (
            "LinearElasticPlaneStrain2DLaw")  # fmt: skip
    np.savez(
        path,
        nodes=nodes,
        cells=cells,
        element=element,
        law=law,
        newton=np.array(newton),
        clamped=fixed,
        motion=motion,
        gravity=np.asarray(data.gravity, dtype=np.float64),
        material=np.array([m.E, m.nu, m.rho, m.alpha, m.beta]),
        h=data.h,
        steps=data.steps,
        scheme=scheme,
        damp_factor_m=damp,
        lumped=lumped,
        initial_acceleration=initial_acceleration_set,
        rates=rates_set,
        limit=DIVERGED * float(np.max(nodes.max(axis=0) - nodes.min(axis=0))),
    )


def initial_acceleration(part, n_nodes: int, dim: int, fixed: np.ndarray, motion0: np.ndarray):
    """The SPEC's a_0 (N, dim) m/s^2: on the free dofs, M_ff a_f = f_f - K_fc u_c - C_fc v_c -
    M_fc a_c with u = v = 0 there and the constrained dofs at their prescribed state motion0
    (K, 3, dim) at t = 0, from Kratos's own element matrices (mass consistent or lumped as the
    properties say, damping alpha M + beta K, stiffness) and right-hand sides at u = 0 (the
    body force); a sparse LU solve. Kratos alone would start from a_0 = 0."""
    import KratosMultiphysics as KM
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla  # imported by simulate before its clock starts

    info = part.ProcessInfo
    n = dim * n_nodes
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    values: dict[str, list[np.ndarray]] = {"M": [], "C": [], "K": []}
    f = np.zeros(n)
    A_e, f_e = KM.Matrix(), KM.Vector()
    for element in part.Elements:
        dofs = np.array(
            [dim * (node.Id - 1) + k for node in element.GetNodes() for k in range(dim)]
        )
        rows.append(np.repeat(dofs, len(dofs)))
        cols.append(np.tile(dofs, len(dofs)))
        element.CalculateMassMatrix(A_e, info)
        values["M"].append(np.array(A_e).ravel())
        element.CalculateDampingMatrix(A_e, info)
        values["C"].append(np.array(A_e).ravel())
        element.CalculateLocalSystem(A_e, f_e, info)  # at u = 0: K and the body force
        values["K"].append(np.array(A_e).ravel())
        np.add.at(f, dofs, np.array(f_e))
    index = (np.concatenate(rows), np.concatenate(cols))
    M, C, K = (sp.csr_matrix((np.concatenate(values[x]), index), shape=(n, n)) for x in "MCK")
    fixed_dofs = (dim * np.asarray(fixed, dtype=np.int64)[:, None] + np.arange(dim)).ravel()
    free = np.setdiff1d(np.arange(n), fixed_dofs)
    u_c, v_c, a_c = (motion0[:, j, :].ravel() for j in range(3))
    rhs = f - K[:, fixed_dofs] @ u_c - C[:, fixed_dofs] @ v_c - M[:, fixed_dofs] @ a_c
    a0 = np.zeros(n)
    a0[fixed_dofs] = a_c
    a0[free] = spla.spsolve(M[free][:, free].tocsc(), rhs[free])
    return a0.reshape(-1, dim)


def simulate(source: Path, target: Path) -> None:
    """The child's work: read the posed problem (source .npz), run Kratos on one thread, write
    target .npz with U (steps + 1, N, 3) m (NaN from a divergence on), diverged (step or -1),
    reason, wall_time_s (s: from the model's creation to the last step).

    Constrained nodes: DISPLACEMENT fixed and set to the prescribed u before each step's
    prediction; their VELOCITY and ACCELERATION, which Kratos's scheme derives from u by its
    Newmark formulas, are set to the prescribed v and a after the prediction (so that the
    free equations get M_fc a_c + C_fc v_c of the SPEC) and again after the solve (the state
    the next step starts from)."""
    os.environ["OMP_NUM_THREADS"] = "1"
    import KratosMultiphysics as KM
    import KratosMultiphysics.LinearSolversApplication  # noqa: F401 (sparse_lu)
    import KratosMultiphysics.StructuralMechanicsApplication as SMA
    import scipy.sparse.linalg  # noqa: F401 (initial_acceleration's, outside the clock)
    from KratosMultiphysics.StructuralMechanicsApplication import (
        python_solvers_wrapper_structural as wrapper,
    )

    KM.Logger.GetDefaultOutput().SetSeverity(KM.Logger.Severity.WARNING)
    KM.ParallelUtilities.SetNumThreads(1)
    p = np.load(source)
    nodes, cells, fixed, motion = p["nodes"], p["cells"], p["clamped"], p["motion"]
    dim = nodes.shape[1]
    E, nu, rho, alpha, beta = (float(x) for x in p["material"])
    h, steps, limit = float(p["h"]), int(p["steps"]), float(p["limit"])
    settings = KM.Parameters(
        """{
        "solver_type": "Dynamic", "model_part_name": "Structure", "domain_size": 3,
        "echo_level": 0, "analysis_type": "linear", "time_integration_method": "implicit",
        "move_mesh_flag": false, "compute_reactions": false,
        "model_import_settings": {"input_type": "use_input_model_part"},
        "material_import_settings": {"materials_filename": ""},
        "time_stepping": {"time_step": 1.0},
        "linear_solver_settings": {"solver_type": "LinearSolversApplication.sparse_lu"}
        }"""
    )
    settings["domain_size"].SetInt(dim)
    rtol, atol, iterations = (float(x) for x in p["newton"])
    if rtol > 0:  # a nonlinear model: Newton (kratos_nonlinear.py)
        import KratosMultiphysics.ConstitutiveLawsApplication as laws

        settings["analysis_type"].SetString("non_linear")
        settings["move_mesh_flag"].SetBool(True)  # the TL elements' F reads x = X + u
        settings.AddEmptyValue("convergence_criterion").SetString("residual_criterion")
        settings.AddEmptyValue("residual_relative_tolerance").SetDouble(rtol)
        settings.AddEmptyValue("residual_absolute_tolerance").SetDouble(atol)
        settings.AddEmptyValue("max_iteration").SetInt(int(iterations))
    settings["time_stepping"]["time_step"].SetDouble(h)
    settings.AddEmptyValue("scheme_type").SetString(str(p["scheme"]))
    settings.AddEmptyValue("damp_factor_m").SetDouble(float(p["damp_factor_m"]))
    settings.AddEmptyValue("newmark_beta").SetDouble(0.25)
    settings.AddEmptyValue("rayleigh_alpha").SetDouble(alpha)
    settings.AddEmptyValue("rayleigh_beta").SetDouble(beta)

    start = time.perf_counter()
    model = KM.Model()
    part = model.CreateModelPart("Structure")
    part.ProcessInfo[KM.DOMAIN_SIZE] = dim
    solver = wrapper.CreateSolverByParameters(model, settings, "OpenMP")
    solver.AddVariables()
    for i, x in enumerate(nodes):
        z = float(x[2]) if dim == 3 else 0.0
        part.CreateNewNode(i + 1, float(x[0]), float(x[1]), z)
    props = part.GetProperties()[1]
    props.SetValue(KM.YOUNG_MODULUS, E)
    props.SetValue(KM.POISSON_RATIO, nu)
    props.SetValue(KM.DENSITY, rho)
    props.SetValue(KM.THICKNESS, 1.0)  # 2D: per metre of depth, as the SPEC's plane problems
    props.SetValue(KM.COMPUTE_LUMPED_MASS_MATRIX, bool(p["lumped"]))
    props.SetValue(KM.CONSTITUTIVE_LAW, getattr(laws if rtol > 0 else SMA, str(p["law"]))())
    element = str(p["element"])
    for c, cell in enumerate(cells):
        part.CreateNewElement(element, c + 1, [int(k) + 1 for k in cell], props)
    solver.ImportModelPart()
    solver.PrepareModelPart()
    solver.AddDofs()
    gravity = [float(g) for g in p["gravity"]] + [0.0] * (3 - dim)
    for node in part.Nodes:
        node.SetSolutionStepValue(KM.VOLUME_ACCELERATION, gravity)
    components = (KM.DISPLACEMENT_X, KM.DISPLACEMENT_Y, KM.DISPLACEMENT_Z)[:dim]
    held = [part.GetNode(int(i) + 1) for i in fixed]
    for node in held:
        for var in components:
            node.Fix(var)
    solver.Initialize()
    solver.Check()

    def prescribe(i: int, which: tuple) -> None:
        """Set the constrained nodes' variables `which` (indices into u, v, a) to step i."""
        for node, values in zip(held, motion[i], strict=True):
            for j in which:
                vector = [float(x) for x in values[j]] + [0.0] * (3 - dim)
                node.SetSolutionStepValue(
                    (KM.DISPLACEMENT, KM.VELOCITY, KM.ACCELERATION)[j], vector
                )

    rates = (1, 2) if bool(p["rates"]) else ()
    prescribe(0, (0, *rates))
    if bool(p["initial_acceleration"]):
        a0 = initial_acceleration(part, len(nodes), dim, fixed, motion[0])
        for node in part.Nodes:
            node.SetSolutionStepValue(KM.ACCELERATION, list(a0[node.Id - 1]) + [0.0] * (3 - dim))

    U = np.full((steps + 1, len(nodes), 3), np.nan)
    U[0] = 0.0
    U[0, fixed, :dim] = motion[0, :, 0]
    diverged, reason = -1, ""
    read = KM.VariableUtils()
    t = 0.0
    for i in range(1, steps + 1):
        t = solver.AdvanceInTime(t)
        solver.InitializeSolutionStep()
        prescribe(i, (0,))
        solver.Predict()
        prescribe(i, rates)
        converged = solver.SolveSolutionStep()
        prescribe(i, rates)
        solver.FinalizeSolutionStep()
        u = np.array(read.GetSolutionStepValuesVector(part.Nodes, KM.DISPLACEMENT, 0, 3))
        u = u.reshape(-1, 3)
        if not converged:
            diverged, reason = i, f"Newton did not converge in {int(iterations)} iterations"
        elif not np.all(np.isfinite(u)):
            diverged, reason = i, "a displacement is not finite"
        elif np.linalg.norm(u, axis=1).max() > limit:
            diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
        if diverged > 0:
            break
        U[i] = u
    wall = time.perf_counter() - start
    np.savez(target, U=U, diverged=diverged, reason=reason, wall_time_s=wall)


def not_run(dofs: int, reason: str, mesh: str = "reference") -> ExternalRun:
    """A variant that stopped before writing a series, with why."""
    return ExternalRun(
        None, None, dofs, mesh=mesh, status="failed", reason=reason, version=_version()
    )


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in a child process (OMP_NUM_THREADS=1) in workdir and write
    kratos.xdmf there: the displacement (m) on the variant's cells at every t_i = i h, NaN
    from a divergence on (status "failed")."""
    from tissuebench.core import interrupt
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    dofs = nodes.size
    if variant not in variants(data):
        return not_run(
            dofs,
            f"Kratos variant {variant!r} does not pose this export "
            f"(posed: {', '.join(variants(data)) or 'none'})",
        )
    mesh = MESHES[VARIANTS[variant][0]][1]
    cells, cell_type = posed_mesh(data, variant)
    if cell_type == "tetrahedron":
        from tissuebench.workflows.simulators.newton import conforming

        if not conforming(cells, data.cells):
            return not_run(
                dofs, "the six-tetrahedra split of these hexahedra does not conform", mesh
            )
    source, target = workdir / "kratos_input.npz", workdir / "kratos_output.npz"
    write_input(data, variant, source, cells, SPEC_INITIAL_ACCELERATION, SPEC_CONSTRAINED_RATES)
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    command = [
        sys.executable,
        "-m",
        "tissuebench.workflows.simulators.kratos",
        str(source),
        str(target),
    ]
    done = interrupt.run_child(command, TIMEOUT, cwd=workdir, env=env)
    if done is None:
        return not_run(dofs, f"Kratos ran over {TIMEOUT:g} s", mesh)
    (workdir / "kratos.log").write_text(done.stdout + done.stderr)
    if done.returncode != 0 or not target.is_file():
        lines = [line.strip() for line in (done.stderr or done.stdout).splitlines() if line.strip()]
        errors = [line for line in lines if "Error" in line or "error" in line]
        why = (errors or lines or [f"exit status {done.returncode}"])[0]
        return not_run(dofs, f"Kratos failed: {why}"[:300], mesh)
    result = np.load(target)
    U, diverged = result["U"], int(result["diverged"])
    path = workdir / SERIES
    points = np.zeros((len(nodes), 3))
    points[:, : data.dim] = nodes
    write_series(path, ((points, cells, cell_type), {FIELD: U}), data.times)
    return integrated(
        path, float(result["wall_time_s"]), dofs, FIELD, mesh, diverged if diverged > 0 else None,
        result["reason"], data.h,
        "time.perf_counter in a child process, 1 thread, from the Kratos model's creation "
        "to the last step (assembly and a sparse LU at every step); interpreter start and "
        "Kratos's import excluded",
        _version(),
    )  # fmt: skip


if __name__ == "__main__":
    simulate(Path(sys.argv[1]), Path(sys.argv[2]))
