"""A benchmark posed for another simulator: its mesh, node sets, prescribed motion, body force,
material and time stepping, written as JSON (for any code), as a CalculiX deck (.inp, ready
for `ccx`) or as the mesh alone (.vtu, .msh); beside the JSON and the deck, our reference's
displacement history (XDMF), so that the other simulator's output can be graded with
`tissuebench compare` at once. `tissuebench export` (workflows/commands/export.py) is the command.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.series import cell_measures
from tissuebench.solvers.materials import Material
from tissuebench.workflows.io.calculix_deck import (
    check_element,
    check_inp_model,
    default_element,
    write_inp,
)
from tissuebench.workflows.io.exported import Exported, ExportError, write_json, write_mesh

FORMATS = ("json", "inp", "vtu", "msh")
# procedure -> our reference algorithm (the CalculiX step: dynamic_keyword, STATIC_KEYWORD)
PROCEDURES = {"dynamic": "implicit", "static": "quasi-static"}
REFERENCE_FIELD = "displacement"


def oriented(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Cells (VTK order) with a positive area or volume: a quadrilateral taken clockwise, or a
    hexahedron whose bottom face is, is reversed (CalculiX refuses negative Jacobians)."""
    cells = np.array(cells, dtype=np.int64)
    negative = cell_measures(points, cells) < 0
    flip = [0, 3, 2, 1] if cells.shape[1] == 4 else [0, 3, 2, 1, 4, 7, 6, 5]
    cells[negative] = cells[negative][:, flip]
    return cells


def constrained_sets(bench, V) -> dict[str, np.ndarray] | None:
    """On rank 0: {constraint name: sorted global node indices of V} (None elsewhere)."""
    from dolfinx import fem

    mesh, imap = V.mesh, V.dofmap.index_map
    tdim = mesh.topology.dim
    local = {}
    for c in bench.constraints:
        mesh.topology.create_connectivity(c.dim, tdim)
        nodes = fem.locate_dofs_topological(V, c.dim, c.entities)
        nodes = nodes[nodes < imap.size_local]
        local[c.name] = imap.local_to_global(nodes.astype(np.int32)).astype(np.int64)
    parts = mesh.comm.gather(local, root=0)
    if mesh.comm.rank != 0:
        return None
    assert parts is not None  # gathered on rank 0
    return {
        c.name: np.unique(np.concatenate([p[c.name] for p in parts])) for c in bench.constraints
    }


def sample_motion(motion, times: np.ndarray, dim: int) -> tuple[np.ndarray, ...]:
    """(u, v, a), each (len(times), dim), of a constraint's motion(t) at every time."""
    values = np.zeros((3, len(times), dim))
    for i, t in enumerate(times):
        for j, x in enumerate(motion(float(t))):
            values[j, i] = np.asarray(x, dtype=np.float64)[:dim]
    return values[0], values[1], values[2]


TOLERANCE = 1e-9  # m: a region's predicates hold within this (the meshes' nodes are exact)


def geometry(benchmark: str, options: dict) -> dict | None:
    """The undeformed body and each constrained node set's region as a predicate on the
    coordinates (the JSON's `geometry`, schema in workflows/io/exported.py), from the
    benchmark's entry (its box and posing); None for a benchmark that states no regions."""
    from tissuebench.meshes import get_entry
    from tissuebench.meshes.posed import posing

    entry = get_entry(benchmark)
    if entry.posing is None or not (entry.box or entry.body):
        return None
    _, posed = posing(benchmark, **options)
    regions = {"regions": {r.name: r.predicate for r in posed.regions}, "tolerance": TOLERANCE}
    if entry.body:  # a body that is no box: its entry says it
        return {**entry.body, **regions}
    extents = [[0.0, float(length)] for length in entry.box]
    return {"domain": "box", "axes": ["x", "y", "z"][: len(extents)], "extents": extents, **regions}


