"""Newton (newton-physics, built on NVIDIA Warp): today's GPU-class soft-body solvers, run on
the CPU, posing the rod as a Newton user would.

The posed problem (SPEC sections 1, 3, 5)
-----------------------------------------
- Mesh: every exported hexahedron split into six tetrahedra around its 0-6 diagonal (VTK
  order), (0, 6, a, b) for (a, b) consecutive in the ring 1-2-3-7-4-5; each hexahedron's
  corners are first renumbered by octant about its centre, so that all cells share one
  orientation and the split conforms (checked: no interior face is cut two ways). Same nodes
  as the reference: its nodal displacements compare one to one. Each tetrahedron is oriented
  to a positive volume (Newton drops inverted ones).
- Mass: Newton's own lumping, density rho * (tet volume) / 4 to each corner (`add_soft_mesh`;
  the spring variants add the same masses by hand); total rho * volume. The clamped nodes get
  mass 0: Newton's kinematic particles, which no solver moves.
- Gravity: the export's vector (m/s^2) as the model's gravity, up axis along it; contact kept
  out (particle radius 1e-4 m against edges of 0.08 m; no collision pipeline; the
  semi-implicit solver's triangle contact and particle grid off).
- Rayleigh damping C = alpha M + beta K_0 (SPEC section 2):
  - alpha M: Newton has no mass-proportional damping for particles; before every substep each
    particle gets the external force -alpha m v (explicit in the substep, alpha dt <= 1/300).
  - beta K_0: each element's own viscosity, matched to the linear viscous shear stress
    2 beta mu eps_dot of beta K_0 (the volumetric part then differs, as said per solver).

Newton's elastic models, linearised about the rest state (read from the installed kernels)
-------------------------------------------------------------------------------------------
- `SolverVBD` (vertex block descent, implicit Euler): stable neo-Hookean of Smith et al.
  2018, psi = (k_mu / 2)(I_1 - 3) + (lambda_nh / 2)(J - 1 - k_mu / lambda_nh)^2 with
  lambda_nh = k_lambda + k_mu: the Lame constants as they are (k_mu = mu, k_lambda = lambda).
  Damping k_damp * d/dt (F^T F) (objective), stress 4 k_damp eps_dot at small strain, so
  k_damp = beta mu / 2 (Pa s); its bulk viscosity is then (2/3) beta mu, half of MP3's
  beta kappa. A fixed iteration count leaves each step unconverged, so the rest state VBD
  settles to depends on its step (rod n = 2, one step of h x 10 iterations, measured: static
  tip within 4 % of the P1 one for h <= 0.1 s, 41 % too low at h = 0.25 s, 3.2 x at 0.5 s).
- `SolverSemiImplicit` (symplectic Euler): P = k_mu F (1 - 1/(I_C + 1)) + k_lambda
  (J - 1 - 3 k_mu / (4 k_lambda)) cof F, whose small-strain limit is mu = 3 k_mu / 4,
  lambda = k_lambda - 5 k_mu / 8: so k_mu = 4 mu / 3, k_lambda = lambda + 5 mu / 6.
  Damping k_damp (F_dot + J_dot cof F), stress k_damp (eps_dot + omega + tr(eps_dot) I), so
  k_damp = 2 beta mu (bulk viscosity twice MP3's); the skew part omega damps the elements'
  spin, which beta K_0 does not (non-objective): a bending rod sags far too slowly with it.
- `SolverXPBD`: two constraints per tetrahedron, C_dev = I_1 - 3 (compliance
  1 / (k_mu V)) and C_vol = J - 1 (1 / (k_lambda V)), with k_mu = mu, k_lambda = lambda and
  k_damp = beta mu / 2 as for VBD. C_dev is 2 tr(eps) + O(|grad u|^2): the constraint has no
  small-strain shear stiffness at all, so the rod hangs down (below) whatever the iterations
  and substeps (20 x 20 as 10 x 2); with Newton's defaults (2 iterations, one step of h) it
  collapses: 49 tetrahedra inverted at t = 0.4 s.
- Springs on every edge of the tetrahedra: k_e = E * sum over the tets t holding e of
  V_t / L_e^2 (N/m), the 3D form of Van Gelder's rule (1998): in the orientation average of
  a tetrahedron's six edges it gives Young's modulus E exactly, with nu = 1/4 (a central-force
  network's Cauchy value; MP3 has 0.2); damping k_d = beta k_e (N s/m), beta K_0 exactly for
  the linearised network. No volume term: tetrahedra can invert.

Newton users substep within h: each variant's substeps and iterations are in its one-line
description; the output is the state at every t_i = i h. Newton computes in float32
(positions to 3e-8 m on the rod). A run diverges as SPEC sections 3 and 8 say, checked at
every t_i: a displacement not finite or beyond 100 x the largest extent, or an inverted
tetrahedron (J <= 0); NaN from there on, status "failed".

Measured (Newton 1.8.0, Warp 1.19.0 on 2 shared CPU cores), rod MP3, n = 3, h = 1/30 s,
300 steps: E_n time mean (max) against `implicit` (linear) / `implicit+neo-hookean` at load
scale 3, and wall time per simulated second (our `implicit`: 0.012 s, `implicit+neo-hookean`
0.6 s):

    vbd            0.155 (0.22) / 0.076 (0.14)   1.9-2.3 s
    vbd-1          0.164 (0.96) / 0.085 (0.96)   0.18-0.32 s (max: the first steps)
    semi-implicit  0.322 (0.43) / 0.254 (0.36)   0.07-0.08 s (k_damp = 0: 0.152 (0.22))
    xpbd           1.14  (2.1)  / 0.68  (0.90)   1.4-1.5 s (tip 0.34 m down, not 0.12)
    springs        0.215 (0.29) / diverged at t = 4.1 s (inverted)   0.02-0.04 s
    xpbd-springs   0.216 (0.29) / diverged at t = 4.1 s (inverted)   0.5-1.4 s

The tetrahedra alone (linear P1 on the same split, our trapezoidal Newmark) stand at 0.142
(0.21) from the linear hexahedral reference: they are stiffer in bending (static tip 0.69 of
Q1's on n = 2, 0.80 on n = 3). Warp's warm-up (kernel compilation, excluded from the wall
time): 13-45 s per solver with a cold cache, 4-7 s from its cache (module hashing).

The contact benchmark (SPEC 12) is posed by its adapter, contact/newton.py (a one-element slab, u_z
projected to zero after each substep, the needle a kinematic body).

Not posed (variants() is empty): the 2D block with its glued needle (its plane-strain slab
would need u_z held on every node with x and y free, and a Newton particle is either
kinematic in all components or free: no per-component constraint), moving constrained sets
(none in 3D today), and the static procedure (Newton integrates in time only).
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given, installed_version, integrated

NAME = "newton"


def _version() -> str:
    """Newton's installed version, without importing it ("" when absent)."""
    return installed_version("newton")


