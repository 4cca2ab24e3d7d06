"""The measurements of `tissuebench bench`: the driver that runs the worker processes
(workflows/bench/workers.py), the budget model, the capacity search and the timing of
`tissuebench paper`.

Each measurement runs in a fresh worker process (`python -m tissuebench.workflows.bench.workers
--worker ...`, under `mpiexec -n 2` for the 2-rank column) with BLAS/OpenMP threads pinned to
one per rank (THREAD_VARS), so that peak memory is per process and nothing is shared between
the sides. A case whose predicted cost (setup + steps, scaled from the size before) exceeds
its budget is skipped from then on.

A record is one (benchmark, size): {"benchmark", "size", "dofs", "ours1", "ours2", "peer",
"diff_peer", "diff_2ranks", "wall_s"}, each side a worker's result with its "cases" keyed
'algorithm/solver'; an algorithm with a nonlinear elastic model (SPEC 8) is named by its run
label, 'explicit-lumped+neo-hookean/-'. Beside the sweep: the Newton iterations per implicit
step of each nonlinear model at the paper's loads (newton_iterations). Units: seconds, bytes,
degrees of freedom.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np

from tissuebench.workflows.bench.machine import LOAD_LIMIT, LoadMeter, noisy
from tissuebench.workflows.io.output import PREFIX, make_temporary, remove_temporary, write_owned

STEPS = 30  # steps of a timed run; the displacements after them are compared
SHORT = 12  # steps of a run too costly for STEPS (no displacement check)
WARMUP = {STEPS: 5, SHORT: 2}  # first steps left out of the per-step median (25 or 10 remain)
SAFETY = 0.9  # explicit schemes run at SAFETY x their critical step 2 / omega_max (<= 1/30 s)
DIRECT_TOL = 1e-10  # relative displacement difference allowed between direct solvers
THREAD_VARS = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)
# the sweep's benchmarks: the first sets the sizes (ROD_SIZES), the second takes the sizes whose
# dofs come closest; the real-time capacity search bisects the first's size
SWEPT = ("rod", "block")
CAPACITY_BENCHMARK = SWEPT[0]
ROD_SIZES = {"quick": [2, 6, 10], "full": [2, 4, 8, 12, 16, 24, 32, 48]}
# Budgets (s) of one case (predicted setup + steps on one rank; "main" cases are the targets',
# "iterative" the implicit step's CG cases, whose target is at 7e5 dofs) and of the peer's
# assembly (the rod at 7e5 dofs takes about 4 minutes).
BUDGET = {
    "quick": {"main": 10.0, "iterative": 10.0, "other": 5.0, "assembly": 10.0},
    "full": {"main": 30.0, "iterative": 200.0, "other": 8.0, "assembly": 300.0},
}
OURS_ITERATIVE = ("cg", "gamg")  # our iterative solvers; pyamg is their peer
ITERATIVE = OURS_ITERATIVE + ("pyamg",)

# (algorithm, solver): ours with tissuebench's solver names, the peer with its own.
OURS_CASES = [
    ("explicit-lumped", "-"),
    ("implicit", "direct"),
    ("implicit", "cg"),
    ("implicit", "gamg"),
    ("implicit-lumped", "direct"),
    ("explicit", "direct"),
    ("quasi-static", "direct"),
]
# SPEC 8 and 11: the explicit-lumped step with a nonlinear model or a remedy, run in the sweep
# beside the linear one (same worker, same h: the linear scheme's on the plain Q1 mesh); the
# first has a real-time target. A label's "@SCHEME" names a SPEC 11 scheme (case_scheme):
# mean-dilatation with a nonlinear model is F-bar; alone, the linear B-bar stiffness.
MODEL_CASES = [
    ("explicit-lumped+neo-hookean", "-"),
    ("explicit-lumped+corotational", "-"),
    ("explicit-lumped+svk", "-"),
    ("explicit-lumped+neo-hookean-barrier", "-"),
    ("explicit-lumped+neo-hookean@mean-dilatation", "-"),
    ("explicit-lumped@mean-dilatation", "-"),
]
# `tissuebench bench --only explicit-models`: these cases alone, 1 rank (measure_explicit)
EXPLICIT_CASES = [("explicit-lumped", "-"), *MODEL_CASES]
MAIN_CASES = {
    ("explicit-lumped", "-"),
    ("implicit", "direct"),
    ("implicit", "cg"),
    ("implicit", "gamg"),
    ("implicit", "pardiso"),
    ("implicit", "superlu"),
    ("implicit", "pyamg"),
    *MODEL_CASES,
}
# the cases whose real-time capacity is bisected between two sizes of the sweep
CAPACITY_CASES = (("explicit-lumped", "-"), ("implicit", "direct"), MODEL_CASES[0])
# Newton iterations per implicit step at the paper's loads (SPEC 8: s = 1, h and T of the
# benchmark, its default material and mesh size: block MP1 N = 20, rod MP3 n = 3)
NEWTON_MODELS = ("svk", "neo-hookean", "corotational")
NEWTON_BENCHMARKS = ("block", "rod")
DIRECT = {"direct", "superlu", "pardiso"}
EXPLICIT = ("explicit", "explicit-lumped")

ROUNDS = 6  # rounds of the explicit-models worker: each case takes BLOCK steps per round
BLOCK = 5  # steps of a case in a row; the first BLOCK_WARM of each are not timed (its caches)
BLOCK_WARM = 2

WORKER_MODULE = "tissuebench.workflows.bench.workers"  # run by `python -m` in every worker


def peer_cases(pardiso: bool) -> list[tuple[str, str]]:
    """The peer's (algorithm, solver) cases: PARDISO where pypardiso has MKL, else SuperLU."""
    best = "pardiso" if pardiso else "superlu"
    cases = [("explicit-lumped", "-"), ("implicit", "superlu"), ("implicit", "pyamg")]
    if pardiso:
        cases.insert(1, ("implicit", "pardiso"))
    return cases + [(a, best) for a in ("implicit-lumped", "explicit", "quasi-static")]


