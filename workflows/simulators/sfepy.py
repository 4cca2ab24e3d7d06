"""SfePy (https://sfepy.org) as an outside simulator: an exported benchmark (workflows/
exporting.py, `Exported`) posed as elastodynamics (linear, or the rod's neo-hookean and svk
total Lagrangian: below) in SfePy's own terms and integrated by
its elastodynamics time steppers (sfepy.solvers.ts_solvers: ts.newmark, ts.generalized_alpha,
ts.bathe, ts.central_difference, ts.velocity_verlet), in process.

How it is posed (SPEC sections 1-3):

- the mesh from the export's nodes and cells (`Mesh.from_data`: node i is SfePy's vertex i; a
  quadrilateral's and a hexahedron's VTK corner order is SfePy's), vector Q1 field, 2x2(x2)
  Gauss (order 2: exact for the Q1 mass and stiffness on the export's affine cells);
- the equation of motion M a + C v + K u = f with three unknowns u, du, ddu (the layout
  SfePy's steppers expect): `dw_dot` (rho) or `de_mass` (rho, row-sum lumping) for M,
  C = alpha M + beta K from the same terms, `dw_lin_elastic` with SfePy's isotropic D (plane
  strain or plane stress in 2D) for K, `dw_volume_lvf` with rho g for the body force;
- each constrained set (`Exported.effective_sets`; a node follows the last set that names
  it) as essential conditions on u, du and ddu: the export's sampled (u, v, a), looked up by
  step index at the t_i and interpolated linearly in time at a stepper's sub-step times
  (ts.bathe and ts.generalized_alpha are run with their boundary values set at their
  sub-step times, which SfePy's own steppers do not do: see `steppers`);
- zero initial state on the free nodes; SfePy computes the initial acceleration from the
  equation of motion at t = 0 (M a_0 = f - K u_0 - C v_0, as the SPEC);
- one Newton iteration per step with an exact (SuperLU) solve of the linear system, the
  factorisation kept across steps; SfePy's reduced ("active only") vectors, so that the
  constrained values enter the free equations as known terms.

The nonlinear models of SPEC section 8 (neo-hookean, svk) on a 3D mesh: SfePy's total
Lagrangian hyperelastic terms, each the SPEC's energy exactly, by its implicit steppers with a
Newton loop (sfepy_nonlinear.py).

The contact benchmark (SPEC 12: an export with a `contact` block) is posed with SfePy's rigid
contact terms by its adapter, contact/sfepy.py.

Run, the displacement at every t_i goes to WORKDIR/sfepy.xdmf; a run stops at its first step
with a non-finite displacement or one beyond 100 times the domain's extent (SPEC section 3)
and writes NaN there (compare marks that step as its divergence).
"""

from __future__ import annotations

import contextlib
import io
import math
import time
import warnings
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import ExternalRun, given
from tissuebench.workflows.simulators import sfepy_nonlinear as nl

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

NAME = "sfepy"
try:
    TITLE = f"SfePy {metadata.version('sfepy')}"
except metadata.PackageNotFoundError:
    TITLE = "SfePy"
SERIES = "sfepy.xdmf"
FIELD = "displacement"
TIMING = "SfePy problem setup and time loop, in process"
DIVERGENCE_FACTOR = 100.0  # SPEC section 3: a displacement beyond 100 x the extent diverges