TITLE = f"Newton {_version()}".strip()

PARTICLE_RADIUS = 1e-4  # m: contact radius, far below the edges, so that contact stays out
DIVERGED = 100.0  # SPEC section 3: a nodal displacement beyond 100 x the largest extent
MESH = "tetrahedra, 6 per hexahedron, on the reference's nodes"
FIELD = "displacement"

# six tetrahedra around the 0-6 diagonal of a VTK hexahedron: (0, 6, a, b), (a, b)
# consecutive in the ring 1-2-3-7-4-5 of the six other corners
HEX_TETS = ((0, 6, 1, 2), (0, 6, 2, 3), (0, 6, 3, 7), (0, 6, 7, 4), (0, 6, 4, 5), (0, 6, 5, 1))
# the six quadrilateral faces of a VTK hexahedron
HEX_FACES = ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7))
# VTK corner k of a hexahedron by its octant about the centre: (x, y, z) above the centre
OCTANT_CORNER = {
    (0, 0, 0): 0,
    (1, 0, 0): 1,
    (1, 1, 0): 2,
    (0, 1, 0): 3,
    (0, 0, 1): 4,
    (1, 0, 1): 5,
    (1, 1, 1): 6,
    (0, 1, 1): 7,
}

# name -> (solver, element, substeps per h, iterations per substep, one-line description)
VARIANTS = {
    "vbd": (
        "vbd",
        "tets",
        10,
        10,
        "SolverVBD (vertex block descent, implicit Euler), 10 substeps of h/10 x 10 iterations "
        "(Newton's example settings); stable neo-Hookean, k_mu = mu, k_lambda = lambda, "
        "k_damp = beta mu/2",
    ),
    "vbd-1": (
        "vbd",
        "tets",
        1,
        10,
        "SolverVBD, one step of h x 10 iterations (the real-time budget); stable "
        "neo-Hookean, k_mu = mu, k_lambda = lambda, k_damp = beta mu/2",
    ),
    "semi-implicit": (
        "semi-implicit",
        "tets",
        10,
        0,
        "SolverSemiImplicit (symplectic Euler), 10 substeps of h/10 (stable from 3 on rod "
        "MP3, n = 3); neo-Hookean of Smith et al., k_mu = 4mu/3, k_lambda = lambda + 5mu/6, "
        "k_damp = 2 beta mu",
    ),
    "xpbd": (
        "xpbd",
        "tets",
        10,
        10,
        "SolverXPBD, 10 substeps of h/10 x 10 iterations, relaxation 0.9; tetrahedral "
        "constraints I_1 - 3 and J - 1, k_mu = mu, k_lambda = lambda, k_damp = beta mu/2 "
        "(no small-strain shear stiffness)",
    ),
    "springs": (
        "semi-implicit",
        "springs",
        10,
        0,
        "mass-spring network on every tetrahedron edge, k = E sum(V_tet)/L^2, k_d = beta k; "
        "SolverSemiImplicit, 10 substeps of h/10",
    ),
    "xpbd-springs": (
        "xpbd",
        "springs",
        10,
        10,
        "mass-spring network on every tetrahedron edge, k = E sum(V_tet)/L^2, k_d = beta k; "
        "SolverXPBD distance constraints, 10 substeps of h/10 x 10 iterations",
    ),
}


