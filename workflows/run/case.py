"""A case of the study: several runs on one benchmark mesh, measured against a reference run.

A case directory holds, for every run `label`: label.xdmf + label.h5 (displacement and
velocity at every step), and for the case: metrics.csv, summary.json and the figures.
"""

import math
import os
import platform
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Literal, NamedTuple

from mpi4py import MPI

import numpy as np
from tqdm import tqdm

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.core.fingerprint import fingerprint
from tissuebench.meshes import get_benchmark, get_entry
from tissuebench.meshes.gmshio import check_positive_int
from tissuebench.metrics import Metrics
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.series import InputError
from tissuebench.metrics.table import METRICS
from tissuebench.solvers import ALGORITHMS, REFERENCE
from tissuebench.solvers.contact import Measures
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.models import LINEAR, REFERENCE_MODEL, run_label
from tissuebench.solvers.schemes import STANDARD, scheme_label
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.substeps import sub_stepped, substep_count
from tissuebench.solvers.system import System, probe
from tissuebench.workflows.io.limits import check as check_limits
from tissuebench.workflows.io.limits import estimate, step_count
from tissuebench.workflows.io.output import RunFolder, collective
from tissuebench.workflows.io.summary import (
    SUMMARY,
    CaseSummary,
    RunSummary,
    read_case_summary,
    read_summary,
    write_case_summary,
)
from tissuebench.workflows.io.tables import write_contact_csv, write_metrics_csv, write_tip_csv
from tissuebench.workflows.io.xdmf import as_series, gather_series, write_series
from tissuebench.workflows.run.contact_figures import plot_contact
from tissuebench.workflows.run.contact_readings import contact_readings
from tissuebench.workflows.run.phases import Phases


class RunSpec(NamedTuple):
    """One run of a case: its label (the name in files and tables), algorithm, material and
    elastic model (SPEC section 8)."""

    label: str
    algorithm: str
    material: object  # a material name, file or Material
    model: str = LINEAR


@dataclass
class Case:
    """Runs (RunSpec, or tuples of its fields) on one benchmark; `reference` is a label.

    None for mesh_size, dt or end_time means the benchmark's default; `options` are the
    benchmark's own options (for the block: needle_width, m); `petsc` the PETSc options text
    in force (it changes the numbers, so it is part of the fingerprint)."""

    name: str
    benchmark: str
    runs: list
    reference: str
    mesh_size: int | None = None
    dt: float | None = None
    end_time: float | None = None
    options: dict = field(default_factory=dict)
    plane: str = "strain"
    solver: str = "direct"
    petsc: str = ""
    description: str = ""
    scheme: str = "standard"  # SPEC 11: the element's scheme, NAME or NAME:key=value,...
    substeps: int | Literal["auto"] = (
        1  # SPEC 11: sub-steps of the explicit runs per step h, or "auto"
    )

    def __post_init__(self):
        self.runs = [RunSpec(*run) for run in self.runs]


def algorithm_case(
    name: str, benchmark: str, material: object, algorithms: list[str], **options
) -> "Case":
    """The usual case: each algorithm on one material, against `implicit` on that material."""
    labels = list(dict.fromkeys([REFERENCE, *algorithms]))
    return Case(name, benchmark, [(a, a, material) for a in labels], REFERENCE, **options)


def model_case(
    name: str,
    benchmark: str,
    material: object,
    algorithms: list[str],
    models: list[str],
    reference: str | None = None,
    **options,
) -> "Case":
    """Every algorithm with every model on one material (SPEC section 8), against `reference`,
    a run label that must be among them. Without one, the reference is `implicit` with the
    first of linear, neo-hookean and neo-hookean-barrier among the models (with neo-hookean
    when none is), and it always runs."""
    runs = {run_label(a, m): (a, m) for m in models for a in algorithms}
    if reference is not None and reference not in runs:
        raise UserError(
            f"reference {reference!r} is not among the runs ({', '.join(runs)}): "
            "name one of them, ALGORITHM or ALGORITHM+MODEL"
        )
    if reference is None:
        preferred = (LINEAR, REFERENCE_MODEL, "neo-hookean-barrier")
        model = next((m for m in preferred if m in models), REFERENCE_MODEL)
        reference = run_label(REFERENCE, model)
        runs = {reference: (REFERENCE, model), **runs}
    specs = [RunSpec(label, a, material, m) for label, (a, m) in runs.items()]
    specs.sort(key=lambda r: r.label != reference)  # the reference first
    return Case(name, benchmark, specs, reference, **options)


