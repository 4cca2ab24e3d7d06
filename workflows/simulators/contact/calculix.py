"""CalculiX on a contact benchmark (SPEC 12): the needle as a rigid body that CalculiX's own
contact pushes against the block (the deck: workflows/io/calculix_contact.py); calculix.py
hands an export with a `contact` block here.

Variants: `static-contact-CPE4` for the static procedure (*STATIC, DIRECT, one increment per
t_i; graded against our quasi-static), the needle's contact NODE TO SURFACE with the export's
penalty slope; the models linear and neo-hookean (NLGEOM).

Measured with CalculiX 2.20 on contact-MP1, linear, static, T = 10 s (the needle stops at
t = 2 s), against our quasi-static on the same mesh (tests/test_external_calculix_contact.py),
at N = 10, 20, 40: the needle force at t = 2 s (and 10 s alike) 25.9, 25.5, 25.7 N/m, ours
33.8, 29.6, 26.6 (23 %, 14 %, 3.5 % apart: ours comes down to CalculiX's as the mesh
refines); E_i max 3.7e-3, 2.5e-3, 5.4e-4 m^2 (21 %, 16 %, 3.7 % of the zero field's); the
largest interpenetration over the edge (sampled at 9 points on each deformed edge, as ours)
0.034, 0.019, 0.0061 m (ours 0.019, 0.011, 0.0048; at CalculiX's nodes only 0.0097, 0.0046,
0.0025 m: node to surface keeps the nodes out and lets the needle in between them); the
force equals the fixed edges' reactions to 1e-5; the ccx process 10, 17-22 and 69-93 s (ours
0.3, 0.5, 3 s). neo-hookean (contact-MP1-nhb's model for simulators): the force 29.9, 35.2,
36.1 N/m, ours 40.3, 37.5, 36.8 (26 %, 6 %, 1.9 %), E_i max 23 %, 5.3 %, 1.8 % of the zero
field's, ccx 12, 37, 135 s. Two contact discretisations that meet as the mesh refines.
SURFACE TO SURFACE let the edge pass through the needle at N = 8 and gave a force that
depends on the path at N = 20 (9.8 N/m at t = 1 s, ours 14.6), so it is not offered.

Not posed (`skipped`): the dynamic procedure (DYNAMIC_REFUSED); on a dynamic export the
variant `quasi-static-contact-CPE4` solves its load history by *STATIC instead, and is graded
as a quasi-static run (against the dynamic truth, as our quasi-static algorithm is).

The force: minus the sum of the band's reaction forces RF (the band is moved by *BOUNDARY),
per 1 m of CPE4 thickness: the force the block exerts on the needle, N/m, +x when the needle
pushes the block in -x; written by io/tables.py's write_force_csv with t_0 = 0 at rest (the
needle touches the edge without force) as ExternalRun.force.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from tissuebench.core import interrupt
from tissuebench.workflows.simulators import ExternalRun

JOB = "job"
SERIES = "calculix.xdmf"  # the block's displacement at every t_i, t_0 = 0 included
FIELD = "displacement"
FORCE = "force.csv"
TIMEOUT = 3600.0  # s
MODELS = ("linear", "neo-hookean")
CONTACT_TYPE = "NODE TO SURFACE"
DYNAMIC_REFUSED = (
    "CalculiX 2.20 stops implicit dynamic contact with a moving rigid needle (measured on "
    "contact-MP1): at fixed increments h (*DYNAMIC, DIRECT) it ends 'solution seems to diverge' "
    "at step 2 node to surface (N = 8 and 20) and at t = 0.57 s surface to surface (CPE4 and a "
    "one-element C3D8 slab alike; 0.53 s at h/2 and h/4; without damping at 2.03 s); with "
    "automatic increments it cuts them to its minimum ('too many cutbacks'); its energy-based "
    "impact rules (checkimpacts) count no work of a prescribed displacement, its external work "
    "staying 0 while the needle drives the block; MORTAR contact refuses CPE4 (the 2D "
    "expansion's MPCs) and crashed in the slab"
)


QUASI_STATIC = "quasi-static-contact-CPE4"  # the dynamic export's load history, *STATIC


def variants(data) -> dict[str, str]:
    """The contact variants of this export (module docstring): on a dynamic export, QUASI_STATIC,
    its load history solved by *STATIC at every t_i (no inertia, no damping: our quasi-static
    algorithm's problem), since CalculiX's dynamic contact stops (DYNAMIC_REFUSED)."""
    if data.model not in MODELS:
        return {}
    from tissuebench.workflows.io.calculix_contact import SIGMA_INF
    from tissuebench.workflows.simulators import calculix  # the deck's materials, as there

    k = float(data.contact["penalty"]["k"])
    flags = ", NLGEOM" if data.model != "linear" else ""
    name, quasi = "static-contact-CPE4", ""
    if data.procedure == "dynamic":
        name = QUASI_STATIC
        quasi = (
            "quasi-static: the dynamic case's load history without inertia and damping, as our "
            "quasi-static algorithm (CalculiX 2.20's dynamic contact stops, its skipped line); "
        )
    return {
        name: f"{quasi}*STATIC, DIRECT{flags}, one increment per t_i, CPE4; the needle "
        "a rigid band of CPE4 moved by *BOUNDARY, *CONTACT PAIR NODE TO SURFACE (the block's "
        "edge x = 1 the slave), frictionless, PRESSURE-OVERCLOSURE=LINEAR with k = "
        f"{k:.5g} Pa/m (the export's penalty kappa E / h_e) and sigma_inf = k x {SIGMA_INF:g} m; "
        + calculix.elastic(data)
    }


def skipped(data) -> dict[str, str]:
    """What is not posed of a contact export, and why."""
    if data.model not in MODELS:
        return {"all": f"the {data.model} model has no CalculiX material"}
    if data.procedure == "dynamic":
        return {"contact-implicit-CPE4": DYNAMIC_REFUSED, "contact-hht-CPE4": DYNAMIC_REFUSED}
    return {}


def read_contact_frd(data, frd: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times (n,) s, the block's displacement (n, N, 2) m, the needle force (n, 2) N/m) at the
    increments of CalculiX's .frd (t_0 not among them)."""
    from tissuebench.workflows.io.calculix import read_frd

    N = len(data.nodes)
    _, _, _, read_times, disp, _ = read_frd(frd, ("DISP",))
    _, _, _, rf_times, forces, _ = read_frd(frd, ("FORC",))
    times = np.asarray(read_times, dtype=float)
    if np.asarray(rf_times, dtype=float).shape != times.shape:
        raise ValueError(f"{frd}: {len(times)} displacement blocks, not as many of RF")
    u = np.array([d[:N, :2] for d in disp])
    # the band's nodes follow the block's; RF holds the force on the band: the needle force
    # is minus it, per the CPE4 thickness of 1 m
    force = np.array([-f[N:, :2].sum(axis=0) for f in forces])
    return times, u, force


def run(data, variant: str, workdir: Path) -> ExternalRun:
    """Write the deck, run ccx, and return the block's displacement series (workdir/
    calculix.xdmf) and the needle force (workdir/force.csv)."""
    from tissuebench.workflows.io.calculix_contact import contact_inp_text
    from tissuebench.workflows.io.tables import write_force_csv
    from tissuebench.workflows.io.xdmf import write_series
    from tissuebench.workflows.simulators.calculix import version

    if variant not in variants(data):
        raise ValueError(
            f"CalculiX has no contact variant {variant!r} here: use "
            f"{', '.join(variants(data)) or '(none)'}"
        )
    workdir = Path(workdir)
    if variant == QUASI_STATIC:  # the same deck as the static export's
        data = replace(data, procedure="static")
    (workdir / f"{JOB}.inp").write_text(contact_inp_text(data, CONTACT_TYPE))
    env = {**os.environ, "OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1"}
    N, steps = len(data.nodes), data.steps
    dofs = 2 * N
    timing = "the ccx process, 1 thread (deck, contact search, assembly, factorisations, .frd)"
    start = time.perf_counter()
    done = interrupt.run_child(["ccx", "-i", JOB], TIMEOUT, cwd=workdir, env=env)
    if done is None:
        return ExternalRun(None, None, dofs, status="failed", reason=f"ccx ran over {TIMEOUT:g} s")
    wall = time.perf_counter() - start
    (workdir / "ccx.log").write_text(done.stdout + done.stderr)
    errors = [line.strip() for line in done.stdout.splitlines() if "*ERROR" in line]
    status, reason = "ok", None
    if done.returncode != 0 or errors:
        status = "failed"
        reason = errors[0] if errors else f"ccx exited with status {done.returncode}"
    try:
        times, u, force = read_contact_frd(data, workdir / f"{JOB}.frd")
    except (OSError, ValueError) as exc:  # InputError is a ValueError
        reason = reason or f"its .frd is not read: {exc}"
        return ExternalRun(None, wall, dofs, status="failed", reason=reason, timing=timing)
    kept = np.flatnonzero(np.abs(times / data.h - np.round(times / data.h)) < 1e-3)
    index = np.round(times[kept] / data.h).astype(int)
    count = int(index.max()) if len(index) else 0
    if status == "ok" and not np.array_equal(index, np.arange(1, steps + 1)):
        status, reason = "failed", f"ccx wrote {len(index)} of the {steps} steps t_i"
    U = np.full((count + 1, N, 3), np.nan)
    U[0] = 0.0
    U[index, :, :2] = u[kept]
    U[index, :, 2] = 0.0
    F = np.full((count + 1, 2), np.nan)
    F[0] = 0.0  # at rest the needle touches the edge without force (SPEC 12)
    F[index] = force[kept]
    series = workdir / SERIES
    points = np.column_stack([data.nodes, np.zeros(N)])
    mesh = (points, np.asarray(data.cells, dtype=np.int64), data.cell_type)
    write_series(series, (mesh, {FIELD: U}), data.times[: count + 1])
    forces = None
    if np.isfinite(F).all():
        forces = workdir / FORCE
        write_force_csv(forces, data.times[: count + 1], F)
    return ExternalRun(
        series,
        wall,
        dofs,
        field=FIELD,
        status=status,
        reason=reason,
        timing=timing,
        version=version(),
        force=forces,
    )