def contact_object(benchmark: str, bench, V, material: Material, times: np.ndarray) -> dict | None:
    """The JSON's `contact` (schema in workflows/io/exported.py) for a benchmark with a rigid
    tool in contact: what its entry states (`tool`: shape, motion, law, penalty, what is
    graded), with our penalty's k = kappa E / h_e (Pa/m) for the material, its quadrature, the
    centre c(t_i) (m) at every t_i and, on rank 0, the surface's nodes (sorted indices of the
    export's nodes); None for one without. Collective."""
    from dolfinx import fem

    from tissuebench.meshes import get_entry
    from tissuebench.solvers.contact import QUADRATURE_DEGREE

    entry, contact = get_entry(benchmark), bench.contact
    if entry.contact_export is None or contact is None:
        return None
    mesh, imap = V.mesh, V.dofmap.index_map
    mesh.topology.create_connectivity(mesh.topology.dim - 1, mesh.topology.dim)
    nodes = fem.locate_dofs_topological(V, mesh.topology.dim - 1, contact.facets)
    nodes = imap.local_to_global(nodes[nodes < imap.size_local].astype(np.int32))
    parts = mesh.comm.gather(nodes.astype(np.int64), root=0)
    if mesh.comm.rank != 0:
        return None
    assert parts is not None  # gathered on rank 0
    stated = entry.contact_export(
        bench.mesh_size, **{k: v for k, v in bench.options.items() if k in entry.options}
    )
    stated["penalty"]["k"] = contact.kappa * material.E / contact.edge_size
    points = QUADRATURE_DEGREE // 2 + 1  # Gauss-Legendre with n points: exact to degree 2n - 1
    stated["penalty"]["quadrature"] = (
        f"Gauss-Legendre, {points} points on each edge of the surface (exact to degree "
        f"{2 * points - 1})"
    )
    stated["motion"]["c"] = [[float(v) for v in contact.centre(float(t))] for t in times]
    stated["law"]["surface_nodes"] = np.unique(np.concatenate(parts)).tolist()
    return stated


def truth_case(
    benchmark: str,
    options: dict,
    material: Material,
    model: str,
    h: float,
    steps: int,
    plane: str | None,
    procedure: str,
) -> dict:
    """The JSON's `truth`: the SPEC 10 case this export is (its converged reference, graded by
    `tissuebench compare truth:CASE`), or {"case": None, "why": ...}."""
    from tissuebench.meshes import get_entry
    from tissuebench.solvers.materials import FIELDS, MATERIALS
    from tissuebench.solvers.truth.cases import CASES

    entry = get_entry(benchmark)
    width = float(options.get("needle_width", 0.0))
    scale = float(options.get("load_scale", 1.0))
    names = ", ".join(CASES)
    if procedure != "dynamic":
        return {"case": None, "why": "the truth is dynamic; this export is quasi-static"}
    why = entry.no_truth(options)
    if why is not None:
        return {"case": None, "why": why}
    for case, (bench, mat, case_model, s, w) in CASES.items():
        same_material = all(getattr(material, f) == getattr(MATERIALS[mat], f) for f in FIELDS)
        if (
            bench == benchmark
            and same_material
            and case_model == model
            and s == scale
            and (w is None or w == width)
            and plane in (None, "strain")
        ):
            if not (math.isclose(h, entry.dt) and math.isclose(h * steps, entry.end_time)):
                return {
                    "case": None,
                    "why": f"the truth {case} is computed at h = {entry.dt:.6g} s to "
                    f"T = {entry.end_time:g} s; this export has h = {h:.6g} s, "
                    f"T = {h * steps:.6g} s",
                }
            return {
                "case": case,
                "compare": f"tissuebench compare truth:{case} CANDIDATE --out DIR",
                "what": "a converged solution of the continuum problem: second-order "
                "displacement (Taylor-Hood Q2-Q1 for nu >= 0.45 and neo-Hookean), the "
                "trapezoidal rule with consistent mass, on three refined grids and h/2",
                "own_error": "its E_i max, estimated from its grids and h/2 and stated beside "
                "every grade against it (target: 0.2 % of the truth's own E_i against "
                "rest; results/truth.md)",
            }
    return {
        "case": None,
        "why": f"no truth case is this benchmark, material, model, load scale and needle "
        f"width (the truth cases: {names})",
    }