def key(case: tuple) -> str:
    """'algorithm/solver' of a case (algorithm, solver[, steps])."""
    return f"{case[0]}/{case[1]}"


def split_case_label(label: str) -> tuple[str, str]:
    """(algorithm, model) of a case's first entry, 'explicit-lumped+neo-hookean' or
    'implicit' (the linear model): the run label of SPEC 8 (solvers/models.split_label,
    without importing the solvers), any '@SCHEME' left out (case_scheme)."""
    algorithm, _, model = label.partition("@")[0].partition("+")
    return algorithm, model or "linear"


def case_scheme(label: str) -> str:
    """The SPEC 11 scheme of a case's label ('mean-dilatation' of
    'explicit-lumped+neo-hookean@mean-dilatation'), 'standard' without '@'."""
    return label.partition("@")[2] or "standard"


def get(rec: dict, side: str, case: tuple, field: str) -> Any:
    """One field of one case of one side ("ours1", "ours2", "peer") of a record, or None."""
    return rec.get(side, {}).get("cases", {}).get(key(case), {}).get(field)


# --- the driver --------------------------------------------------------------------------------


def worker_env() -> dict[str, str]:
    """This process's environment with one BLAS/OpenMP thread (THREAD_VARS = 1)."""
    env = dict(os.environ)
    env.update({name: "1" for name in THREAD_VARS})
    return env


