"""A linear truth's runs side by side (issue 46: the first `make paper` in minutes).

store.compute() runs a case's hierarchy one run after another: each level n at the truth's step
h / k, the coarsest again at h / 2k and h / 4k (its time order) and the finest at h / 2k. These
runs are independent: compute_split() runs each in a worker process of its own (`python -m
tissuebench.solvers.truth.worker`, one rank, one BLAS thread), `jobs` at a time, longest first,
and then takes the same differences, estimate and samples from their kept steps as compute()
does, in the same order, on the same spaces. The numbers are compute()'s, bit for bit (a fresh
Truth's run is the run of one that ran before: Truth.run starts from initial_state(), and the
step matrix is factorised again for a new step); tests/test_truth_split.py checks it on the
quick rod-MP2. Only the wall times differ.

Linear cases without contact only (splittable()): a neo-Hookean or contact case's levels record
Newton's floor, failures and the penalty check as they go, which stay in compute().

Units: a unit (n, m) is level n at the step h / (m k), `m k steps` steps, its every (m k)-th
step kept (the steps of h); its worker writes u (the kept steps' owned dof values of V, m),
the kept steps' times (s), the probe's tip at every step (m), dofs, its wall time (s) and, for
m = 1 with a probe, the static tip (m; NaN with `static_error` where the static solve failed).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core import interrupt
from tissuebench.solvers.truth import PACKAGE_CASES
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.estimate import interior_difference
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.solvers.truth.solver import TruthRun

Unit = tuple[int, int]  # (level n, step fraction m): level n at h / (m k)
# one BLAS/OpenMP thread per worker process (the processes themselves share the cores)
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
POLL_SECONDS = 0.2


def splittable(case: str, quick: bool = False) -> bool:
    """Whether a case's runs go side by side (compute_split): the linear law, no contact, not a
    floor case, one the package defines, and not its quick truth (`quick`: seconds in one
    process, where workers would only add their start-up)."""
    from tissuebench.meshes import in_contact
    from tissuebench.solvers.truth.floor import FLOOR_CASES

    # a worker process knows the package's cases only: one registered from elsewhere (the
    # tests' toy plate) computes in its own process
    if quick or case not in PACKAGE_CASES or case in FLOOR_CASES:
        return False
    benchmark, _, model, _, _ = CASES[case]
    return model == "linear" and not in_contact(benchmark)


def units_of(levels: tuple[int, ...]) -> list[Unit]:
    """The runs of a hierarchy: every level at the step, the coarsest at its half and quarter,
    the finest at its half."""
    return [(n, 1) for n in levels] + [(levels[0], 2), (levels[0], 4), (levels[-1], 2)]


def weight(unit: Unit, dim: int) -> float:
    """A unit's relative cost: its steps (m) times its cells (n^dim)."""
    n, m = unit
    return float(m * n**dim)


def split_share(levels: tuple[int, ...], benchmark: str, jobs: int) -> float:
    """The share of a case's one-core time that its runs take `jobs` at a time, longest first
    (run_units' order): the busiest worker's weight over the total (the runs' costs taken as
    their weights)."""
    from tissuebench.meshes import get_entry

    dim = get_entry(benchmark).gdim
    weights = sorted((weight(u, dim) for u in units_of(levels)), reverse=True)
    workers = [0.0] * max(jobs, 1)
    for w in weights:  # each run to the worker that is free first
        workers[workers.index(min(workers))] += w
    return max(workers) / sum(weights)


def worker_command(case: str, quick: bool, unit: Unit, out: Path) -> list[str]:
    """The command line of one unit's worker."""
    n, m = unit
    module = "tissuebench.solvers.truth.worker"
    return [sys.executable, "-m", module, case, str(n), str(m), str(int(quick)), str(out)]