# variant -> (SfePy time stepper, its parameters, mass, one line of what it is)
VARIANTS: dict[str, tuple[str, dict[str, float | None], str, str]] = {
    "newmark": (
        "ts.newmark",
        {"beta": 0.25, "gamma": 0.5},
        "consistent",
        "ts.newmark, beta = 1/4, gamma = 1/2 (trapezoidal rule, implicit), consistent mass",
    ),
    "generalized-alpha": (
        "ts.generalized_alpha",
        {"rho_inf": 0.5, "alpha_m": None, "alpha_f": None, "beta": None, "gamma": None},
        "consistent",
        "ts.generalized_alpha, rho_inf = 0.5 (alpha_m = 0, alpha_f = 1/3, beta = 4/9, "
        "gamma = 5/6; implicit), consistent mass, boundary values at t_{n+1-alpha}",
    ),
    "bathe": (
        "ts.bathe",
        {},
        "consistent",
        "ts.bathe: trapezoidal rule to t + h/2, then 3-point backward Euler to t + h "
        "(implicit), consistent mass, boundary values at both sub-step times",
    ),
    "central-difference": (
        "ts.central_difference",
        {},
        "consistent",
        "ts.central_difference: explicit Newmark beta = 0, gamma = 1/2, consistent mass, "
        "solves (M + h C/2) a = ... (the SPEC's explicit)",
    ),
    "central-difference-lumped": (
        "ts.central_difference",
        {},
        "lumped",
        "ts.central_difference: explicit Newmark beta = 0, gamma = 1/2, row-sum lumped mass "
        "M_L (de_mass), C = alpha M_L + beta K",
    ),
    "velocity-verlet": (
        "ts.velocity_verlet",
        {},
        "consistent",
        "ts.velocity_verlet: explicit, consistent mass, solves M a = ... with the damping "
        "C v of the half-step velocity",
    ),
}


class Diverged(Exception):
    """Raised from SfePy's step hook to stop a run that blew up (SPEC section 3)."""


def available() -> str | None:
    """None when SfePy can be imported, else how to install it."""
    try:
        import sfepy  # noqa: F401
    except ImportError:
        return "SfePy is not installed: pip install 'tissuebench[sfepy]' (or make external-tools)"
    return None


def variants(data: Exported) -> dict[str, str]:
    """The variants that pose the export faithfully: every SfePy elastodynamics stepper for a
    dynamic export of the linear model, the implicit ones for a 3D dynamic export of a model
    in NONLINEAR; none for the static procedure or another model. A contact export:
    its adapter's (contact/sfepy.py)."""
    if data.procedure != "dynamic" or skipped(data).get("all"):
        return {}
    if data.model in nl.NONLINEAR:
        return nl.variants(data, {name: spec[3] for name, spec in VARIANTS.items()})
    if data.model != "linear":
        return {}
    plane = f", plane {data.plane or 'strain'}" if data.dim == 2 else ""
    elastic = f"D = stiffness_from_youngpoisson of the export's {given(data.material)}{plane}"
    return {name: f"{spec[3]}; {elastic}" for name, spec in VARIANTS.items()}


def skipped(data: Exported) -> dict[str, str]:
    """Variants that cannot pose this export, with why ({"all": why} when none can)."""
    posed = ", ".join(["linear", *nl.NONLINEAR])
    if data.model != "linear" and data.model not in nl.NONLINEAR:
        return {"all": f"the {data.model} model is not posed in SfePy here ({posed} only)"}
    if data.procedure != "dynamic":
        return {"all": "SfePy's elastodynamics steppers pose the dynamic procedure only"}
    if data.model in nl.NONLINEAR:
        return nl.skipped(data, list(VARIANTS))
    return {}


def motion_at(t: float, times: np.ndarray, h: float, values: np.ndarray) -> np.ndarray:
    """A sampled motion (steps + 1, d) at time t (s): the sample itself at a t_i (looked up by
    step index), else linear interpolation between the samples around t."""
    k = t / h
    i = int(round(k))
    if abs(k - i) <= 1e-9 * max(1.0, abs(k)):
        return values[min(max(i, 0), len(values) - 1)]
    return np.array([np.interp(t, times, values[:, j]) for j in range(values.shape[1])])