def versions() -> dict[str, str]:
    from importlib.metadata import version

    import petsc4py

    import dolfinx
    import gmsh
    import shapely

    return {
        "tissuebench": version("tissuebench"),
        "python": platform.python_version(),
        "dolfinx": dolfinx.__version__,
        "petsc4py": petsc4py.__version__,
        "gmsh": gmsh.__version__,
        "shapely": shapely.__version__,
        "manifold3d": version("manifold3d"),
        "mpi_ranks": MPI.COMM_WORLD.size,
    }


def nan_to_none(x: float) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else x


def case_inputs(case: Case, mesh_size: int, h: float, n_steps: int, materials: dict) -> dict:
    """Every input that changes the case's numbers (its fingerprint is their hash)."""
    v = versions()
    return {
        "benchmark": case.benchmark,
        "mesh_size": mesh_size,
        "options": dict(sorted(case.options.items())),
        "plane": case.plane if get_entry(case.benchmark).gdim == 2 else None,
        "h": h,
        "steps": n_steps,
        "solver": case.solver,
        "petsc": " ".join(case.petsc.split()),
        "reference": case.reference,
        "runs": [
            {
                "label": run.label,
                "algorithm": run.algorithm,
                "material": asdict(materials[run.material]),
                # the linear model is left out, so that the results of the paper's study
                # (sections 1-7) keep the fingerprint they had before models existed
                **({"model": run.model} if run.model != LINEAR else {}),
            }
            for run in case.runs
        ],
        "versions": {k: v[k] for k in ("tissuebench", "dolfinx", "petsc4py")},
        # SPEC 11, only where not the paper's: the inputs of earlier results are unchanged
        **({"scheme": scheme_label(case.scheme)} if case.scheme != STANDARD else {}),
        **({"substeps": case.substeps} if case.substeps != 1 else {}),
    }


def run_case(
    case: "Case",
    out_dir: Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] = print,
    force: bool = False,
    figures: bool = True,
) -> CaseSummary:
    """Run every run of the case, measure it against the reference and write the case folder
    (whole, or not at all; see workflows/io/output.py for which folders may be written). Returns
    its summary (workflows/io/summary.py), whose `phases_s` holds the wall time of each phase;
    complete results of the same inputs are kept and their summary returned, with `skipped`
    set, unless `force`, or unless they lack the figures and `figures` asks for them. Without
    `figures` no figure is drawn (and none is listed in the summary's files)."""
    rank0 = comm.rank == 0
    entry = get_entry(case.benchmark)
    mesh_size = entry.mesh_size if case.mesh_size is None else case.mesh_size
    check_positive_int("mesh size", mesh_size)
    h = entry.dt if case.dt is None else case.dt
    end_time = entry.end_time if case.end_time is None else case.end_time
    n_steps = step_count(h, end_time)
    materials = {m: get_material(m) for m in dict.fromkeys(run.material for run in case.runs)}
    inputs = case_inputs(case, mesh_size, h, n_steps, materials)
    explicit = [run for run in case.runs if ALGORITHMS[run.algorithm].explicit]
    if isinstance(case.substeps, int) and case.substeps > 1 and explicit:
        said = substep_count(case.substeps, h, n_steps, len(explicit))  # or refused: too many
        if rank0:
            log(f"{case.name}: {said}")

    with RunFolder(out_dir, comm) as folder:
        state = folder.prepare(inputs, force)
        if state == "complete" and figures:
            drawn = comm.bcast(has_figures(folder.path) if rank0 else None, root=0)
            if not drawn:  # written with --no-figures: the same inputs, run again to draw them
                if rank0:
                    log(f"{out_dir}: complete results without figures, run again to draw them")
                state = folder.prepare(inputs, True)
        if state == "complete":
            if rank0:
                log(
                    f"{out_dir}: complete results for the same inputs exist, skipped (--force "
                    "reruns)"
                )
            summary = comm.bcast(read_case_summary(folder.path) if rank0 else None, root=0)
            if summary is None:  # prepare found it complete: it was there a moment ago
                raise UserError(f"{folder.path}: its summary.json could not be read")
            summary.skipped = True
            return summary
        need = estimate(entry.gdim, entry.nodes(mesh_size), n_steps, len(case.runs), comm.size)
        check_limits(need, folder.path.parent, comm)
        if rank0 and not math.isclose(n_steps * h, end_time, rel_tol=1e-9):
            log(
                f"{case.name}: end time {end_time:g} s is not a multiple of h = {h:g} s; "
                f"running {n_steps} steps to t = {n_steps * h:.6g} s"
            )
        with folder.writing() as tmp:
            summary = compute_case(
                case, tmp, folder.path, inputs, mesh_size, h, n_steps, materials, comm, log, figures
            )
    return summary