def run_worker(kind: str, ranks: int, spec: dict, tmp: Path, tag: str, timeout: float) -> dict:
    """Run one worker process (under mpiexec for ranks > 1); its result dict, or
    {"error": ...} if it failed."""
    spec_path, result_path = tmp / f"{tag}.spec.json", tmp / f"{tag}.result.json"
    spec_path.write_text(json.dumps(spec))
    result_path.unlink(missing_ok=True)
    command = [
        sys.executable,
        "-m",
        WORKER_MODULE,
        "--worker",
        kind,
        str(spec_path),
        str(result_path),
    ]
    if ranks > 1:
        mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
        command = [mpiexec, "-n", str(ranks)] + command
    meter = LoadMeter()
    try:
        proc = subprocess.run(
            command, env=worker_env(), capture_output=True, text=True, timeout=timeout
        )
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:.0f} s", "cases": {}, "load": meter.stop()}
    if proc.returncode != 0 or not result_path.exists():
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        error = f"exit {proc.returncode}: {' | '.join(tail)}"
        return {"error": error, "cases": {}, "load": meter.stop()}
    return {**json.loads(result_path.read_text()), "load": meter.stop()}


def run_quiet(
    kind: str,
    ranks: int,
    spec: dict,
    tmp: Path,
    tag: str,
    timeout: float,
    log: Callable[[str], None],
    run: Callable[..., dict] = run_worker,
) -> dict:
    """run_worker, and once more if other processes loaded the machine beyond LOAD_LIMIT
    during it (machine.noisy): the quieter of the two results, with "reruns": 1 and the first
    one's load as "first_load"; "reruns": 0 without a rerun. `run` is run_worker (tests give
    another)."""
    result = run(kind, ranks, spec, tmp, tag, timeout)
    if not noisy(result.get("load")):
        return {**result, "reruns": 0}
    first = result["load"]
    log(
        f"{tag}: other processes kept {first['others_cores']:.2f} cores busy "
        f"(> {LOAD_LIMIT:g}): measuring it once more"
    )
    again = run(kind, ranks, spec, tmp, tag, timeout)
    if again.get("load", {}).get("others_cores", math.inf) > first["others_cores"]:
        again = result
    return {**again, "reruns": 1, "first_load": first}


def block_size_for(dofs: int) -> int:
    """The even block N whose 2 (N + 1)^2 dofs come closest to `dofs`."""
    return max(2, 2 * round((math.sqrt(dofs / 2) - 1) / 2))


def rod_dofs(n: int) -> int:
    """Degrees of freedom of the rod at mesh size n."""
    return 3 * (2 * n + 1) * (n + 1) ** 2


class Budget:
    """How many steps a case runs at the next size: STEPS, SHORT, or 0 (skipped from then on),
    from its setup and step times at the size before scaled by (dofs ratio)^p: p = 2 (setup)
    and 1.4 (step) for direct solvers on the rod (3D), 1.5 and 1.2 on the block, 1.2 and 1.5
    for the iterative solvers, 1.2 and 1.1 otherwise. The peer is skipped when its assembly
    (scaled by ratio^1.1) would exceed its budget."""

    def __init__(self, mode: str):
        self.limits = BUDGET[mode]
        self.last: dict[tuple, tuple] = {}  # (dofs, setup, step) or (dofs, assembly)
        self.stopped: set[tuple] = set()

    def steps(self, side: str, benchmark: str, case: tuple[str, str], dofs: int) -> int:
        k = (side, benchmark, case)
        if k in self.stopped:
            return 0
        if k not in self.last:
            return STEPS
        last_dofs, setup, step = self.last[k]
        r = dofs / last_dofs
        if case[1] in DIRECT:
            from tissuebench.meshes import get_entry

            # a direct solve's growth with the dofs: steeper in 3D (more fill-in) than in 2D
            p_setup, p_step = {3: (2.0, 1.4), 2: (1.5, 1.2)}[get_entry(benchmark).gdim]
        else:
            p_setup, p_step = (1.2, 1.5) if case[1] in ITERATIVE else (1.2, 1.1)
        if case[1] in ITERATIVE:
            limit = self.limits["iterative"]
        else:
            limit = self.limits["main" if case in MAIN_CASES else "other"]
        for n in (STEPS, SHORT):
            if setup * r**p_setup + n * step * r**p_step <= limit:
                return n
        self.stopped.add(k)
        return 0

    def record(
        self, side: str, benchmark: str, case: tuple[str, str], dofs: int, record: dict
    ) -> None:
        if "step_s" in record:
            self.last[(side, benchmark, case)] = (dofs, record["setup_s"], record["step_s"])
        else:
            self.stopped.add((side, benchmark, case))

    def peer_assembly(self, benchmark: str, dofs: int, result: dict | None = None) -> bool:
        """Whether the peer runs at `dofs`; with `result`, record its assembly time."""
        k = ("peer-assembly", benchmark)
        if result is not None:
            if "assembly_s" in result:
                self.last[k] = (dofs, sum(result["assembly_s"].values()))
            return True
        if k in self.stopped:
            return False
        if k in self.last and (
            self.last[k][1] * (dofs / self.last[k][0]) ** 1.1 > self.limits["assembly"]
        ):
            self.stopped.add(k)
            return False
        return True


