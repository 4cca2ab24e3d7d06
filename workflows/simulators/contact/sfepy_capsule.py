"""SfePy poses the needle in 3D (SPEC 13: the rigid capsule pushed down the axis into the top
face of the tissue cylinder, frictionless) on the export's own mesh with its rigid contact term
`dw_contact_sphere` (sfepy/terms/terms_surface.py), integrated by its ts.newmark.

What SfePy 2026.3 offers, and how it is used (read from its sources; the planar needle's
adapter, contact/sfepy.py, says more of the terms):

- `dw_contact_sphere` is a penalty term: the pressure f(d) = k <d> (Pa, f_0 = 0) along the
  normal n = (C - x) / |C - x| toward the sphere's centre C, d = R - |x - C| the penetration (m)
  of the deformed point x = X + u, integrated over the undeformed facets (small deformation);
  its residual and its tangent enter SfePy's Newton. SfePy's parameter is k, a stiffness per
  area (Pa/m), the meaning of SPEC 12's k: here k = kappa E / h_e of the export's
  `contact.penalty` (its suggestion, kappa = 10 by default), stated in the variant's line;
- SfePy has no term for a cylinder, and the capsule is not a sphere: its signed distance is the
  distance to the ray {c + r e_z, r >= 0} minus R. So the term is given its contact body (the
  object it builds once from its material and keeps, `term.cs`): a subclass of SfePy's own
  ContactSphere that sees a deformed point above the centre (z > c_z) at the centre's height,
  where its closest point on the ray is: below c_z it is SfePy's ball, above it the radial
  penalty toward the axis, the shaft, with the same f(d), d = R - r and n = -e_r. The force and
  the penetration stay SfePy's; the tangent is SfePy's sphere's plus, at the shaft's points,
  f / r e_z e_z^T (`capsule_function`): SfePy's term differentiates a normal that turns with
  z, the shaft's does not (without it Newton converges, linearly: measured at n = 3, s = 2,
  2.5 times the iterations, the same answer);
- where the shaft acts: at n = 3 with the export's k the top face never rises above c_z at
  s = 1 (the ball alone touches it; the penalty lets the tissue 0.045 m in); at s = 2 it does
  from t = 1 s, and there SfePy's force is our implicit's within 7e-5 of its largest, the ball
  alone (SfePy's sphere as it is) 95 % off;
- the capsule moves: before each step its centre is put at c(t_{n+1}), the export's
  `contact.motion.c` by step index;
- the mesh is the export's (hexahedra 3_8 or tetrahedra 3_4, node i SfePy's vertex i), vector
  Q1/P1 field; the volume and the top face's facets (their nodes all in
  `contact.law.surface_nodes`) integrated at VOLUME_ORDER and FACET_ORDER, ours (with one
  difference on the O-grid's hexahedra, at VOLUME_ORDER); the bottom's nodes fixed (u = du =
  ddu = 0);
- time stepping as the planar adapter's (ts.newmark, beta = 1/4, gamma = 1/2, consistent mass,
  Rayleigh damping C = alpha M + beta K): Newton on the step's acceleration with the contact
  tangent, converged when the residual drops by 1e-10 or below contact/sfepy.py's ATOL_SCALE x
  K's largest diagonal x the extent (N); a step that does not converge in NEWTON_STEPS
  iterations ends the run as failed.

The force on the capsule (N) is the sum of the contact term's nodal forces at the solution
(its residual vector: the force that the tissue exerts on the capsule, +z when it pushes it
back up); its x and y components are a symmetry error.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given
from tissuebench.workflows.simulators.contact import sfepy as planar

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

FORCE = "sfepy_force.csv"
CELLS = {"hexahedron": "3_8", "tetrahedron": "3_4"}  # the export's cells -> SfePy's geometry
# the volume quadrature's degree, for M, C and K alike: 2 x 2 x 2 Gauss points on a hexahedron,
# as sfepy.py and our elastic force (solvers/models/model.py QUADRATURE_DEGREE); 4 points on a
# tetrahedron, exact there. On the O-grid's trilinear (not affine) hexahedra the integrands are
# not polynomials, and ours integrates the Rayleigh damping's K_0 with UFL's estimate (degree
# 5, solvers/system.py) but its elastic force at degree 2: measured at n = 3, SfePy with K_0 in
# C at order 5 matches our implicit to round-off (E_n 1e-9, force 2e-14), with one order 2 for
# all its nodes differ 1.5e-4 (E_n) and its force 8e-6
VOLUME_ORDER = 2
# the facet quadrature's degree, as ours (solvers/contact.py QUADRATURE_DEGREE): 3 x 3 Gauss
# points on a quadrilateral, 6 points on a triangle (SfePy's are basix's there: measured, its
# force on a tetrahedral cylinder equals ours to 1e-13, and with order 5 it was 2 % off)
FACET_ORDER = 4
VARIANTS = {"newmark": planar.VARIANTS["newmark"]}


def check(data: Exported) -> str | None:
    """Why SfePy cannot pose this contact export with the capsule (None: it can)."""
    shape = (data.contact or {}).get("shape", {})
    if shape.get("kind") != "capsule":
        return f"this adapter poses SPEC 13's capsule only, not {shape.get('kind')!r}"
    if shape.get("axis", "z") != "z":
        return f"the capsule's axis is z here, not {shape.get('axis')!r}"
    if data.dim != 3 or data.cell_type not in CELLS:
        return f"SfePy's contact terms act on 3D hexahedra or tetrahedra, not {data.cell_type}"
    if data.model != "linear":
        return (
            f"the {data.model} model is not posed in SfePy here: its contact terms are of "
            "small deformation, and sfepy.py poses the linear model only"
        )
    if data.procedure != "dynamic":
        return "SfePy's elastodynamics steppers pose the dynamic procedure only"
    if any(any(np.any(x != 0.0) for x in m) for m in data.motions.values()):
        return "a contact export's constrained sets are fixed: this one moves a set"
    if np.any(np.asarray(data.gravity) != 0.0):
        return "SPEC 13 has no body force: this export has gravity, not posed here"
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose this capsule export (none for another model or procedure)."""
    if check(data) is not None:
        return {}
    pen = planar.tool(data)["penalty"]
    return {
        name: f"{words}; SfePy's dw_contact_sphere over the top face, its body the capsule (the "
        "ball below c_z, above it the radial penalty toward the axis), penalty SfePy's k = "
        f"kappa E / h_e = {pen['kappa']:g} x {data.material.E:g} / {pen['h_e']:.4g} = "
        f"{pen['k']:.6g} Pa/m (f_0 = 0); D = stiffness_from_youngpoisson (3D) of the export's "
        f"{given(data.material)}"
        for name, words in VARIANTS.items()
    }