def has_figures(folder: Path) -> bool:
    """True if the case folder's summary lists a figure (a PNG): False for one written without
    figures (`tissuebench run --no-figures`)."""
    summary = read_summary(folder) or {}
    files = summary.get("files")
    return isinstance(files, list) and any(str(f).endswith(".png") for f in files)


def compute_case(
    case: "Case",
    tmp: Path,
    target: Path,
    inputs: dict,
    mesh_size: int,
    h: float,
    n_steps: int,
    materials: dict,
    comm: MPI.Comm,
    log: Callable[[str], None],
    figures: bool = True,
) -> CaseSummary:
    """The runs, metrics, figures (unless not `figures`) and summary of a case, written into
    tmp, which becomes target, with the wall time of each phase. Collective."""
    rank0 = comm.rank == 0
    # progress bars on rank 0, unless a worker's parent says its own lines (paper's beside)
    bars = rank0 and os.environ.get("TISSUEBENCH_PROGRESS_BARS") != "0"
    phases = Phases()
    with phases.timed("mesh"):
        bench = get_benchmark(case.benchmark, mesh_size=mesh_size, comm=comm, **case.options)
    start = time.perf_counter()
    with phases.timed("forms"):
        systems = {
            m: System(bench, materials[m], plane=case.plane, scheme=case.scheme) for m in materials
        }
    system_s = (time.perf_counter() - start) / len(systems)  # M, K, f of one material

    results, tips, shapes = {}, {}, {}  # shapes: the runs' displacement Series (rank 0)
    contacts = {}  # SPEC 12, 13: each run's (F's gdim components, interpenetration) a step kept
    measures: dict = {}  # SPEC 12: each material system's Measures
    for label, algorithm, material, model in case.runs:
        system = systems[material]
        with phases.timed(f"run {label}"):  # its set-up (assembly, factorisations) and loop
            start = time.perf_counter()
            integrator, k, critical = sub_stepped(
                algorithm, system, h, case.substeps, solver=case.solver, model=model
            )
            setup_s = time.perf_counter() - start  # assembly and factorisations before the loop
            if k != 1:
                said = substep_count(k, h, n_steps)  # auto's k: refused where it is too many
                if rank0:
                    log(f"{case.name:>18} {label:<18} {said}")
            bar = tqdm(
                total=n_steps,
                desc=f"{case.name} {label}",
                unit="step",
                leave=False,
                disable=not bars,
                mininterval=0.5,
            )
            try:
                run = simulate(
                    integrator,
                    n_steps,
                    bench.extent,
                    label,
                    on_step=lambda state: bar.update(1 if state.i else 0),
                )
            finally:
                bar.close()  # also when interrupted: the last line is then the error's
            integrator.destroy()
        results[label] = (run, material, algorithm, model, setup_s, k, critical)
        if rank0:
            said = (
                "ok"
                if run.status == "ok"
                else f"DIVERGED at step {run.diverged_step} (t = {run.diverged_time:.4g} s)"
            )
            if run.reason:
                said += f": {run.reason}"
            log(
                f"{case.name:>18} {label:<18} {systems[material].material.name}: {said}, "
                f"{run.steps} steps in {run.wall_time_s:.2f} s"
            )

    with phases.timed("output"):
        for label, (run, material, *_) in results.items():
            V = systems[material].V
            series = gather_series(V, {"displacement": run.u, "velocity": run.v})
            stamps = np.arange(run.steps + 1) * h
            collective(comm, lambda: write_series(tmp / f"{label}.xdmf", series, stamps), target)
            if rank0 and figures:  # for the figures, as reading the file back would give it
                assert series is not None  # gathered on rank 0
                try:
                    shapes[label] = as_series(tmp / f"{label}.xdmf", series, stamps)
                except InputError:  # no step kept (diverged at step 0): the figures read nothing
                    pass

    metrics_start = time.perf_counter()
    metrics = Metrics(next(iter(systems.values())).V)
    for label, (run, material, *_) in results.items():
        system = systems[material]
        if bench.probe is not None:
            tips[label] = np.reshape(  # (steps kept, gdim): none if step 0 diverged
                [probe(system.V, u, bench.probe) for u in run.u], (len(run.u), system.gdim)
            )
        if bench.contact is not None:
            if material not in measures:  # its forms compiled once per system
                measures[material] = Measures(system)
            measure = measures[material]
            contacts[label] = np.reshape(
                [measure(u, i * h) for i, u in enumerate(run.u)], (len(run.u), system.gdim + 1)
            )
    ref_run = results[case.reference][0]
    times = np.arange(n_steps + 1) * h
    curves, status = {}, {}
    bar = tqdm(  # each candidate's step twice: its E_n and E_i, then its E_s (Metrics.histories)
        total=2 * sum(min(len(ref_run.u), len(run.u)) for run, *_ in results.values()),
        desc=f"{case.name} metrics",
        unit="step",
        leave=False,
        disable=not bars,
        mininterval=0.5,
        miniters=1,  # not tqdm's guess from the fast first pass, which skipped the slow second
    )
    try:
        histories = metrics.histories(
            ref_run.u,
            {label: run.u for label, (run, *_) in results.items()},
            on_step=lambda: bar.update(1),
        )
        for label, (run, *_) in results.items():
            curves[label] = {name: np.full(n_steps + 1, np.nan) for name in METRICS}
            for name, values in histories[label].items():  # the steps both have
                curves[label][name][: len(values)] = values
            status[label] = np.full(n_steps + 1, "ok", dtype=object)
            if ref_run.status == "diverged":  # NaN from the diverged step on, the reference's too
                status[label][ref_run.diverged_step :] = "reference diverged"
            if run.status == "diverged":
                status[label][run.diverged_step :] = "diverged"
            for name in METRICS:
                curves[label][name][status[label] != "ok"] = np.nan
    finally:
        bar.close()  # also when interrupted: the last line is then the error's
    phases.times["metrics"] = time.perf_counter() - metrics_start

    summary = CaseSummary(
        case=case.name,
        description=case.description,
        benchmark=case.benchmark,
        material=sorted({s.material.name for s in systems.values()}),
        reference=case.reference,
        mesh_size=bench.mesh_size,
        num_dofs=next(iter(systems.values())).num_dofs(),
        h=h,
        end_time=n_steps * h,
        steps=n_steps,
        plane=inputs["plane"],
        options=dict(case.options),
        solver=case.solver,
        system_time_s=system_s,
        versions=versions(),
    )
    for label, (run, material, algorithm, model, setup_s, k, critical) in results.items():
        readings = {}
        for name in METRICS:
            peak, mean = summarize(curves[label][name])
            readings[f"{name}_max"], readings[f"{name}_mean"] = nan_to_none(peak), nan_to_none(mean)
        summary.runs[label] = RunSummary(
            algorithm=algorithm,
            model=model,
            material=systems[material].material.name,
            status=run.status,
            diverged_step=run.diverged_step,
            diverged_time=run.diverged_time,
            reason=run.reason,
            steps=run.steps,
            wall_time_s=run.wall_time_s,
            setup_time_s=setup_s,
            readings=readings,
            has_probe=label in tips,
            tip_displacement_final=(
                tips[label][-1].tolist() if label in tips and len(tips[label]) else None
            ),
            scheme=scheme_label(case.scheme),
            substeps=k,
            critical_dt_s=critical,
            contact=contact_readings(contacts[label]) if label in contacts else None,
        )

    def write():
        with phases.timed("output"):
            files = [f"{label}.{ext}" for label in results for ext in ("xdmf", "h5")]
            write_metrics_csv(tmp / "metrics.csv", times, curves, status)
            if tips:
                write_tip_csv(tmp / "tip.csv", times, tips)
                files.append("tip.csv")
            if contacts:
                write_contact_csv(tmp / "contact.csv", times, contacts)
                files.append("contact.csv")
        if figures:
            with phases.timed("figures"):
                if contacts:
                    tool = bench.contact.tool if bench.contact is not None else None
                    plot_contact(tmp / "contact.png", case.name, times, contacts, tool)
                    files.append("contact.png")
                from tissuebench.workflows.run import figures as drawn

                files += drawn.case_figures(tmp, case, summary, times, curves, tips, shapes)
        summary.files = ["metrics.csv", *files, SUMMARY]
        summary.inputs, summary.fingerprint = inputs, fingerprint(inputs)
        summary.phases_s = dict(phases.times)  # the summary's own writing is not in them
        write_case_summary(tmp, summary)  # last: it marks the folder ours
        return summary

    summary = collective(comm, write, target)
    interrupt.checkpoint(comm)  # a signal on any rank: every rank stops before the commit
    return summary