def relative_difference(
    u_ref: np.ndarray, x_ref: np.ndarray, u: np.ndarray, x: np.ndarray
) -> float:
    """||u - u_ref|| / ||u_ref|| over all nodal components, nodes matched by coordinates."""
    if u_ref.shape != u.shape or np.abs(x_ref - x).max() > 1e-9:
        return math.nan
    norm = np.linalg.norm(u_ref)
    return float(np.linalg.norm(u - u_ref) / norm) if norm > 0 else math.nan


def compare_displacements(
    path_ref: Path, path: Path, pairs: list[tuple[str, str]]
) -> dict[str, float]:
    """{peer key: rel. difference} for (ref key, key) pairs of two saved displacement files."""
    if not (Path(path_ref).exists() and Path(path).exists()):
        return {}
    a, b = np.load(path_ref), np.load(path)
    return {
        k: relative_difference(a[r], a["x"], b[k], b["x"]) for r, k in pairs if r in a and k in b
    }


def sweep_sizes(mode: str) -> list[tuple[str, int, int]]:
    """(benchmark, size, dofs) of the sweep: the rod at ROD_SIZES, then the block at the sizes
    whose dofs come closest to the rod's."""
    rod, block = SWEPT
    sizes = [(rod, n, rod_dofs(n)) for n in ROD_SIZES[mode]]
    sizes += [(block, block_size_for(d), 2 * (block_size_for(d) + 1) ** 2) for _, _, d in sizes]
    return sizes


def measure_explicit(mode: str, out: Path, log: Callable[[str], None]) -> list[dict]:
    """`tissuebench bench --only explicit-models`: the sweep's sizes with EXPLICIT_CASES only
    (the linear explicit-lumped step and the same step with each model or remedy, side by side
    in one 1-rank worker per size: explicit_worker, no budget), the records as measure's with
    "ours1" only. Writes a partial DIR/performance-explicit.json after each size."""
    tmp = make_temporary(out / f"{PREFIX}bench-explicit-tmp")
    timeout = 2 * sum(BUDGET[mode].values()) + 300
    records = []
    for benchmark, size, dofs in sweep_sizes(mode):
        tag = f"{benchmark}-{size}"
        start = time.perf_counter()
        spec = {
            "benchmark": benchmark,
            "size": size,
            "cases": [(*c, STEPS) for c in EXPLICIT_CASES],
            "triad": False,
        }
        rec: dict[str, Any] = {"benchmark": benchmark, "size": size, "dofs": dofs}
        rec["ours1"] = run_quiet("explicit", 1, spec, tmp, tag + "-ours1", timeout, log)
        rec["wall_s"] = time.perf_counter() - start
        records.append(rec)
        partial = json.dumps({"mode": mode, "partial": True, "records": records})
        write_owned(out / "performance-explicit.json", lambda tmp: tmp.write_text(partial))
        linear = get(rec, "ours1", EXPLICIT_CASES[0], "step_s")
        ratios = [
            f"{c[0].removeprefix('explicit-lumped')} "
            + (
                f"{get(rec, 'ours1', c, 'step_s') / linear:.2f}"
                if linear and get(rec, "ours1", c, "step_s")
                else "-"
            )
            for c in MODEL_CASES
        ]
        error = rec["ours1"].get("error")
        log(
            f"{benchmark:5s} size {size:4d}  {dofs:7d} dofs  {rec['wall_s']:6.1f} s  linear "
            + (f"{linear * 1e3:.3g} ms; /linear: " if linear else "- ; ")
            + ", ".join(ratios)
            + (f"  ({error})" if error else "")
        )
    remove_temporary(tmp)
    return records


