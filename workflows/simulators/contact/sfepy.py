"""SfePy poses the contact benchmark (SPEC 12: the rigid half-stadium needle in frictionless
contact with the block's right edge) with its own rigid contact terms, `dw_contact_sphere`
and `dw_contact_plane` (sfepy/terms/terms_surface.py), integrated by its ts.newmark.

What SfePy 2026.3 offers, and how it is used (read from its sources):

- both terms are penalty terms: the pressure f(d) = k <d> (Pa, f_0 = 0) along the body's
  normal, d the penetration (m), so k is a stiffness per area (Pa/m), the meaning of SPEC
  12's k: here k = kappa E / h_e of the export's `contact.penalty` (kappa = 10 by default);
  their residual and their exact tangent enter SfePy's Newton;
- both are 3D only (their `geometries` are 3_4 and 3_8, their normals 3-vectors), and there
  is no cylinder term: the block is posed as a one-element-thick slab of hexahedra (the
  export's quadrilaterals extruded by SLAB m), with u_z = 0 at every node. Its in-plane
  motion is that of the export's 2D Q1 plane strain problem (2x2x2 Gauss is exact for the
  z-constant fields; the slab's two faces are loaded alike and move alike);
- the disc of the needle is SfePy's sphere, of radius R centred on the slab's mid-plane: on
  the slab's facet quadrature points, at most dz = SLAB/2 from that plane, its section is a
  circle of radius sqrt(R^2 - dz^2), at most dz^2 / (2 R) = 1.25e-8 m smaller than R.
  Measured: with SLAB = 1e-3 m, E_i against our implicit was 100 times larger than with
  1e-4 m (1e-7 against 1e-9 m^2 at N = 8), so this section is what remains of the slab;
- the flanks y = 0.5 +- R (x >= c_x) are SfePy's planes. A plane term selects its points by
  their undeformed position (its bounding polygon is in the plane's own coordinates, here x
  and z, and every point of the right edge has X = 1), and a sphere by its deformed position
  within the whole sphere; neither can say "x >= c_x" of the deformed point, which the
  half-stadium needs (otherwise the plane y = 0.6 would push every point below it, and the
  sphere and a flank would both push the points just right of c_x). So each term is given
  its contact body (the object it builds once from its material and keeps, `term.cs` or
  `term.cp`): a subclass of SfePy's own ContactSphere / ContactPlane whose point selection
  adds the half-stadium's split by the deformed position: the disc acts where x < c_x, the
  upper flank where x >= c_x and y >= c_y, the lower one where x >= c_x and y < c_y. The
  force, its normal, the penetration and the tangent stay SfePy's;
- the needle moves: before each step the bodies are moved to c(t_{n+1}) (the export's
  `contact.motion.c`, by step index);
- time stepping as sfepy.py's "newmark" (ts.newmark, beta = 1/4, gamma = 1/2, consistent
  mass, Rayleigh damping C = alpha M + beta K), now nonlinear: Newton on the step's
  acceleration with the contact tangent, SfePy's backtracking line search, converged when
  the residual drops by 1e-10 or below ATOL_SCALE x K's largest diagonal x the extent (N, as
  ours); a step that does not converge in NEWTON_STEPS iterations ends the run as failed.

The needle force per unit thickness (N/m) is the sum of the contact terms' nodal forces at
the solution (their residual vector: the force the tissue exerts on the needle), divided by
SLAB; the interpenetration is the largest -g_n over the deformed right edge, sampled at 9
points on each edge between two nodes (as ours).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.meshes.tools import from_shape
from tissuebench.workflows.simulators import ExternalRun, given

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

SLAB = 1e-4  # m, the thickness of the one-element slab in which SfePy's 3D terms act
NEWTON_STEPS = 50  # Newton iterations allowed per step
# Newton's absolute tolerance (N): ATOL_SCALE x the slab's K's largest diagonal x the block's
# extent, as ours (solvers/nonlinear.py), below which round-off, not Newton, decides
ATOL_SCALE = 1e-13
SAMPLES = 9  # points per deformed edge where the interpenetration is sampled
FORCE = "sfepy-force.csv"
DEPTH = "sfepy-interpenetration.csv"
VARIANTS = {
    "newmark": "ts.newmark, beta = 1/4, gamma = 1/2 (trapezoidal rule, implicit), consistent "
    "mass, Newton with the contact tangent and a line search",
}


def tool(data: Exported) -> dict:
    """The export's `contact` block (ValueError for an export without one)."""
    if data.contact is None:
        raise ValueError("not a contact export: it has no `contact` block (SPEC 12)")
    return data.contact


