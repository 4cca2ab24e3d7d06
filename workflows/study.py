"""A case of the study: several runs on one benchmark mesh, measured against a reference run.

A case directory holds, for every run `label`: label.xdmf + label.h5 (displacement and
velocity at every step), and for the case: metrics.csv, summary.json and the figures.
"""

import csv
import json
import math
import platform
from dataclasses import dataclass, field

from mpi4py import MPI

import numpy as np
from tqdm import tqdm

from tissuebench.meshes import get_benchmark
from tissuebench.metrics import Metrics
from tissuebench.metrics.compare import COLUMNS, summarize
from tissuebench.metrics.errors import NAMES
from tissuebench.solvers import REFERENCE, get_integrator
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System, probe
from tissuebench.workflows.output import SUMMARY, partial_directory
from tissuebench.workflows.xdmf import write_xdmf


@dataclass
class Case:
    """Runs (label, algorithm, material) on one benchmark; `reference` is a label."""

    name: str
    benchmark: str
    runs: list
    reference: str
    mesh_size: int | None = None
    dt: float | None = None
    end_time: float | None = None
    needle_width: float = 0.0
    plane: str = "strain"
    solver: str = "direct"
    description: str = ""
    extra: dict = field(default_factory=dict)


def algorithm_case(name, benchmark, material, algorithms, **options):
    """The usual case: each algorithm on one material, against `implicit` on that material."""
    labels = list(dict.fromkeys([REFERENCE, *algorithms]))
    return Case(name, benchmark, [(a, a, material) for a in labels], REFERENCE, **options)


def versions():
    import dolfinx
    import petsc4py
    import gmsh
    import shapely

    from importlib.metadata import version

    return {"tissuebench": version("tissuebench"), "python": platform.python_version(),
            "dolfinx": dolfinx.__version__, "petsc4py": petsc4py.__version__,
            "gmsh": gmsh.__version__, "shapely": shapely.__version__,
            "manifold3d": version("manifold3d"), "mpi_ranks": MPI.COMM_WORLD.size}


def nan_to_none(x):
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else x


def run_case(case, out_dir, comm=MPI.COMM_WORLD, log=print):
    """Run every run of the case, measure it against the reference and write the case
    directory (whole, or not at all). Returns the summary dict."""
    rank0 = comm.rank == 0
    options = {"mesh_size": case.mesh_size} if case.mesh_size is not None else {}
    if case.benchmark == "block":
        options["needle_width"] = case.needle_width
    bench = get_benchmark(case.benchmark, comm=comm, **options)
    h = case.dt or bench.dt
    end_time = case.end_time or bench.end_time
    n_steps = max(1, round(end_time / h))
    systems = {m: System(bench, m, plane=case.plane) for m in dict.fromkeys(m for _, _, m in case.runs)}
    metrics = Metrics(next(iter(systems.values())).V)

    results, tips = {}, {}
    with partial_directory(out_dir, comm) as tmp:
        for label, algorithm, material in case.runs:
            system = systems[material]
            integrator = get_integrator(algorithm, system, h, solver=case.solver)
            bar = tqdm(total=n_steps, desc=f"{case.name} {label}", unit="step", leave=False,
                       disable=not rank0, mininterval=0.5)
            run = simulate(integrator, n_steps, bench.extent, label,
                           on_step=lambda state: bar.update(1 if state.i else 0))
            bar.close()
            write_xdmf(tmp / f"{label}.xdmf", system.V, np.arange(run.steps + 1) * h,
                       {"displacement": run.u, "velocity": run.v})
            results[label] = (run, material, algorithm)
            if bench.probe is not None:
                tips[label] = np.array([probe(system.V, u, bench.probe) for u in run.u])
            if rank0:
                status = "ok" if run.status == "ok" else f"DIVERGED at step {run.diverged_step} (t = {run.diverged_time:.4g} s)"
                log(f"{case.name:>18} {label:<18} {material}: {status}, {run.steps} steps in {run.wall_time_s:.2f} s")

        ref = results[case.reference][0].u
        times = np.arange(n_steps + 1) * h
        curves = {label: metrics.history(ref, run.u) for label, (run, _, _) in results.items()}
        for label, (run, _, _) in results.items():  # NaN from the diverged step on
            if run.status == "diverged":
                for name in NAMES:
                    curves[label][name][run.diverged_step:] = np.nan

        summary = {
            "case": case.name, "description": case.description, "benchmark": case.benchmark,
            "material": sorted({s.material.name for s in systems.values()}), "reference": case.reference,
            "mesh_size": bench.mesh_size, "num_dofs": next(iter(systems.values())).num_dofs(),
            "h": h, "end_time": n_steps * h, "steps": n_steps, "plane": case.plane,
            "needle_width": case.needle_width if case.benchmark == "block" else None,
            "solver": case.solver, "versions": versions(), "runs": {}, **case.extra,
        }
        for label, (run, material, algorithm) in results.items():
            entry = {"algorithm": algorithm, "material": systems[material].material.name, "status": run.status,
                     "diverged_step": run.diverged_step, "diverged_time": run.diverged_time,
                     "steps": run.steps, "wall_time_s": run.wall_time_s}
            for name in NAMES:
                peak, mean = summarize(curves[label][name])
                entry[f"{name}_max"], entry[f"{name}_mean"] = nan_to_none(peak), nan_to_none(mean)
            if label in tips:
                entry["tip_displacement_final"] = tips[label][-1].tolist()
            summary["runs"][label] = entry

        files = [f"{label}.{ext}" for label in results for ext in ("xdmf", "h5")]
        if rank0:
            write_metrics_csv(tmp / "metrics.csv", times, curves)
            if tips:
                write_tip_csv(tmp / "tip.csv", times, tips)
                files.append("tip.csv")
            from tissuebench.workflows import figures

            files += figures.case_figures(tmp, case, summary, times, curves, tips)
            summary["files"] = ["metrics.csv", *files, SUMMARY]
            (tmp / SUMMARY).write_text(json.dumps(summary, indent=2) + "\n")
    return comm.bcast(summary if rank0 else None, root=0)


def write_metrics_csv(path, times, curves):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(COLUMNS)
        for label, curve in curves.items():
            for i, t in enumerate(times):
                writer.writerow([label, i, repr(float(t)), *(repr(float(curve[n][i])) for n in NAMES)])


def write_tip_csv(path, times, tips):
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        d = next(iter(tips.values())).shape[1]
        writer.writerow(["algorithm", "step", "time", *("u_" + "xyz"[k] for k in range(d))])
        for label, tip in tips.items():
            for i, t in enumerate(times[: len(tip)]):
                writer.writerow([label, i, repr(float(t)), *(repr(float(x)) for x in tip[i])])