def measure(
    mode: str, out: Path, log: Callable[[str], None]
) -> tuple[list[dict], list[dict], dict, list[dict]]:
    """Run every worker: the records (one per (benchmark, size)), the capacity probes, the
    paper's wall times (full mode only) and the Newton iterations of the nonlinear models
    (newton_iterations). Writes a partial DIR/performance.json after each size and works in
    DIR/.tissuebench-bench-tmp, removed at the end."""
    tmp = make_temporary(out / f"{PREFIX}bench-tmp")
    budget = Budget(mode)
    from tissuebench.workflows.bench.peer_skfem import pardiso_available

    all_peer_cases = peer_cases(pardiso_available())
    timeout = 2 * sum(BUDGET[mode].values()) + 300  # a worker that hangs, not one that is slow
    records = []
    for benchmark, size, dofs in sweep_sizes(mode):
        tag = f"{benchmark}-{size}"
        rec: dict[str, Any] = {"benchmark": benchmark, "size": size, "dofs": dofs}
        start = time.perf_counter()
        ocases = [(*c, budget.steps("ours", benchmark, c, dofs)) for c in OURS_CASES + MODEL_CASES]
        ocases = [c for c in ocases if c[2]]
        spec = {
            "benchmark": benchmark,
            "size": size,
            "cases": ocases,
            "mesh_out": str(tmp / f"{tag}.mesh.npz"),
            "u_out": str(tmp / f"{tag}.ours1.npz"),
        }
        rec["ours1"] = run_quiet("ours", 1, spec, tmp, tag + "-ours1", timeout, log)
        for c in ocases:
            budget.record("ours", benchmark, c[:2], dofs, rec["ours1"]["cases"].get(key(c), {}))
        h = rec["ours1"].get("h", {})
        spec.update(h=h, mesh_out=None, u_out=str(tmp / f"{tag}.ours2.npz"))
        rec["ours2"] = run_quiet("ours", 2, spec, tmp, tag + "-ours2", timeout, log)
        pcases = []
        if budget.peer_assembly(benchmark, dofs):
            pcases = [(*c, budget.steps("peer", benchmark, c, dofs)) for c in all_peer_cases]
            # pyamg is the reference of our iterative solvers: it runs wherever one of them ran
            ran_iterative = any(
                get(rec, "ours1", ("implicit", s), "step_s") for s in OURS_ITERATIVE
            )
            pcases = [
                (a, s, SHORT)
                if (a, s) == ("implicit", "pyamg") and not n and ran_iterative
                else (a, s, n)
                for a, s, n in pcases
            ]
            pcases = [c for c in pcases if c[2]]
        if pcases and Path(tmp / f"{tag}.mesh.npz").exists() and h:
            pspec = {
                "benchmark": benchmark,
                "cases": pcases,
                "h": h,
                "mesh_in": str(tmp / f"{tag}.mesh.npz"),
                "u_out": str(tmp / f"{tag}.peer.npz"),
            }
            rec["peer"] = run_worker("peer", 1, pspec, tmp, tag + "-peer", timeout)
            budget.peer_assembly(benchmark, dofs, rec["peer"])
        else:
            why = "over budget" if not pcases else "no mesh from the 1-rank run"
            rec["peer"] = {"skipped": why, "cases": {}}
        for c in pcases:
            budget.record("peer", benchmark, c[:2], dofs, rec["peer"]["cases"].get(key(c), {}))
        # same displacement after STEPS steps: the peer against ours (1 rank), 2 ranks against 1
        pairs = []
        for a, s, n in pcases:
            ref = (a, "cg") if s == "pyamg" else (a, "-" if s == "-" else "direct")
            if n == STEPS and get(rec, "ours1", ref, "steps") == STEPS:
                pairs.append((key(ref), key((a, s))))
        rec["diff_peer"] = compare_displacements(
            tmp / f"{tag}.ours1.npz", tmp / f"{tag}.peer.npz", pairs
        )
        rec["diff_2ranks"] = compare_displacements(
            tmp / f"{tag}.ours1.npz", tmp / f"{tag}.ours2.npz", [(key(c), key(c)) for c in ocases]
        )
        for path in tmp.glob(f"{tag}.*.npz"):
            path.unlink()
        rec["wall_s"] = time.perf_counter() - start
        records.append(rec)
        partial = json.dumps({"mode": mode, "partial": True, "records": records})
        write_owned(out / "performance.json", lambda tmp: tmp.write_text(partial))
        errors = [
            f"{side}: {rec[side]['error']}"
            for side in ("ours1", "ours2", "peer")
            if "error" in rec[side]
        ]
        log(
            f"{benchmark:5s} size {size:4d}  {dofs:7d} dofs  {rec['wall_s']:6.1f} s  "
            f"ours {len(ocases)} cases, peer {len(pcases)}"
            + (f"  ({'; '.join(errors)})" if errors else "")
        )
    probes = refine_capacity(records, tmp, timeout, log)
    newton = newton_iterations(tmp, timeout, log)
    paper = time_paper(tmp, log) if mode == "full" else {}
    remove_temporary(tmp)
    return records, probes, paper, newton