def check(data: Exported) -> str | None:
    """Why SfePy cannot pose this contact export (None: it can)."""
    shape = (data.contact or {}).get("shape", {})
    if shape.get("kind") != "half-stadium":
        return f"SfePy's terms pose a half-stadium needle only, not {shape.get('kind')!r}"
    if data.dim != 2 or data.cell_type != "quadrilateral" or (data.plane or "strain") != "strain":
        return "SfePy's slab extrudes a 2D plane strain mesh of quadrilaterals only"
    if data.model != "linear":
        return (
            f"the {data.model} model is not posed in SfePy here: its contact terms are of "
            "small deformation, and sfepy.py poses the linear model only"
        )
    if data.procedure != "dynamic":
        return "SfePy's elastodynamics steppers pose the dynamic procedure only"
    if any(any(np.any(x != 0.0) for x in m) for m in data.motions.values()):
        return "a contact export's constrained sets are fixed: this one moves a set"
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose this contact export (none for another model or procedure)."""
    if check(data) is not None:
        return {}
    pen = tool(data)["penalty"]
    return {
        name: f"{words}; SfePy's dw_contact_sphere (the disc) and dw_contact_plane (the "
        f"flanks), their bodies split at x = c_x by the deformed position, penalty k = kappa "
        f"E / h_e = {pen['kappa']:g} x {data.material.E:g} / {pen['h_e']:.4g} = {pen['k']:.6g} "
        f"Pa/m (f_0 = 0), on a {SLAB:g} m slab with u_z = 0; D = stiffness_from_youngpoisson "
        f"(3D, plane strain by u_z = 0) of the export's {given(data.material)}"
        for name, words in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """What SfePy does not pose of this contact export, and why."""
    why = check(data)
    if why is not None:
        return {"all": why}
    explicit = (
        "not posed here: the penalty stiffness lowers an explicit scheme's critical step, "
        "and sub-stepping SfePy's explicit steppers (SPEC 11) is not implemented"
    )
    other = "not posed on contact here: only ts.newmark is run with the contact terms"
    return {
        "central-difference": explicit,
        "central-difference-lumped": explicit,
        "velocity-verlet": explicit,
        "generalized-alpha": other,
        "bathe": other,
    }


def slab(nodes: np.ndarray, cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 2D mesh (nodes (N, 2) m, quadrilaterals (C, 4) VTK order) extruded into one layer
    of hexahedra of thickness SLAB: nodes (2N, 3), node i at z = 0 and i + N at z = SLAB."""
    n = len(nodes)
    points = np.vstack([np.c_[nodes, np.zeros(n)], np.c_[nodes, np.full(n, SLAB)]]).astype(
        np.float64
    )
    return np.ascontiguousarray(points), np.ascontiguousarray(
        np.hstack([cells, cells + n]), dtype=np.int32
    )


def bodies():
    """The half-stadium's three contact bodies, subclasses of SfePy's ContactSphere and
    ContactPlane that select their points by the deformed position (see the module)."""
    from sfepy.mechanics.contact_bodies import ContactPlane, ContactSphere

    class Disc(ContactSphere):
        """SfePy's sphere acting where the deformed point is left of the centre."""

        def mask_points(self, points, eps):
            return super().mask_points(points, eps) & (points[:, 0] < self.centre[0])

    class Flank(ContactPlane):
        """SfePy's plane y = c_y + side R (normal (0, -side, 0), into the needle) acting
        where the deformed point is at x >= c_x on its side of c_y. SfePy hands mask_points
        the undeformed points: the deformed ones are those plus the term's u there."""

        def __init__(self, side: int, radius: float, centre: np.ndarray):
            self.side, self.radius, self.term, self.state = side, radius, None, None
            square = [[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 0.0, 1.0]]
            super().__init__(centre, [0.0, -float(side), 0.0], square)
            self.move(centre)

        def move(self, centre: np.ndarray) -> None:
            self.centre = np.asarray(centre, dtype=np.float64)
            self.anchor = self.centre + [0.0, self.side * self.radius, 0.0]
            self.adotn = float(np.dot(self.anchor, self.normal))

        def mask_points(self, points):
            u = self.term.get(self.state, "val").reshape(points.shape)
            x = points + u
            c = self.centre
            return (x[:, 0] >= c[0]) & (self.side * (x[:, 1] - c[1]) >= 0.0)

    return Disc, Flank