def skipped(data: Exported) -> dict[str, str]:
    """What SfePy does not pose of this capsule export, and why (one line each)."""
    why = check(data)
    if why is not None:
        return {"all": why}
    explicit = (
        "not posed on the capsule: the penalty stiffness lowers an explicit scheme's critical "
        "step, and sub-stepping SfePy's explicit steppers (SPEC 11) is not implemented"
    )
    implicit = "not posed on the capsule here: only ts.newmark is run with the contact term"
    return {
        "central-difference": explicit,
        "central-difference-lumped": explicit,
        "velocity-verlet": explicit,
        "generalized-alpha": implicit,
        "bathe": implicit,
    }


def capsule_body(centre: np.ndarray, radius: float):
    """The capsule as a contact body of SfePy's dw_contact_sphere (see the module): SfePy's
    ContactSphere of radius R (m) centred at c (m) that sees a point above c at c's height;
    `shaft` marks the term's points last masked that were above c (the tangent needs them)."""
    from sfepy.mechanics.contact_bodies import ContactSphere

    class CapsuleBody(ContactSphere):
        """SfePy's sphere with the half-infinite cylinder above it."""

        shaft: np.ndarray | None = None

        def level(self, points: np.ndarray) -> np.ndarray:
            """The points (m) with z lowered to c_z where above it: the closest point of the
            ray is then the centre, so SfePy's sphere measures the capsule's distance."""
            out = np.array(points, dtype=np.float64)
            out[:, 2] = np.minimum(out[:, 2], self.centre[2])
            return out

        def mask_points(self, points, eps):
            self.shaft = points[:, 2] > self.centre[2]
            return super().mask_points(self.level(points), eps)

        def get_distance(self, points):
            return super().get_distance(self.level(points))

    return CapsuleBody(np.asarray(centre, dtype=np.float64), float(radius))