def newton_iterations(tmp: Path, timeout: float, log: Callable[[str], None]) -> list[dict]:
    """`implicit` with each nonlinear model (NEWTON_MODELS) at the paper's loads, in both modes:
    each benchmark of NEWTON_BENCHMARKS at its default material and mesh size, s = 1, h and T
    its defaults (block MP1 N = 20 and rod MP3 n = 3: 300 steps), one 1-rank worker per
    benchmark. [{"benchmark", "size", "material", "h", "steps", "result"}], the result being
    the worker's, its cases keyed 'implicit+MODEL/direct' with the Newton iterations of every
    step that converged (a divergence, such as an inverted element, ends the run there)."""
    from tissuebench.meshes import get_entry

    runs = []
    for benchmark in NEWTON_BENCHMARKS:
        entry = get_entry(benchmark)
        steps = round(entry.end_time / entry.dt)
        cases = [(f"implicit+{m}", "direct", steps) for m in NEWTON_MODELS]
        spec = {"benchmark": benchmark, "size": entry.mesh_size, "cases": cases, "triad": False}
        start = time.perf_counter()
        result = run_worker("ours", 1, spec, tmp, f"newton-{benchmark}", timeout)
        runs.append(
            {
                "benchmark": benchmark,
                "size": entry.mesh_size,
                "material": entry.material,
                "h": entry.dt,
                "steps": steps,
                "result": result,
            }
        )
        summary = []
        for c in cases:
            its = result.get("cases", {}).get(key(c), {}).get("newton_iterations")
            summary.append(f"{c[0]} " + (f"mean {np.mean(its):.2f} max {max(its)}" if its else "-"))
        log(
            f"Newton {benchmark} {entry.material} size {entry.mesh_size}, {steps} steps: "
            + "; ".join(summary)
            + f"  ({time.perf_counter() - start:.1f} s)"
            + (f"  ({result['error']})" if "error" in result else "")
        )
    return runs