def build_problem(data: Exported, workdir: Path):
    """SfePy's Problem for the contact export on the slab (see the module), the stepper set;
    returns (problem, contact terms, move(step) that puts the needle at c(t_step), the
    Newton status)."""
    from sfepy.base.base import IndexedStruct
    from sfepy.discrete import (
        Equation,
        Equations,
        FieldVariable,
        Function,
        Functions,
        Integral,
        Material,
        Problem,
    )
    from sfepy.discrete.conditions import Conditions, EssentialBC
    from sfepy.discrete.fem import FEDomain, Field, Mesh
    from sfepy.mechanics.matcoefs import stiffness_from_youngpoisson
    from sfepy.solvers.ls import ScipyDirect
    from sfepy.solvers.nls import Newton
    from sfepy.solvers.ts_solvers import NewmarkTS
    from sfepy.terms import Term

    from tissuebench.workflows.simulators.sfepy import disjoint_sets, extent_of

    m, contact = data.material, tool(data)
    radius = float(contact["shape"]["radius"])
    k = float(contact["penalty"]["k"])
    centres = np.asarray(contact["motion"]["c"], dtype=np.float64)
    n = len(data.nodes)
    points, hexes = slab(np.asarray(data.nodes, dtype=np.float64), data.cells)
    mesh = Mesh.from_data(
        "tissuebench-slab",
        points,
        np.zeros(len(points), dtype=np.int32),
        [hexes],
        [np.zeros(len(hexes), dtype=np.int32)],
        ["3_8"],
    )
    domain = FEDomain("domain", mesh)
    omega = domain.create_region("Omega", "all")
    field = Field.from_args("fu", np.float64, "vector", omega, approx_order=1)
    if not np.array_equal(field.get_coor(), points):
        raise RuntimeError("SfePy's Q1 field does not number its nodes as the slab")
    surface_nodes = np.asarray(contact["law"]["surface_nodes"], dtype=np.int64)
    both = np.r_[surface_nodes, surface_nodes + n]
    functions = Functions([Function("surface", lambda coors, domain=None: both)])
    right = domain.create_region("Right", "vertices by surface", "facet", functions=functions)

    u = FieldVariable("u", "unknown", field, order=0)
    du = FieldVariable("du", "unknown", field, order=1)
    ddu = FieldVariable("ddu", "unknown", field, order=2)
    v = FieldVariable("v", "test", field, primary_var_name="u")
    dv = FieldVariable("dv", "test", field, primary_var_name="du")
    ddv = FieldVariable("ddv", "test", field, primary_var_name="ddu")

    D = stiffness_from_youngpoisson(3, m.E, m.nu)
    solid = Material(
        "solid",
        values={"D": D, "beta_D": m.beta * D, "rho": m.rho, "alpha_rho": m.alpha * m.rho},
    )
    c0 = np.r_[centres[0], 0.5 * SLAB]
    f = np.array([[k, 0.0]])
    disc_m = Material("disc", values={"f": f, ".c": c0, ".r": radius})
    square = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, 1.0]])
    flank_m = [
        Material(name, values={"f": f, ".n": [0.0, -s, 0.0], ".a": c0, ".bs": square})
        for name, s in (("upper", 1.0), ("lower", -1.0))
    ]
    volume = Integral("i", order=2)
    facets = Integral("ic", order=5)  # 3 Gauss points along the edge, as ours

    def term(text, **args):
        return Term.new(text, volume, omega, solid=solid, **args)

    terms = term("dw_dot(solid.rho, ddv, ddu)", ddv=ddv, ddu=ddu)
    if m.alpha > 0:
        terms = terms + term("dw_dot(solid.alpha_rho, dv, du)", dv=dv, du=du)
    if m.beta > 0:
        terms = terms + term("dw_lin_elastic(solid.beta_D, dv, du)", dv=dv, du=du)
    if m.alpha == 0 and m.beta == 0:
        terms = terms + term("dw_zero(dv, du)", dv=dv, du=du)
    terms = terms + term("dw_lin_elastic(solid.D, v, u)", v=v, u=u)
    touch = [
        Term.new(
            "dw_contact_sphere(disc.f, disc.c, disc.r, v, u)", facets, right, disc=disc_m, v=v, u=u
        )
    ]
    for mat in flank_m:
        touch.append(
            Term.new(
                f"dw_contact_plane({mat.name}.f, {mat.name}.n, {mat.name}.a, {mat.name}.bs, v, u)",
                facets,
                right,
                **{mat.name: mat},
                v=v,
                u=u,
            )
        )
    for t in touch:
        terms = terms + t
    equations = Equations([Equation("balance_of_forces", terms)])

    bcs = [EssentialBC("plane", omega, {"u.2": 0.0, "du.2": 0.0, "ddu.2": 0.0})]
    for j, (_, set_nodes) in enumerate(disjoint_sets(data).items()):
        layers = np.r_[set_nodes, set_nodes + n]
        select = Function(f"nodes_{j}", lambda coors, domain=None, s=layers: s)
        region = domain.create_region(
            f"set_{j}", f"vertices by nodes_{j}", "vertex", functions=Functions([select])
        )
        bcs.append(
            EssentialBC(f"bc_{j}", region, {"u.[0,1]": 0.0, "du.[0,1]": 0.0, "ddu.[0,1]": 0.0})
        )

    problem = Problem("tissuebench-contact", equations=equations, active_only=True)
    problem.setup_output(output_dir=str(workdir), output_filename_trunk="sfepy")
    problem.set_bcs(ebcs=Conditions(bcs))
    problem.set_ics(Conditions([]))

    Disc, Flank = bodies()
    contact_terms = [t for t in problem.equations[0].terms if t.name.startswith("dw_contact")]
    disc = Disc(c0.copy(), radius)
    flanks = []
    for t in contact_terms:
        if t.name == "dw_contact_sphere":
            t.cs = disc
        else:
            side = 1 if "upper" in t.arg_str else -1
            body = Flank(side, radius, c0.copy())
            body.term, body.state = t, t.get_state_variables()[0]
            t.cp = body
            flanks.append(body)

    def move(step: int) -> None:
        c = np.r_[centres[min(step, len(centres) - 1)], 0.5 * SLAB]
        disc.centre = c
        for body in flanks:
            body.move(c)

    status = IndexedStruct()
    ls = ScipyDirect({"method": "superlu", "use_presolve": False})
    problem.time_update()
    K = problem.evaluate(
        "dw_lin_elastic.2.Omega(solid.D, v, u)", mode="weak", dw_mode="matrix", copy_materials=False
    )
    nls = Newton(
        {
            "i_max": NEWTON_STEPS,
            "eps_a": ATOL_SCALE * float(K.diagonal().max()) * extent_of(data.nodes),
            "eps_r": 1e-10,
            "eps_mode": "or",
            "lin_red": None,
        },
        lin_solver=ls,
        status=status,
    )

    class MovingNeedleNewmark(NewmarkTS):
        """SfePy's ts.newmark with the needle moved to c(t_{n+1}) before each step."""

        def step(self, ts, vec, nls, pack, unpack, **kwargs):
            move(int(round(ts.time / data.h)))
            return super().step(ts, vec, nls, pack, unpack, **kwargs)

    conf = {
        "t0": 0.0,
        "t1": float(data.times[-1]),
        "dt": None,
        "n_step": data.steps + 1,
        "is_linear": False,
        "var_names": {"u": "u", "du": "du", "ddu": "ddu"},
        "verbose": False,
        "beta": 0.25,
        "gamma": 0.5,
    }
    problem.set_solver(MovingNeedleNewmark(conf, nls=nls, context=problem, verbose=False))
    move(0)
    return problem, contact_terms, move, status