def capsule_function(body):
    """The contact term's kernel for the capsule: SfePy's dw_contact_sphere kernel, and in the
    tangent (fmode 1) at the shaft's points + f / r e_z e_z^T, which removes the sphere's turning
    of the normal with z (the shaft's normal is horizontal whatever the point's height)."""
    from sfepy.terms.terms_surface import ContactSphereTerm

    def function(out, force, normals, fd, geo, fmode):
        status = ContactSphereTerm.function(out, force, normals, fd, geo, fmode)
        shaft = body.shaft
        if fmode == 0 or fd is None or shaft is None or not shaft.any():
            return status
        bf = geo.bf[0][:, 0]  # (points, element nodes): SfePy's term takes the first facet's
        points, n_ep = bf.shape
        vz = np.zeros((points, 1, 3 * n_ep))
        vz[:, 0, 2 * n_ep :] = bf  # the z components' block, as SfePy's term lays them out
        zz = np.einsum("qai,qaj->qij", vz, vz)
        extra = np.zeros_like(out)
        on = shaft.reshape(fd.shape[:2])[..., None, None]
        geo.integrate(extra, np.ascontiguousarray(fd * on * zz[None]))
        out += extra
        return status

    return function


def build_problem(data: Exported, workdir: Path):
    """SfePy's Problem for the capsule export on its mesh (see the module), the stepper set;
    returns (problem, the contact term, the Newton status)."""
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

    m, contact = data.material, planar.tool(data)
    radius = float(contact["shape"]["radius"])
    k = float(contact["penalty"]["k"])
    centres = np.asarray(contact["motion"]["c"], dtype=np.float64)
    nodes = np.ascontiguousarray(data.nodes, dtype=np.float64)
    cells = np.ascontiguousarray(data.cells, dtype=np.int32)
    mesh = Mesh.from_data(
        "tissuebench-cylinder",
        nodes,
        np.zeros(len(nodes), dtype=np.int32),
        [cells],
        [np.zeros(len(cells), dtype=np.int32)],
        [CELLS[data.cell_type]],
    )
    domain = FEDomain("domain", mesh)
    omega = domain.create_region("Omega", "all")
    field = Field.from_args("fu", np.float64, "vector", omega, approx_order=1)
    if not np.array_equal(field.get_coor(), nodes):  # the step hook reads u in node order
        raise RuntimeError("SfePy's P1/Q1 field does not number its nodes as the export")
    top_nodes = np.asarray(contact["law"]["surface_nodes"], dtype=np.int64)
    on_top = Functions([Function("surface", lambda coors, domain=None: top_nodes)])
    top = domain.create_region("Top", "vertices by surface", "facet", functions=on_top)

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
    tool = Material("tool", values={"f": np.array([[k, 0.0]]), ".c": centres[0], ".r": radius})
    volume = Integral("i", order=VOLUME_ORDER)

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
    terms = terms + Term.new(
        "dw_contact_sphere(tool.f, tool.c, tool.r, v, u)",
        Integral("ic", order=FACET_ORDER),
        top,
        tool=tool,
        v=v,
        u=u,
    )
    equations = Equations([Equation("balance_of_forces", terms)])

    bcs = []
    for j, (_, set_nodes) in enumerate(disjoint_sets(data).items()):
        select = Function(f"nodes_{j}", lambda coors, domain=None, s=set_nodes: s)
        region = domain.create_region(
            f"set_{j}", f"vertices by nodes_{j}", "vertex", functions=Functions([select])
        )
        bcs.append(EssentialBC(f"bc_{j}", region, {"u.all": 0.0, "du.all": 0.0, "ddu.all": 0.0}))

    problem = Problem("tissuebench-capsule", equations=equations, active_only=True)
    problem.setup_output(output_dir=str(workdir), output_filename_trunk="sfepy")
    problem.set_bcs(ebcs=Conditions(bcs))
    problem.set_ics(Conditions([]))

    (touch,) = [t for t in problem.equations[0].terms if t.name == "dw_contact_sphere"]
    body = capsule_body(centres[0], radius)
    touch.cs = body
    touch.function = capsule_function(body)

    status = IndexedStruct()
    problem.time_update()
    K = problem.evaluate(
        "dw_lin_elastic.2.Omega(solid.D, v, u)", mode="weak", dw_mode="matrix", copy_materials=False
    )
    nls = Newton(
        {
            "i_max": planar.NEWTON_STEPS,
            "eps_a": planar.ATOL_SCALE * float(K.diagonal().max()) * extent_of(nodes),
            "eps_r": 1e-10,
            "eps_mode": "or",
            "lin_red": None,
        },
        lin_solver=ScipyDirect({"method": "superlu", "use_presolve": False}),
        status=status,
    )

    class MovingCapsuleNewmark(NewmarkTS):
        """SfePy's ts.newmark with the capsule's centre put at c(t_{n+1}) before each step."""

        def step(self, ts, vec, nls, pack, unpack, **kwargs):
            step = int(round(ts.time / data.h))
            body.centre = centres[min(step, len(centres) - 1)].copy()
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
    problem.set_solver(MovingCapsuleNewmark(conf, nls=nls, context=problem, verbose=False))
    return problem, touch, status


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run the capsule export in SfePy in workdir: workdir/sfepy.xdmf (the displacement, m, on
    the export's nodes at every t_i up to the last step run, then NaN where it failed) and
    workdir/sfepy_force.csv (the force that the tissue exerts on the capsule, N, x, y and z, at
    every step run: io/tables.py write_force_csv). A failure comes back with status "failed"
    and the reason; wall_time_s (s) covers SfePy's problem setup and time loop."""
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series
    from tissuebench.workflows.simulators import sfepy as base

    if variant not in VARIANTS:
        raise ValueError(f"unknown SfePy capsule variant {variant!r}: use {', '.join(VARIANTS)}")
    why = check(data)
    if why is not None:
        raise ValueError(f"SfePy cannot pose this capsule export: {why}")
    sfepy = base.sfepy_modules()
    from sfepy.base.base import output

    workdir = Path(workdir)
    nodes = np.asarray(data.nodes, dtype=np.float64)
    N, steps, h = len(nodes), data.steps, data.h
    U = np.full((steps + 1, N, 3), np.nan)
    F = np.full((steps + 1, 3), np.nan)
    limit = base.DIVERGENCE_FACTOR * base.extent_of(nodes)
    last, status, reason, diverged = -1, "ok", None, False
    touch = newton = None

    def record(pb, ts, variables):
        """SfePy's step hook: keep u (m) and the force on the capsule (N) at step ts.step."""
        nonlocal last
        i = int(ts.step)
        if i > 0 and newton.get("condition", 0) != 0:
            raise base.Diverged(
                f"Newton did not converge at step {i} (t = {i * h:.6g} s) in "
                f"{planar.NEWTON_STEPS} iterations (condition {newton.condition})"
            )
        values = variables["u"]().reshape(N, 3)
        last = i
        base.check_step(values, i, h, limit)
        U[i] = values
        F[i] = planar.term_force(touch)

    saved = output.output_function, output.level
    output.set_output(quiet=True)
    start = time.perf_counter()
    try:
        with base.quiet(), np.errstate(all="ignore"):
            problem, touch, newton = build_problem(data, workdir)
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
        series = workdir / base.SERIES
        mesh = (nodes, np.asarray(data.cells, dtype=np.int64), data.cell_type)
        write_series(series, (mesh, {base.FIELD: U[: last + 1]}), data.times)
        kept = np.isfinite(F[: last + 1]).all(axis=1)
        force = workdir / FORCE
        write_force_csv(force, data.times[: last + 1][kept], F[: last + 1][kept])
    return ExternalRun(
        series=series,
        wall_time_s=wall,
        dofs=N * 3,
        field=base.FIELD,
        mesh="reference",
        status=status,
        reason=reason,
        timing=base.TIMING,
        version=sfepy.__version__,
        force=force,
    )