def disjoint_sets(data: Exported) -> dict[str, np.ndarray]:
    """The export's effective constrained sets made disjoint: a node shared by sets of equal
    motion (the block's fixed corners) is kept by the last one only; empty sets dropped."""
    effective = data.effective_sets()
    names = list(effective)
    out = {}
    for k, name in enumerate(names):
        nodes = np.asarray(effective[name], dtype=np.int64)
        for later in names[k + 1 :]:
            nodes = np.setdiff1d(nodes, effective[later])
        if len(nodes):
            out[name] = nodes
    return out


def is_fixed(motion: tuple[np.ndarray, ...]) -> bool:
    """Whether a sampled motion (u, v, a) is zero throughout."""
    return all(np.all(x == 0.0) for x in motion)


@contextlib.contextmanager
def quiet():
    """SfePy's console output swallowed: what it prints, and the deprecation warnings that its
    use of NumPy and pyparsing raises."""
    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        yield


def sfepy_modules():
    """Import the SfePy modules used here with their console output swallowed (SfePy's terms
    print a line about an optional JAX on import); returns sfepy (ImportError if absent)."""
    with quiet():
        import sfepy
        import sfepy.discrete  # noqa: F401
        import sfepy.discrete.conditions  # noqa: F401
        import sfepy.discrete.fem  # noqa: F401
        import sfepy.discrete.fem.poly_spaces  # noqa: F401 (imports SymPy: 1 s)
        import sfepy.mechanics.matcoefs  # noqa: F401
        import sfepy.solvers.ls  # noqa: F401
        import sfepy.solvers.nls  # noqa: F401
        import sfepy.solvers.ts_solvers  # noqa: F401
        import sfepy.terms  # noqa: F401
    return sfepy


def steppers() -> dict:
    """SfePy stepper name -> the class run for it. ts.bathe and ts.generalized_alpha are
    SfePy's with one change: the boundary values are set at their sub-step times.

    SfePy 2026.3 sets a step's essential conditions once, at t_{n+1}, before the step: its
    ts.bathe then solves the sub-step to t_n + h/2 with the boundary values of t_{n+1} and,
    having moved its clock on by h/2 instead of back, the sub-step to t_{n+1} with those of
    t_{n+1} + h/2, which it also leaves in the result (the block's needle ends each step
    h/2 ahead of its motion); its ts.generalized_alpha solves the balance at t_{n+1-alpha_f}
    with the boundary values of t_{n+1}. Here Bathe's sub-steps get the values at t_n + h/2
    and t_{n+1}, and the generalized-alpha balance the alpha-weighted ones, (1 - alpha_f)
    g_{n+1} + alpha_f g_n for u and v and (1 - alpha_m) a_{n+1} + alpha_m a_n for a (exact:
    the motion is interpolated linearly between the t_i). With fixed boundaries (the rod)
    both are SfePy's stepper unchanged."""
    from sfepy.solvers import ts_solvers as sts

    class BatheTS(sts.BatheTS):
        def step(self, ts, vec, nls, pack, unpack, prestep_fun):
            dt = ts.dt
            ut, vt, at = unpack(vec)
            ts.set_substep_time(-0.5 * dt)  # t_n + h/2
            prestep_fun(ts, vec)
            nlst1 = self.create_nlst1(nls, dt, ut, vt, at)
            ut1 = nlst1(ut)
            vt1 = nlst1.v(ut1)
            at1 = nlst1.a(vt1)
            ts.restore_step_time()  # t_{n+1}
            prestep_fun(ts, pack(ut1, vt1, at1))
            nlst2 = self.create_nlst2(nls, dt, ut, ut1, vt, vt1)
            ut2 = nlst2(ut1)
            vt2 = nlst2.v(ut2)
            at2 = nlst2.a(vt2)
            return pack(ut2, vt2, at2)

    class GeneralizedAlphaTS(sts.GeneralizedAlphaTS):
        def step(self, ts, vec, nls, pack, unpack, prestep_fun=None, **kwargs):
            dt = ts.dt
            alpha_m, alpha_f, gamma, beta = self.pars
            ut, vt, at = unpack(vec)
            nlst = self.create_nlst(nls, dt, alpha_m, alpha_f, gamma, beta, ut, vt, at)
            end = ts.time
            ts.set_substep_time(-alpha_f * dt)  # t_{n+1-alpha_f}
            ts.acceleration_time = end - alpha_m * dt
            try:
                prestep_fun(ts, vec)
                atp = nlst(at)
            finally:
                ts.restore_step_time()
                ts.acceleration_time = None
            prestep_fun(ts, vec)  # the boundary values of t_{n+1} for the step's state
            return pack(nlst.u(atp), nlst.v(atp), atp)

    return {
        "ts.newmark": sts.NewmarkTS,
        "ts.generalized_alpha": GeneralizedAlphaTS,
        "ts.bathe": BatheTS,
        "ts.central_difference": sts.CentralDifferenceTS,
        "ts.velocity_verlet": sts.VelocityVerletTS,
    }