def term_force(term) -> np.ndarray:
    """The sum of one contact term's nodal forces at the current state (N, (3,)): its residual
    vector summed per component, the force that the tissue exerts on the body."""
    val, _ = term.evaluate(mode="weak", diff_var=None, standalone=False)
    return val.reshape(len(val), 3, -1).sum(axis=(0, 2))


def interpenetration(
    nodes: np.ndarray, u: np.ndarray, edge: np.ndarray, c: np.ndarray, shape: dict
) -> float:
    """The largest -g_n (m, 0 where nothing penetrates) over the deformed surface: the edges
    between consecutive surface nodes `edge` (ordered along the edge), SAMPLES points each;
    nodes (N, 2) and u (N, 2) in m, c the needle's centre (m), `shape` the export's tool."""
    x = nodes[edge] + u[edge]
    s = np.linspace(0.0, 1.0, SAMPLES)[None, :, None]
    points = ((1 - s) * x[:-1, None, :] + s * x[1:, None, :]).reshape(-1, 2)
    return max(0.0, float(-from_shape(shape).signed_distance(points, c).min()))


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run the contact export in SfePy in workdir: workdir/sfepy.xdmf (the in-plane
    displacement, m, at every t_i up to the last step run, then NaN where it failed) and
    workdir/sfepy-force.csv (the needle force per unit thickness, N/m, write_force_csv's
    columns) and workdir/sfepy-interpenetration.csv (time s, interpenetration m). A failure
    comes back with status "failed" and the reason; wall_time_s (s) covers SfePy's problem
    setup and time loop."""
    from tissuebench.workflows.io.tables import write_force_csv, write_rows
    from tissuebench.workflows.io.xdmf import write_series
    from tissuebench.workflows.simulators import sfepy as base

    if variant not in VARIANTS:
        raise ValueError(f"unknown SfePy contact variant {variant!r}: use {', '.join(VARIANTS)}")
    why = check(data)
    if why is not None:
        raise ValueError(f"SfePy cannot pose this contact export: {why}")
    sfepy = base.sfepy_modules()
    from sfepy.base.base import output

    workdir = Path(workdir)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    N, steps, h = len(nodes), data.steps, data.h
    contact = tool(data)
    centres = np.asarray(contact["motion"]["c"], dtype=np.float64)
    edge = np.asarray(contact["law"]["surface_nodes"], dtype=np.int64)
    edge = edge[np.argsort(nodes[edge, 1])]
    U = np.zeros((steps + 1, N, 3))
    U[:, :, :2] = np.nan
    F = np.full((steps + 1, 2), np.nan)
    depth = np.zeros(steps + 1)
    limit = base.DIVERGENCE_FACTOR * base.extent_of(nodes)
    last, status, reason, diverged = -1, "ok", None, False
    terms: list = []
    newton = None

    def record(pb, ts, variables):
        """SfePy's step hook: keep u, the force and the interpenetration at step ts.step."""
        nonlocal last
        i = int(ts.step)
        if i > 0:
            condition = newton.get("condition", 0)
            if condition != 0:
                raise base.Diverged(
                    f"Newton did not converge at step {i} (t = {i * h:.6g} s) in "
                    f"{NEWTON_STEPS} iterations (condition {condition})"
                )
        values = variables["u"]().reshape(2 * N, 3)[:N, :2]
        last = i
        base.check_step(values, i, h, limit)
        U[i, :, :2] = values
        F[i] = sum(term_force(t) for t in terms)[:2] / SLAB
        depth[i] = interpenetration(nodes, values, edge, centres[i], contact["shape"])

    saved = output.output_function, output.level
    output.set_output(quiet=True)
    start = time.perf_counter()
    try:
        with base.quiet(), np.errstate(all="ignore"):
            problem, terms, _, newton = build_problem(data, workdir)
            problem.solve(save_results=False, step_hook=record, verbose=False)
    except base.Diverged as error:
        status, reason, diverged = "failed", str(error), True
    except Exception as error:  # a SfePy failure is a result of the run, not a crash
        first = (str(error).strip().splitlines() or [""])[0]
        status, reason = "failed", f"SfePy {type(error).__name__}: {first}"[:300]
    finally:
        wall = time.perf_counter() - start
        output.output_function, output.level = saved
    if status == "ok" and last != steps:
        status, reason = "failed", f"SfePy stopped at step {last} of {steps}"
    series = force = None
    if status != "ok" and not diverged and 0 <= last < steps:
        last += 1  # the step that failed, NaN
    if last >= 0:
        points = np.zeros((N, 3))
        points[:, :2] = nodes
        series = workdir / base.SERIES
        mesh = (points, np.asarray(data.cells, dtype=np.int64), data.cell_type)
        write_series(series, (mesh, {base.FIELD: U[: last + 1]}), data.times)
        kept = np.isfinite(F[: last + 1]).all(axis=1)
        force = workdir / FORCE
        write_force_csv(force, data.times[: last + 1][kept], F[: last + 1][kept])
        write_rows(
            workdir / DEPTH,
            [
                {"time": t, "interpenetration": d}
                for t, d in zip(data.times[: last + 1][kept], depth[: last + 1][kept], strict=True)
            ],
        )
    return ExternalRun(
        series=series,
        wall_time_s=wall,
        dofs=N * 2,
        field=base.FIELD,
        mesh=f"reference, extruded into one layer of hexahedra {SLAB:g} m thick (u_z = 0)",
        status=status,
        reason=reason,
        timing=base.TIMING,
        version=sfepy.__version__,
        force=force,
    )