def available() -> str | None:
    """None when Newton (and Warp) can be imported here, else what to install."""
    try:
        import newton  # noqa: F401
        import warp  # noqa: F401
    except ImportError as err:
        return f"Newton is not installed ({err}): pip install newton"
    return None


def variants(data) -> dict[str, str]:
    """The variants that pose this export, name -> one line; empty for the static procedure,
    for 2D exports and for moving constrained sets (module docstring); a contact export's
    variants are its adapter's (contact/newton.py)."""
    if data.procedure != "dynamic" or data.dim != 3 or data.cell_type != "hexahedron":
        return {}
    if any(np.any(np.abs(np.asarray(x)) > 0) for motion in data.motions.values() for x in motion):
        return {}
    return {
        name: f"{spec[4]}; {elastic_words(data.material, name)}" for name, spec in VARIANTS.items()
    }


def elastic_words(material, variant: str) -> str:
    """How the variant takes the export's E and nu, with values (module docstring)."""
    solver, element = VARIANTS[variant][:2]
    if element == "springs":
        return (
            f"k from E = {material.E:g} Pa; the network's nu is 1/4 whatever the export's "
            f"(nu = {material.nu:g} is not posed)"
        )
    k_mu, k_lambda, k_damp = tet_parameters(material, solver)
    return (
        f"k_mu = {k_mu:.5g} Pa, k_lambda = {k_lambda:.5g} Pa, k_damp = {k_damp:.5g} Pa s of the "
        f"export's {given(material)}"
    )


def skipped(data) -> dict[str, str]:
    """Why no variant poses this export, when none does."""
    if data.procedure != "dynamic":
        return {"all": "Newton steps dynamics only; the static procedure has no counterpart"}
    if data.dim != 3 or data.cell_type != "hexahedron":
        return {"all": "a Newton particle is fixed in every direction or free: a one-layer slab "
                "of a 2D benchmark cannot hold only its z motion"}  # fmt: skip
    if not variants(data):
        return {"all": "a moving constrained set has no counterpart in Newton's particles"}
    return {}


# --- the mesh ---------------------------------------------------------------------------------