def build_problem(data: Exported, variant: str, workdir: Path):
    """SfePy's Problem for the export (see the module docstring) with the variant's stepper
    set, its output folder workdir (nothing is written there unless asked)."""
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
    from sfepy.terms import Term

    kind, params, mass, _ = VARIANTS[variant]
    dim, m = data.dim, data.material
    nodes = np.ascontiguousarray(data.nodes, dtype=np.float64)
    cells = np.ascontiguousarray(data.cells, dtype=np.int32)
    mesh = Mesh.from_data(
        "tissuebench",
        nodes,
        np.zeros(len(nodes), dtype=np.int32),
        [cells],
        [np.zeros(len(cells), dtype=np.int32)],
        ["2_4" if dim == 2 else "3_8"],
    )
    domain = FEDomain("domain", mesh)
    omega = domain.create_region("Omega", "all")
    field = Field.from_args("fu", np.float64, "vector", omega, approx_order=1)
    if not np.array_equal(field.get_coor(), nodes):  # the step hook reads u in node order
        raise RuntimeError("SfePy's Q1 field does not number its nodes as the export")
    u = FieldVariable("u", "unknown", field, order=0)
    du = FieldVariable("du", "unknown", field, order=1)
    ddu = FieldVariable("ddu", "unknown", field, order=2)
    v = FieldVariable("v", "test", field, primary_var_name="u")
    dv = FieldVariable("dv", "test", field, primary_var_name="du")
    ddv = FieldVariable("ddv", "test", field, primary_var_name="ddu")

    D = stiffness_from_youngpoisson(dim, m.E, m.nu, plane=data.plane or "strain")
    lumped = mass == "lumped"
    nonlinear = data.model in nl.NONLINEAR
    mu = m.E / (2 * (1 + m.nu))  # Pa, SPEC section 1
    lam = m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu))  # Pa
    solid = Material(
        "solid",
        values={
            "D": D,
            "mu": mu,
            "K": lam + 2 * mu / 3,  # Pa: the SPEC's kappa
            "beta_D": m.beta * D,
            "rho": m.rho,
            "alpha_rho": m.alpha * m.rho,
            ".lumping": "row_sum" if lumped else "none",
            ".lumped": 1.0 if lumped else 0.0,
        },
    )
    force = m.rho * np.asarray(data.gravity, dtype=np.float64)  # N/m^3
    load = Material("load", values={"f": force[:, None]})
    integral = Integral("i", order=2)

    def term(text, **args):
        return Term.new(text, integral, omega, solid=solid, **args)

    if lumped:
        inertia = term(
            "de_mass(solid.rho, solid.lumping, solid.lumped, ddv, ddu)", ddv=ddv, ddu=ddu
        )
        mass_damping = "de_mass(solid.alpha_rho, solid.lumping, solid.lumped, dv, du)"
    else:
        inertia = term("dw_dot(solid.rho, ddv, ddu)", ddv=ddv, ddu=ddu)
        mass_damping = "dw_dot(solid.alpha_rho, dv, du)"
    terms = inertia
    if m.alpha > 0:
        terms = terms + term(mass_damping, dv=dv, du=du)
    if m.beta > 0:
        terms = terms + term("dw_lin_elastic(solid.beta_D, dv, du)", dv=dv, du=du)
    if m.alpha == 0 and m.beta == 0:  # keeps du in the equations, as SfePy's examples do
        terms = terms + term("dw_zero(dv, du)", dv=dv, du=du)
    for elastic in nl.NONLINEAR[data.model][0] if nonlinear else ("dw_lin_elastic(solid.D, v, u)",):
        terms = terms + term(elastic, v=v, u=u)
    if np.any(force != 0):
        terms = terms - Term.new("dw_volume_lvf(load.f, v)", integral, omega, load=load, v=v)
    equations = Equations([Equation("balance_of_forces", terms)])

    times, h = data.times, data.h
    bcs = []
    for k, (name, set_nodes) in enumerate(disjoint_sets(data).items()):
        select = Function(f"nodes_{k}", lambda coors, domain=None, n=set_nodes: n)
        region = domain.create_region(
            f"set_{k}", f"vertices by nodes_{k}", "vertex", functions=Functions([select])
        )
        motion = data.motions[name]
        if is_fixed(motion):
            values = {"u.all": 0.0, "du.all": 0.0, "ddu.all": 0.0}
        else:
            values = {}
            for var, series in zip(("u", "du", "ddu"), motion, strict=True):

                def prescribed(ts, coors, series=series, var=var, **kwargs):
                    t = ts.time
                    if var == "ddu" and getattr(ts, "acceleration_time", None) is not None:
                        t = ts.acceleration_time
                    return np.tile(motion_at(float(t), times, h, series), (len(coors), 1))

                values[f"{var}.all"] = Function(f"{var}_{k}", prescribed)
        bcs.append(EssentialBC(f"bc_{k}", region, values))

    problem = Problem("tissuebench", equations=equations, active_only=True)
    problem.setup_output(output_dir=str(workdir), output_filename_trunk="sfepy")
    problem.set_bcs(ebcs=Conditions(bcs))
    problem.set_ics(Conditions([]))

    ls = ScipyDirect({"method": "superlu", "use_presolve": not nonlinear})
    if nonlinear:
        newton = nl.newton_options(problem, integral)
    else:  # one exact solve per step (the problem is linear); eps_a = 0 so that no step is
        # skipped for a small initial residual
        newton = {"i_max": 1, "eps_a": 0.0, "eps_r": 1.0}

    class NewtonStatus(IndexedStruct):
        """SfePy's Newton status that keeps a failed solve's condition (1: no convergence in
        i_max iterations, 2: line search failed) until the step hook reads it."""

        failed = 0

        def __setitem__(self, key, value):
            super().__setitem__(key, value)
            if key == "condition" and value != 0 and not self.failed:
                self.failed = int(value)

    nls = Newton({**newton, "lin_red": None}, lin_solver=ls, status=NewtonStatus())
    conf = {
        "t0": 0.0,
        "t1": float(data.times[-1]),
        "dt": None,
        "n_step": data.steps + 1,
        "is_linear": not nonlinear,
        "var_names": {"u": "u", "du": "du", "ddu": "ddu"},
        "verbose": False,
        **params,
    }
    problem.set_solver(steppers()[kind](conf, nls=nls, context=problem, verbose=False))
    return problem