def run_units(
    case: str,
    quick: bool,
    units: list[Unit],
    jobs: int,
    folder: Path,
    say: Callable[[str], None],
    dim: int,
) -> dict[Unit, Path]:
    """Run the units, `jobs` at a time, longest first (weight), each in a worker process; the
    file each wrote. RuntimeError (with the worker's last lines) if one fails; a signal stops
    them all (core/interrupt.py)."""
    pending = sorted(units, key=lambda u: -weight(u, dim))
    env = {**os.environ, **dict.fromkeys(THREAD_VARS, "1")}
    running: dict[Unit, tuple[subprocess.Popen, float, Path]] = {}
    done: dict[Unit, Path] = {}
    try:
        while pending or running:
            while pending and len(running) < jobs:
                unit = pending.pop(0)
                out, log = folder / f"{unit[0]}-{unit[1]}.npz", folder / f"{unit[0]}-{unit[1]}.log"
                with open(log, "w") as err:
                    process = subprocess.Popen(
                        worker_command(case, quick, unit, out),
                        stdout=subprocess.DEVNULL,
                        stderr=err,
                        env=env,
                    )
                running[unit] = (process, time.perf_counter(), out)
            time.sleep(POLL_SECONDS)
            interrupt.checkpoint(MPI.COMM_SELF)
            for unit, (process, started, out) in list(running.items()):
                code = process.poll()
                if code is None:
                    continue
                del running[unit]
                n, m = unit
                if code != 0 or not out.is_file():
                    lines = (folder / f"{n}-{m}.log").read_text().strip().splitlines()[-5:]
                    raise RuntimeError(
                        f"truth {case}: the run of level {n} at h/{m}k failed (exit {code}): "
                        + " | ".join(lines)
                    )
                done[unit] = out
                say(
                    f"{case} n={n}{'' if m == 1 else f' at h/{m}k'}: "
                    f"{time.perf_counter() - started:.1f} s ({len(done)} of {len(units)} runs)"
                )
    finally:
        interrupt.stop_children([process for process, _, _ in running.values()])
    return done


def _load(path: Path, V) -> tuple[TruthRun, dict]:
    """A unit's TruthRun on V and the arrays its worker wrote."""
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    run = TruthRun(
        V=V,
        times=arrays["times"],
        u=arrays["u"],
        tip=arrays.get("tip"),
        dofs=int(arrays["dofs"]),
        wall=float(arrays["wall"]),
    )
    return run, arrays


@dataclass(frozen=True)
class Levels:
    """What a split computation takes from the store (solvers/truth/store.py hands them in: it
    imports this module, never the other way): the case's inputs, a level's Truth, the levels,
    the own error and the samples, as store.compute() uses them."""

    inputs: Callable[..., dict]
    level_truth: Callable[..., tuple]
    levels_of: Callable[..., tuple[int, ...]]
    own_error: Callable[..., dict]
    sample: Callable[..., TruthSamples | None]


def compute_split(
    case: str, quick: bool, jobs: int, parts: Levels, log: Callable[[str], None] | None = None
) -> TruthSamples | None:
    """store.compute()'s TruthSamples of a splittable case on one rank, its runs `jobs` at a
    time in worker processes (store.compute_split hands in `parts`). `log` hears each run's
    end."""
    inputs, level_truth, levels_of = parts.inputs, parts.level_truth, parts.levels_of
    own_error, sample = parts.own_error, parts.sample
    say = log or (lambda line: None)
    comm = MPI.COMM_SELF
    start = time.perf_counter()
    given = inputs(case, quick)
    steps, k = given["steps"], given["step_divisor"]
    levels = levels_of(case, quick)
    units = units_of(levels)
    truth, bench = level_truth(case, levels[0], comm)
    dim = bench.mesh.geometry.dim
    with tempfile.TemporaryDirectory(prefix=f"tissuebench-truth-{case}-") as tmp:
        files = run_units(case, quick, units, min(jobs, len(units)), Path(tmp), say, dim)
        info: dict = {"levels": [], "dofs": [], "wall": [], "steps": steps, "level_differences": []}
        tips, statics = [], []
        previous = None
        for n in levels:
            if n != levels[0]:
                truth, bench = level_truth(case, n, comm)
            run, extra = _load(files[(n, 1)], truth.V)
            info["levels"].append(n)
            info["dofs"].append(run.dofs)
            info["wall"].append(run.wall)
            info["h"], info["step"] = bench.dt, bench.dt / k
            if run.tip is not None:
                tips.append(np.asarray(run.tip)[::k].tolist())
                if "static_error" in extra:
                    say(f"{case} n={n}: {extra['static_error']}; its static tip is not reported")
                statics.append(extra["static"].tolist())
            if previous is not None:
                info["level_differences"].append(interior_difference(previous, run).tolist())
                previous.u = None
            if previous is None:
                half, _ = _load(files[(n, 2)], truth.V)
                quarter, _ = _load(files[(n, 4)], truth.V)
                pairs = ((run, half), (half, quarter))
                info["time_order_differences"] = [
                    float(interior_difference(a, b).max()) for a, b in pairs
                ]
            previous = run
        half, _ = _load(files[(levels[-1], 2)], truth.V)
    info["half_wall"] = half.wall
    if half.tip is not None:
        info["half_tip"] = np.asarray(half.tip)[::k].tolist()
    time_ei = interior_difference(run, half)
    info["time_difference"] = time_ei.tolist()
    half = None
    if tips:
        info["tip"], info["static_tip"] = tips, statics
    own = own_error(info, time_ei, dim)
    samples = sample(truth, run, case, own, given, info)
    if samples is not None:
        samples.hierarchy["total_wall"] = time.perf_counter() - start
    return samples