def build(
    benchmark: str,
    mesh_size: int,
    options: dict,
    material: Material,
    model: str,
    h: float,
    steps: int,
    plane: str,
    procedure: str,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Build the benchmark's mesh over comm and collect what an export holds. Collective;
    returns (Exported on rank 0 and None elsewhere, the Benchmark, its vector Q1 space)."""
    from dolfinx import fem

    from tissuebench.meshes import get_benchmark
    from tissuebench.workflows.io.xdmf import gather_mesh

    bench = get_benchmark(benchmark, mesh_size=mesh_size, comm=comm, **options)
    dim = bench.gdim
    V = fem.functionspace(bench.mesh, ("Lagrange", 1, (dim,)))
    mesh_data, _ = gather_mesh(V)
    sets = constrained_sets(bench, V)
    times = np.arange(steps + 1) * h
    contact = contact_object(benchmark, bench, V, material, times)
    if comm.rank != 0:
        return None, bench, V
    assert mesh_data is not None and sets is not None  # gathered on rank 0
    points, cells, cell_type = mesh_data
    points = np.ascontiguousarray(points[:, :dim])
    data = Exported(
        benchmark=benchmark,
        mesh_size=mesh_size,
        options={**bench.options},
        plane=plane if dim == 2 else None,
        material=material,
        model=model,
        procedure=procedure,
        h=h,
        steps=steps,
        nodes=points,
        cell_type=cell_type,
        cells=oriented(points, cells),
        node_sets=sets,
        motions={c.name: sample_motion(c.motion, times, dim) for c in bench.constraints},
        gravity=np.asarray(bench.gravity, dtype=np.float64)[:dim],
        probe=tuple(bench.probe) if bench.probe is not None else None,
        geometry=geometry(benchmark, bench.options),
        truth=truth_case(
            benchmark,
            bench.options,
            material,
            model,
            h,
            steps,
            plane if dim == 2 else None,
            procedure,
        ),
        contact=contact,
    )
    return data, bench, V


def run_reference(
    data: Exported | None,
    bench,
    material: Material,
    path: Path,
    solver: str = "direct",
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> dict:
    """Run our reference for the export (`implicit`, or `quasi-static` for the static
    procedure, with the export's model) as `tissuebench run` runs it, and write its
    displacement history to path (.xdmf, with its .h5). Collective; returns what the JSON's
    `reference` records."""
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.models import run_label
    from tissuebench.solvers.simulate import simulate
    from tissuebench.solvers.system import System
    from tissuebench.workflows.io.output import collective
    from tissuebench.workflows.io.xdmf import gather_series, write_series

    model, procedure, h, steps, plane = comm.bcast(
        (data.model, data.procedure, data.h, data.steps, data.plane or "strain")
        if comm.rank == 0 and data is not None
        else None,
        root=0,
    )
    algorithm = PROCEDURES[procedure]
    label = run_label(algorithm, model)
    system = System(bench, material, plane=plane)
    integrator = get_integrator(algorithm, system, h, solver=solver, model=model)
    try:
        run = simulate(integrator, steps, bench.extent, label)
    finally:
        integrator.destroy()
    readings = None
    if bench.contact is not None:  # SPEC 12: the needle force and interpenetration at each t_i
        from tissuebench.solvers.contact import Measures

        measure = Measures(system)
        readings = [measure(u, i * h) for i, u in enumerate(run.u)]
    series = gather_series(system.V, {REFERENCE_FIELD: run.u})
    collective(comm, lambda: write_series(path, series, np.arange(run.steps + 1) * h), path)
    info = {
        "file": path.name,
        "field": REFERENCE_FIELD,
        "run": label,
        "status": run.status,
        "steps": run.steps,
        "wall_time_s": run.wall_time_s,
    }
    if run.status != "ok":
        info["diverged_step"], info["reason"] = run.diverged_step, run.reason
    if readings is not None:
        unit = "N/m, x and y" if system.gdim == 2 else "N, x, y and z"
        info["contact"] = {
            "force": [[float(x) for x in r[:-1]] for r in readings],
            "interpenetration": [float(r[-1]) for r in readings],
            "meaning": f"our run's needle force F ({unit}) and interpenetration (m) at "
            "each t_i kept, as `contact.graded` defines them",
        }
    if comm.rank == 0:
        state = (
            "ok" if run.status == "ok" else f"DIVERGED at step {run.diverged_step}: {run.reason}"
        )
        log(f"reference {label}: {state}, {run.steps} steps in {run.wall_time_s:.2f} s")
    return info


# --- JSON -------------------------------------------------------------------------------------


def reference_path(out: Path) -> Path:
    """Where the reference's history goes beside an export: OUT-stem.reference.xdmf (+ .h5)."""
    return out.with_name(f"{out.stem}.reference.xdmf")


def export(
    benchmark: str,
    fmt: str,
    out: Path,
    *,
    mesh_size: int,
    options: dict,
    material: Material,
    model: str,
    h: float,
    steps: int,
    plane: str = "strain",
    procedure: str = "dynamic",
    element: str | None = None,
    reference: bool = True,
    solver: str = "direct",
    force: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> list[Path]:
    """Write the export of format fmt to out and, for json and inp unless reference is False,
    our reference's history beside it (reference_path). Every check comes before the heavy
    work; every file is written under a temporary name and renamed into place. Collective;
    returns the files written."""
    from tissuebench.meshes import get_entry
    from tissuebench.workflows.io.output import PREFIX, check_file_target, collective, write_owned

    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r}: use one of {', '.join(FORMATS)}")
    if procedure not in PROCEDURES:
        raise ExportError(f"unknown procedure {procedure!r}: use {' or '.join(PROCEDURES)}")
    entry = get_entry(benchmark)
    dim = entry.gdim
    if fmt == "inp" and entry.tool is not None:
        raise ExportError(
            f"the CalculiX deck does not pose {benchmark}'s rigid tool in contact: export it "
            "as json (its `contact` states the tool and the law)"
        )
    if fmt == "inp":
        element = element or default_element(dim, plane)
        check_element(element, dim, plane)
        check_inp_model(model)
    elif element is not None:
        raise ExportError(f"--element applies to --format inp only, not to {fmt}")
    with_reference = reference and fmt in ("json", "inp")
    ref_path = reference_path(out)
    also = [ref_path, ref_path.with_suffix(".h5")] if with_reference else []
    collective(comm, lambda: check_file_target(out, fmt, force, also))

    data, bench, _ = build(
        benchmark, mesh_size, options, material, model, h, steps, plane, procedure, comm
    )
    written = [out]
    if with_reference:
        staging = out.with_name(f"{PREFIX}export-{out.name}-{os.getpid()}")
        collective(comm, lambda: staging.mkdir(parents=True, exist_ok=True), staging)
        try:
            info = run_reference(data, bench, material, staging / ref_path.name, solver, comm, log)

            def place():
                for path in also[::-1]:  # the .h5 first: the .xdmf names it
                    write_owned(path, lambda tmp, name=path.name: os.replace(staging / name, tmp))

            collective(comm, place, ref_path)
        finally:
            if comm.rank == 0:
                for path in also:
                    (staging / path.name).unlink(missing_ok=True)
                if staging.is_dir():
                    staging.rmdir()
        if comm.rank == 0:
            data.reference = info
        written += also

    def write():
        if fmt == "json":
            write_owned(out, lambda p: write_json(data, p))
        elif fmt == "inp":
            write_owned(out, lambda p: write_inp(data, p, element))
        else:
            write_owned(out, lambda p: write_mesh(data, p, fmt))

    collective(comm, write, out)
    return written


def step_note(h: float, end_time: float, steps: int) -> str | None:
    """The line saying that h does not divide the end time, or None."""
    if math.isclose(steps * h, end_time, rel_tol=1e-9):
        return None
    return (
        f"end time {end_time:g} s is not a multiple of h = {h:g} s; exporting {steps} steps to "
        f"t = {steps * h:.6g} s"
    )