def canonical_hexahedra(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The hexahedra (VTK order) with their corners renumbered by octant about each cell's
    centre, so that every cell of a grid-like mesh has one orientation; a cell whose corners
    do not fill the eight octants keeps its order."""
    out = np.array(cells, dtype=np.int64)
    for c, cell in enumerate(out):
        x = nodes[cell]
        octants = (x > x.mean(axis=0)).astype(int)
        slots = [OCTANT_CORNER[tuple(o)] for o in octants]
        if sorted(slots) == list(range(8)):
            renumbered = np.empty(8, dtype=np.int64)
            renumbered[slots] = cell
            out[c] = renumbered
    return out


def tet_volumes(nodes: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Signed volumes (m^3) of tetrahedra (T, 4) on nodes (N, 3)."""
    a, b, c, d = (nodes[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", np.cross(b - a, c - a), d - a) / 6.0


def cone_split(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Six positively oriented tetrahedra (T = 6 C, 4) per hexahedron (C, 8), VTK order, that
    conform on any hexahedral mesh, where split_hexahedra's need not (the cylinder's O-grid,
    whose blocks are turned against each other): each cell coned from its lowest-numbered
    corner over the three faces away from it, each face cut along the diagonal through its own
    lowest-numbered corner, so that both cells beside a face cut it alike. Exact for convex
    cells (star-shaped from that corner)."""
    nodes = np.asarray(nodes, dtype=np.float64)
    cells = np.asarray(cells, dtype=np.int64)
    faces = cells[:, np.array(HEX_FACES)]  # (C, 6, 4)
    apex = cells.min(axis=1)
    away = ~np.any(faces == apex[:, None, None], axis=2)  # (C, 6): 3 faces per cell
    far = faces[away].reshape(len(cells), 3, 4)
    first = np.argmin(far, axis=2)  # the face's lowest corner: its diagonal's end
    turned = np.take_along_axis(far, (first[..., None] + np.arange(4)) % 4, axis=2)
    triangles = np.stack([turned[..., [0, 1, 2]], turned[..., [0, 2, 3]]], axis=2)
    triangles = triangles.reshape(len(cells), 6, 3)
    tets = np.concatenate([np.repeat(apex, 6)[:, None], triangles.reshape(-1, 3)], axis=1)
    negative = tet_volumes(nodes, tets) < 0
    tets[negative] = tets[negative][:, [0, 1, 3, 2]]
    return tets


def split_hexahedra(nodes: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Six positively oriented tetrahedra (T = 6 C, 4) per hexahedron (C, 8), VTK order, around
    each cell's 0-6 diagonal after canonical_hexahedra."""
    hexes = canonical_hexahedra(nodes, cells)
    tets = hexes[:, np.array(HEX_TETS)].reshape(-1, 4)
    negative = tet_volumes(nodes, tets) < 0
    tets[negative] = tets[negative][:, [0, 1, 3, 2]]
    return tets


def conforming(tets: np.ndarray, cells: np.ndarray) -> bool:
    """Whether the tetrahedra conform: no face held by more than two, and the faces held by one
    are exactly two per boundary quadrilateral of the hexahedra (a quadrilateral between two
    cells cut along different diagonals leaves four more)."""
    faces = np.sort(tets[:, [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]]].reshape(-1, 3), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    quads = np.asarray(cells)[:, HEX_FACES].reshape(-1, 4)
    _, quad_counts = np.unique(np.sort(quads, axis=1), axis=0, return_counts=True)
    boundary = int(np.sum(quad_counts == 1))
    return bool(counts.max() <= 2) and int(np.sum(counts == 1)) == 2 * boundary


def lumped_masses(nodes: np.ndarray, tets: np.ndarray, rho: float) -> np.ndarray:
    """Particle masses (kg) as add_soft_mesh lumps them: rho V_t / 4 to each corner."""
    masses = np.zeros(len(nodes))
    np.add.at(masses, tets.ravel(), np.repeat(rho * tet_volumes(nodes, tets) / 4.0, 4))
    return masses


def spring_network(nodes: np.ndarray, tets: np.ndarray, E: float) -> tuple[np.ndarray, np.ndarray]:
    """Every edge of the tetrahedra (S, 2) and its stiffness k_e = E sum(V_t) / L_e^2 (N/m), the
    sum over the tetrahedra holding the edge."""
    pairs = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])
    edges = np.sort(tets[:, pairs].reshape(-1, 2), axis=1)
    volumes = np.repeat(tet_volumes(nodes, tets), len(pairs))
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    shares = np.zeros(len(unique))
    np.add.at(shares, inverse.ravel(), volumes)
    lengths2 = np.sum((nodes[unique[:, 0]] - nodes[unique[:, 1]]) ** 2, axis=1)
    return unique, E * shares / lengths2


def tet_parameters(material, solver: str) -> tuple[float, float, float]:
    """(k_mu, k_lambda, k_damp) in (Pa, Pa, Pa s) for Newton's tetrahedra under solver
    ("vbd", "semi-implicit", "xpbd"): see the module docstring."""
    mu, lam, beta = material.mu, material.lmbda, material.beta
    if solver == "semi-implicit":
        return 4.0 * mu / 3.0, lam + 5.0 * mu / 6.0, 2.0 * beta * mu
    return mu, lam, beta * mu / 2.0


# --- Newton -----------------------------------------------------------------------------------


@contextlib.contextmanager
def _stderr_silenced():
    """File descriptor 2 to /dev/null (Warp's native CUDA probe prints there at init)."""
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _import_newton():
    """(warp, newton), Warp initialised quietly on its default kernel cache."""
    import warp as wp

    if hasattr(wp.config, "log_level"):  # Warp >= 1.10: the logger replaces config.quiet
        wp.config.log_level = wp.LOG_WARNING
    else:
        wp.config.quiet = True
    with _stderr_silenced():
        wp.init()
    import newton

    return wp, newton


def _builder(data, variant: str, tets: np.ndarray):
    """A ModelBuilder holding the posed rod for variant (not yet finalised)."""
    wp, newton = _import_newton()
    solver, element = VARIANTS[variant][:2]
    m = data.material
    gravity = np.zeros(3)
    gravity[: data.dim] = data.gravity
    up = "xyz"[int(np.argmax(np.abs(gravity)))] if np.any(gravity) else "y"
    builder = newton.ModelBuilder(up_axis=up, gravity=tuple(float(g) for g in gravity))
    nodes = np.asarray(data.nodes, dtype=np.float64)
    if element == "tets":
        k_mu, k_lambda, k_damp = tet_parameters(m, solver)
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
    else:
        masses = lumped_masses(nodes, tets, m.rho)
        builder.add_particles(
            pos=[wp.vec3(*x) for x in nodes],
            vel=[wp.vec3(0.0, 0.0, 0.0)] * len(nodes),
            mass=masses.tolist(),
            radius=[PARTICLE_RADIUS] * len(nodes),
        )
        edges, stiffness = spring_network(nodes, tets, m.E)
        for (i, j), k in zip(edges, stiffness, strict=True):
            builder.add_spring(int(i), int(j), float(k), float(m.beta * k), 0.0)
    for sets in data.effective_sets().values():
        for i in sets:
            builder.particle_mass[int(i)] = 0.0  # kinematic: the clamped face
    return builder


def _solver(newton, model, variant: str):
    """Newton's solver of variant on model."""
    solver, _, _, iterations, _ = VARIANTS[variant]
    if solver == "vbd":
        model.particle_grid = None
        return newton.solvers.SolverVBD(model, iterations=iterations)
    if solver == "xpbd":  # keeps the particle grid: its particle contact asserts one
        return newton.solvers.SolverXPBD(model, iterations=iterations)
    model.particle_grid = None
    return newton.solvers.SolverSemiImplicit(model, enable_tri_contact=False)


def _integrate(data, variant: str, builder, tets: np.ndarray, steps: int):
    """Finalise builder on the CPU and step it: (U (steps + 1, N, 3) m with NaN from a
    divergence on, the step it diverged at or None, the reason, wall time s). A step diverges
    as SPEC sections 3 and 8 say: a displacement not finite or beyond 100 x the domain's
    largest extent, or an inverted tetrahedron (J <= 0), checked at every t_i."""
    wp, newton = _import_newton()
    nodes = np.asarray(data.nodes, dtype=np.float64)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    volumes = tet_volumes(nodes, tets)
    substeps = VARIANTS[variant][2]
    alpha = data.material.alpha
    dt = data.h / substeps
    start = time.perf_counter()
    if VARIANTS[variant][0] == "vbd":
        builder.color()
    model = builder.finalize(device="cpu")
    solver = _solver(newton, model, variant)
    states = model.state(), model.state()
    control = model.control()
    mass = model.particle_mass.numpy().astype(np.float64)[:, None]
    rest = model.particle_q.numpy().astype(np.float64)
    U = np.full((steps + 1, len(rest), 3), np.nan)
    U[0] = 0.0
    diverged, reason = None, None
    for i in range(1, steps + 1):
        for _ in range(substeps):
            state_in, state_out = states
            # alpha M: the mass-proportional Rayleigh force, explicit over the substep
            force = state_in.particle_f.numpy()  # on the CPU, a view of Warp's array
            force[:] = -alpha * mass * state_in.particle_qd.numpy()
            solver.step(state_in, state_out, control, None, dt)
            states = state_out, state_in
        U[i] = states[0].particle_q.numpy() - rest
        if not np.all(np.isfinite(U[i])):
            diverged, reason = i, "a displacement is not finite"
        elif np.linalg.norm(U[i], axis=1).max() > DIVERGED * extent:
            diverged, reason = i, f"a displacement exceeds {DIVERGED:g} x the domain's extent"
        else:
            J = tet_volumes(nodes + U[i], tets) / volumes
            if J.min() <= 0:
                inverted = int(np.sum(J <= 0))
                diverged, reason = i, f"{inverted} tetrahedra inverted (J down to {J.min():.3g})"
        if diverged is not None:
            U[i] = np.nan
            break
    wall = time.perf_counter() - start
    return U, diverged, reason, wall


def simulate(data, variant: str, steps: int | None = None) -> dict:
    """Run variant on the export: {"U": (steps + 1, N, 3) m, "tets", "diverged" (step or None),
    "reason", "wall_time_s", "compile_s"}. A warm-up of one step of h compiles Warp's
    kernels (or loads them from its cache) first; wall_time_s is then measured from the
    finalisation of the posed model (VBD's colouring included) to the last step, compile time
    excluded."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown Newton variant {variant!r}: use one of {', '.join(VARIANTS)}")
    steps = data.steps if steps is None else steps
    nodes = np.asarray(data.nodes, dtype=np.float64)
    tets = split_hexahedra(nodes, data.cells)
    start = time.perf_counter()
    _integrate(data, variant, _builder(data, variant, tets), tets, 1)
    compile_s = time.perf_counter() - start
    U, diverged, reason, wall = _integrate(
        data, variant, _builder(data, variant, tets), tets, steps
    )
    return {
        "U": U,
        "tets": tets,
        "diverged": diverged,
        "reason": reason,
        "wall_time_s": wall,
        "compile_s": compile_s,
    }


def not_run(dofs: int, reason: str) -> ExternalRun:
    """A variant that stopped before writing a series, with why."""
    return ExternalRun(
        None, None, dofs, mesh=MESH, status="failed", reason=reason, version=_version()
    )


def run(data, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant serially in workdir and write newton.xdmf there: the displacement
    (particle position - rest position, m) on the tetrahedra at every t_i = i h; NaN from a
    divergence on (status "failed")."""
    from tissuebench.workflows.io.xdmf import write_series

    workdir = Path(workdir)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    dofs = 3 * len(nodes)
    if variant not in variants(data):
        return not_run(
            dofs,
            f"Newton variant {variant!r} does not pose this export "
            f"(posed: {', '.join(variants(data)) or 'none'})",
        )
    tets = split_hexahedra(nodes, data.cells)
    if not conforming(tets, data.cells):
        return not_run(dofs, "the six-tetrahedra split of these hexahedra does not conform")
    try:
        result = simulate(data, variant)
    except Exception as err:  # Newton or Warp refusing the model: a failed run, not a crash
        first = (str(err).splitlines() or [""])[0]
        return not_run(dofs, f"Newton raised {type(err).__name__}: {first}")
    path = workdir / "newton.xdmf"
    points = np.zeros((len(nodes), 3))
    points[:, : data.dim] = nodes
    write_series(path, ((points, result["tets"], "tetrahedron"), {FIELD: result["U"]}), data.times)
    substeps = VARIANTS[variant][2]
    timing = (
        f"time.perf_counter from Newton's model finalisation (VBD's graph colouring included) "
        f"to the last of {data.steps} steps x {substeps} substeps, Warp on the CPU, float32; "
        f"kernel compilation (or cache load) excluded, done in a warm-up step: "
        f"{result['compile_s']:.1f} s"
    )
    return integrated(
        path, result["wall_time_s"], dofs, FIELD, MESH, result["diverged"], result["reason"],
        data.h, timing, _version(),
    )  # fmt: skip