def time_paper(tmp: Path, log: Callable[[str], None]) -> dict[str, float | None]:
    """Wall times (s) of the whole `tissuebench paper` study into scratch directories: serial
    twice (the first also warms the form cache; the second is the one reported) and under
    `mpiexec -n 2` with the cache warm."""
    command = [sys.executable, "-m", "tissuebench.workflows.cli", "paper"]
    mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
    times: dict[str, float | None] = {}
    for name, prefix in (("serial, cold", []), ("serial", []), ("2 ranks", [mpiexec, "-n", "2"])):
        out = tmp / f"paper-{len(times)}"
        shutil.rmtree(out, ignore_errors=True)
        start = time.perf_counter()
        proc = subprocess.run(
            prefix + command + ["--out", str(out)],
            env=worker_env(),
            capture_output=True,
            text=True,
            timeout=1800,
        )
        times[name] = time.perf_counter() - start if proc.returncode == 0 else None
        log(
            f"tissuebench paper, {name}: "
            + (
                f"{times[name]:.1f} s"
                if proc.returncode == 0
                else f"failed (exit {proc.returncode})"
            )
        )
        shutil.rmtree(out, ignore_errors=True)
    return times


# --- the real-time capacity search -------------------------------------------------------------


def rod_points(
    records: list[dict], probes: Iterable[dict], case: tuple[str, str], side: str
) -> list[tuple]:
    """[(n, dofs, step_s, h)] of `case` on the rod from the sweep and the capacity probes,
    sorted by n."""
    ranks = 1 if side == "ours1" else 2
    points = {}
    for rec in records:
        if rec["benchmark"] == CAPACITY_BENCHMARK and get(rec, side, case, "step_s") is not None:
            points[rec["size"]] = (
                rec["size"],
                rec["dofs"],
                get(rec, side, case, "step_s"),
                get(rec, side, case, "h"),
            )
    for p in probes:
        if p["case"] == key(case) and p["ranks"] == ranks and p.get("step_s") is not None:
            points[p["n"]] = (p["n"], p["dofs"], p["step_s"], p["h"])
    return [points[n] for n in sorted(points)]


def refine_capacity(
    records: list[dict], tmp: Path, timeout: float, log: Callable[[str], None]
) -> list[dict]:
    """For the cases with a real-time target, on 1 and 2 ranks: bisect the rod size n between
    the largest size of the sweep that runs in real time (step time <= h) and the next size,
    with runs of SHORT steps. The probes: [{case, ranks, n, dofs, step_s, h}]."""
    probes = []
    for case in CAPACITY_CASES:
        for ranks, side in ((1, "ours1"), (2, "ours2")):
            points = rod_points(records, [], case, side)
            passing = [n for n, _, step, h in points if step <= h]
            sizes = sorted(r["size"] for r in records if r["benchmark"] == CAPACITY_BENCHMARK)
            if not passing or max(passing) == sizes[-1]:
                continue
            lo = max(passing)
            hi = min(n for n in sizes if n > lo)
            while hi - lo > 1:
                n = (lo + hi) // 2
                spec = {"benchmark": CAPACITY_BENCHMARK, "size": n, "cases": [(*case, SHORT)]}
                result = run_worker("ours", ranks, spec, tmp, f"capacity-{n}-{ranks}", timeout)
                r = result.get("cases", {}).get(key(case), {})
                probes.append(
                    {
                        "case": key(case),
                        "ranks": ranks,
                        "n": n,
                        "dofs": result.get("dofs"),
                        "step_s": r.get("step_s"),
                        "h": r.get("h"),
                    }
                )
                ok = r.get("step_s") is not None and r["step_s"] <= r["h"]
                outcome = (
                    f"step/h = {r['step_s'] / r['h']:.3g}"
                    if r.get("step_s")
                    else f"failed: {result.get('error', r.get('error'))}"
                )
                log(f"capacity {key(case)} {ranks} rank(s): rod n={n} " + outcome)
                lo, hi = (n, hi) if ok else (lo, n)
    return probes