def extent_of(nodes: np.ndarray) -> float:
    """The domain's largest extent (m)."""
    return float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))


def check_step(values: np.ndarray, i: int, h: float, limit: float) -> None:
    """Raise Diverged at step i (t = i h, h in s) where the nodal displacements `values` (m)
    are not finite or one is beyond `limit` (m: DIVERGENCE_FACTOR x the domain's extent)."""
    peak = float(np.max(np.linalg.norm(values, axis=1)))
    if not math.isfinite(peak):
        raise Diverged(f"diverged at step {i} (t = {i * h:.6g} s): non-finite displacement")
    if peak > limit:
        raise Diverged(
            f"diverged at step {i} (t = {i * h:.6g} s): largest nodal displacement "
            f"{peak:.3g} m > {DIVERGENCE_FACTOR:g} x the domain's extent"
        )


def run(data: Exported, variant: str, workdir: Path) -> ExternalRun:
    """Run one variant in workdir, serially: write workdir/sfepy.xdmf (the displacement in m
    at every t_i up to the last step run, then one NaN step where it diverged or failed) and
    return what was produced. A failure or a blow-up comes back with status "failed" and the
    reason; wall_time_s (s) covers SfePy's problem setup and time loop."""
    from tissuebench.workflows.io.xdmf import write_series

    if variant not in VARIANTS:
        raise ValueError(f"unknown SfePy variant {variant!r}: use one of {', '.join(VARIANTS)}")
    offered = variants(data)
    if not offered:
        why = skipped(data).get("all", f"{data.model} {data.procedure} is not posed")
        raise ValueError(f"SfePy cannot run this export: {why}")
    if variant not in offered:
        raise ValueError(f"SfePy's {variant} is not run here: {skipped(data)[variant]}")
    sfepy = sfepy_modules()
    from sfepy.base.base import output

    workdir = Path(workdir)
    N, dim, steps, h = len(data.nodes), data.dim, data.steps, data.h
    U = np.zeros((steps + 1, N, 3))
    U[:, :, :dim] = np.nan  # NaN from a divergence on; a 2D mesh's third component is 0
    limit = DIVERGENCE_FACTOR * extent_of(data.nodes)
    last, status, reason, diverged = -1, "ok", None, False
    nonlinear = data.model in nl.NONLINEAR

    def record(pb, ts, variables):
        """SfePy's step hook: keep u at step ts.step (m), stop at a divergence."""
        nonlocal last
        i = int(ts.step)
        values = variables["u"]().reshape(N, dim)
        last = i
        check_step(values, i, h, limit)
        failed = nonlinear and pb.solver.nls.status.failed  # the linear run's Newton: 1 solve
        if failed and i > 0:
            what = f"in {nl.NEWTON_MAX_IT} iterations" if failed == 1 else "(line search failed)"
            raise Diverged(
                f"diverged at step {i} (t = {i * h:.6g} s): Newton did not converge {what}"
            )
        U[i, :, :dim] = values

    saved = output.output_function, output.level
    output.set_output(quiet=True)
    start = time.perf_counter()
    try:
        with quiet(), np.errstate(all="ignore"):
            problem = build_problem(data, variant, workdir)
            problem.solve(save_results=False, step_hook=record, verbose=False)
    except Diverged as error:
        status, reason, diverged = "failed", str(error), True
    except Exception as error:  # a SfePy failure is a result of the run, not a crash
        first = (str(error).strip().splitlines() or [""])[0]
        status, reason = "failed", f"SfePy {type(error).__name__}: {first}"[:300]
    finally:
        wall = time.perf_counter() - start
        output.output_function, output.level = saved
    if status == "ok" and last != steps:
        status, reason = "failed", f"SfePy stopped at step {last} of {steps}"

    series = None
    if status != "ok" and not diverged and 0 <= last < steps:
        last += 1  # the step that failed, NaN
    if last >= 0:
        points = np.zeros((N, 3))
        points[:, :dim] = data.nodes
        series = workdir / SERIES
        mesh = (points, np.asarray(data.cells, dtype=np.int64), data.cell_type)
        write_series(series, (mesh, {FIELD: U[: last + 1]}), data.times)
    return ExternalRun(
        series=series,
        wall_time_s=wall,
        dofs=N * dim,
        field=FIELD,
        mesh="reference",
        status=status,
        reason=reason,
        timing=TIMING,
        version=sfepy.__version__,
    )
