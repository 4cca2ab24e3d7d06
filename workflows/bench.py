"""`tissuebench bench [--quick] [--out DIR]`: how fast the algorithms run, against a scikit-fem +
SciPy peer, the memory-bandwidth limit and 2 MPI ranks.

For the rod (n = 2 .. 48) and the block on matching numbers of degrees of freedom, one run
measures, side by side: the assembly time of K and M; the setup time (everything before the
first step: step matrix, factorisation or preconditioner, initial acceleration) and the time
per step (median after a warm-up, of STEPS or SHORT steps) of every algorithm; the peak
memory (resident set, summed over ranks) during each; the same on 2 ranks; the peer
(workflows/peer_skfem.py) doing the same steps on the same mesh; whether both give the same
displacement after STEPS steps; a STREAM-like triad (w = a x + y on PETSc Vecs of 2^24 entries)
and the bytes an explicit-lumped step must move, giving measured / limit.

Each measurement runs in a fresh worker process (`python -m tissuebench.workflows.bench
--worker ...`, under `mpiexec -n 2` for the 2-rank column) with BLAS/OpenMP threads pinned to
one per rank (THREAD_VARS), so that peak memory is per process and nothing is shared between
the sides. A case whose predicted cost (setup + steps, scaled from the size before) exceeds
its budget is skipped from then on; the report says which sizes ran.

Writes DIR/performance.md, DIR/performance.png and DIR/performance.json. Only the driver (one
process, not under mpiexec) prints. Units: seconds, bytes, degrees of freedom.
"""

import gc
import json
import math
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

STEPS = 30  # steps of a timed run; the displacements after them are compared
SHORT = 12  # steps of a run too costly for STEPS (no displacement check)
WARMUP = {STEPS: 5, SHORT: 2}  # first steps left out of the per-step median (25 or 10 remain)
TRIAD_SIZE = 2**24  # entries of each triad vector (128 MiB): far beyond the caches
SAFETY = 0.9  # explicit schemes run at SAFETY x their critical step 2 / omega_max (at most 1/30 s)
DIRECT_TOL = 1e-10  # relative displacement difference allowed between direct solvers
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
               "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")
ROD_SIZES = {"quick": [2, 6, 10], "full": [2, 4, 8, 12, 16, 24, 32, 48]}
# Budgets (s) of one case (predicted setup + steps on one rank; "main" cases are the targets',
# "iterative" the implicit step's CG cases, whose target is at 7e5 dofs) and of the peer's
# assembly (the rod at 7e5 dofs takes about 4 minutes).
BUDGET = {"quick": {"main": 10.0, "iterative": 10.0, "other": 5.0, "assembly": 10.0},
          "full": {"main": 30.0, "iterative": 200.0, "other": 8.0, "assembly": 300.0}}
OURS_ITERATIVE = ("cg", "gamg")  # our iterative solvers; pyamg is their peer
ITERATIVE = OURS_ITERATIVE + ("pyamg",)

# (algorithm, solver): ours with tissuebench's solver names, the peer with its own.
OURS_CASES = [("explicit-lumped", "-"), ("implicit", "direct"), ("implicit", "cg"), ("implicit", "gamg"),
              ("implicit-lumped", "direct"), ("explicit", "direct"), ("quasi-static", "direct")]
MAIN_CASES = {("explicit-lumped", "-"), ("implicit", "direct"), ("implicit", "cg"), ("implicit", "gamg"),
              ("implicit", "pardiso"), ("implicit", "superlu"), ("implicit", "pyamg")}
DIRECT = {"direct", "superlu", "pardiso"}
EXPLICIT = ("explicit", "explicit-lumped")


def peer_cases(pardiso):
    best = "pardiso" if pardiso else "superlu"
    cases = [("explicit-lumped", "-"), ("implicit", "superlu"), ("implicit", "pyamg")]
    if pardiso:
        cases.insert(1, ("implicit", "pardiso"))
    return cases + [(a, best) for a in ("implicit-lumped", "explicit", "quasi-static")]


def key(case):
    """'algorithm/solver' of a case (algorithm, solver[, steps])."""
    return f"{case[0]}/{case[1]}"


# --- measurements shared by the workers --------------------------------------------------------


def reset_peak_memory():
    """Start a new peak-resident-set measurement for this process (Linux: clear_refs 5)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def peak_memory():
    """This process's peak resident set since the last reset, bytes."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def median_step(times):
    """Median time per step (s) of the steps after the warm-up."""
    return float(np.median(times[WARMUP[len(times)]:]))


# --- the worker for tissuebench (ours), 1 or 2 ranks ------------------------------------------


def triad_bandwidth(comm, size=TRIAD_SIZE, repeats=10):
    """Best STREAM-like triad bandwidth w = 3 x + y over all ranks at once, bytes/s (24 bytes
    per entry: two reads, one write)."""
    from petsc4py import PETSc

    x = PETSc.Vec().createMPI((PETSc.DECIDE, size), comm=comm)
    y, w = x.duplicate(), x.duplicate()
    x.set(1.0)
    y.set(2.0)
    w.set(0.0)
    best = math.inf
    for _ in range(repeats):
        comm.Barrier()
        start = time.perf_counter()
        w.waxpy(3.0, x, y)
        comm.Barrier()
        best = min(best, time.perf_counter() - start)
    for v in (x, y, w):
        v.destroy()
    return 24 * size / best


def explicit_lumped_bytes(matrix_bytes, n):
    """Bytes one explicit-lumped step must move at least: the matrix once (as stored), and the
    vectors u, v, a read and written once, f and M_L read once (8 vectors of n doubles)."""
    return matrix_bytes + 8 * 8 * n


def stable_steps(system, names):
    """{scheme: SAFETY x 2 / omega_max} (s) for the explicit schemes in `names` (for gamma = 1/2,
    beta_N = 0 the critical step is 2 / omega_max whatever the damping), omega_max from SLEPc
    as solvers/stability.py computes it (relative tolerance 1e-4), {scheme: "SLEPc"}, and the
    time this took (s)."""
    from tissuebench.solvers.stability import extreme_eigenvalue, reduced_matrices

    start = time.perf_counter()
    h, how = {}, {}
    for name in names:
        K, M = reduced_matrices(system, lumped=name == "explicit-lumped")
        omega_max, how[name] = math.sqrt(extreme_eigenvalue(K, M, tol=1e-4)), "SLEPc"
        K.destroy()
        M.destroy()
        h[name] = SAFETY * 2.0 / omega_max
    return h, how, time.perf_counter() - start


def ours_worker(spec):
    from mpi4py import MPI
    from petsc4py import PETSc

    import dolfinx.fem.petsc

    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.system import System, gather_by_coordinates

    comm = MPI.COMM_WORLD
    out = {"ranks": comm.size, "cases": {}}
    out["triad_Bps"] = triad_bandwidth(comm)
    bench = get_benchmark(spec["benchmark"], mesh_size=spec["size"], comm=comm)
    system = System(bench)  # the defaults of `tissuebench run`
    K = system.K
    out["dofs"] = system.num_dofs()
    out["matrix_type"] = K.getType()
    kind = "baij" if "baij" in K.getType() else None
    out["assembly_s"] = {}
    for name, form in (("K", system.k_form), ("M", system.m_form)):
        comm.Barrier()
        start = time.perf_counter()
        A = dolfinx.fem.petsc.assemble_matrix(form, kind=kind)
        A.assemble()
        comm.Barrier()
        out["assembly_s"][name] = time.perf_counter() - start
        A.destroy()
    comm.Barrier()
    start = time.perf_counter()
    system.K_csr, system.M_csr  # the compiled products' copies (solvers/blockcsr.py)
    comm.Barrier()
    out["assembly_s"]["block CSR"] = time.perf_counter() - start

    h = {name: bench.dt for name, _, _ in spec["cases"]}
    explicit = sorted({a for a, _, _ in spec["cases"] if a in EXPLICIT})
    if spec.get("h"):
        h.update(spec["h"])
    elif explicit:
        stable, out["omega_from"], out["eigen_s"] = stable_steps(system, explicit)
        h.update({name: min(bench.dt, value) for name, value in stable.items()})
    out["h"] = h

    if comm.rank == 0 and spec.get("mesh_out"):
        n = system.V.dofmap.index_map.size_local
        np.savez(spec["mesh_out"], points=system.V.tabulate_dof_coordinates()[:n, : system.gdim],
                 cells=system.V.dofmap.list, mu=float(system.mu.value), lmbda=float(system.lmbda.value),
                 rho=system.material.rho, alpha=system.material.alpha, beta=system.material.beta)

    displacements = {}
    for algorithm, solver, steps in spec["cases"]:
        record = {"h": h[algorithm], "steps": steps}
        gc.collect()
        reset_peak_memory()
        try:
            comm.Barrier()
            start = time.perf_counter()
            integrator = get_integrator(algorithm, system, h[algorithm],
                                        solver="direct" if solver == "-" else solver)
            state = integrator.start()
            comm.Barrier()
            record["setup_s"] = time.perf_counter() - start
            if algorithm == "explicit-lumped":  # the matrix its one product per step reads
                A = integrator.K_product  # solvers/blockcsr.py: blocks, block columns, row starts
                record["matrix_type"] = "block CSR"
                record["bytes"] = explicit_lumped_bytes(comm.allreduce(A.nbytes), system.num_dofs())
            times, iterations = [], []
            for _ in range(steps):
                comm.Barrier()
                start = time.perf_counter()
                state = integrator.step(state)
                comm.Barrier()
                times.append(time.perf_counter() - start)
                ksp = getattr(integrator.solve, "ksp", None)
                if ksp is not None and solver in OURS_ITERATIVE:
                    iterations.append(ksp.getIterationNumber())
            record["step_s"] = median_step(times)
            record["steps_s"] = times
            if iterations:
                record["iterations"] = float(np.mean(iterations))
            record["finite"] = bool(comm.allreduce(bool(np.isfinite(state.u.array_r).all()), op=MPI.LAND))
            gathered = gather_by_coordinates(system.V, state.u.array_r, comm)
            if comm.rank == 0:
                displacements[key((algorithm, solver))] = gathered[1]
                displacements["x"] = gathered[0][:, : system.gdim]
            for solve in (integrator.solve, getattr(integrator, "mass_solve", None)):
                if getattr(solve, "ksp", None) is not None:
                    solve.ksp.destroy()
            del integrator, state
        except (PETSc.Error, RuntimeError) as err:
            record["error"] = str(err)[:200]
        record["peak_bytes"] = comm.allreduce(peak_memory())
        out["cases"][key((algorithm, solver))] = record
    if comm.rank == 0 and spec.get("u_out"):
        np.savez(spec["u_out"], **displacements)
    return out


# --- the worker for the peer (serial) ---------------------------------------------------------


def peer_worker(spec):
    from tissuebench.workflows import peer_skfem as peer

    data = np.load(spec["mesh_in"])
    material = peer.Material(*(float(data[k]) for k in ("mu", "lmbda", "rho", "alpha", "beta")))
    out = {"ranks": 1, "cases": {}, "pardiso": peer.pardiso_available()}
    system = peer.PeerSystem(spec["benchmark"], data["points"], data["cells"], material)
    out["dofs"] = system.num_dofs()
    out["assembly_s"] = system.assembly_s
    K = system.K
    out["matrix_bytes"] = K.data.nbytes + K.indices.nbytes + K.indptr.nbytes
    out["explicit_lumped_bytes"] = explicit_lumped_bytes(out["matrix_bytes"], system.num_dofs())
    displacements = {}
    for algorithm, solver, steps in spec["cases"]:
        h = spec["h"][algorithm]
        record = {"h": h, "steps": steps}
        gc.collect()
        reset_peak_memory()
        try:
            start = time.perf_counter()
            integrator = peer.get_peer_integrator(algorithm, system, h, solver)
            state = integrator.start()
            record["setup_s"] = time.perf_counter() - start
            times = []
            for _ in range(steps):
                start = time.perf_counter()
                state = integrator.step(state)
                times.append(time.perf_counter() - start)
            record["step_s"] = median_step(times)
            record["steps_s"] = times
            if isinstance(integrator.solve, peer.PyamgCG):
                record["iterations"] = float(np.mean(integrator.solve.iterations))
            if isinstance(integrator.solve, peer.Pardiso):
                integrator.solve.free()
            u = state[1]
            record["finite"] = bool(np.isfinite(u).all())
            x, values = peer.sort_by_coordinates(system.points, u.reshape(-1, system.gdim))
            displacements[key((algorithm, solver))] = values
            displacements["x"] = x
            del integrator, state
        except (RuntimeError, MemoryError, ValueError) as err:
            record["error"] = str(err)[:200]
        record["peak_bytes"] = peak_memory()
        out["cases"][key((algorithm, solver))] = record
    np.savez(spec["u_out"], **displacements)
    return out


def worker_main(argv):
    """`python -m tissuebench.workflows.bench --worker ours|peer SPEC.json RESULT.json`."""
    kind, spec_path, result_path = argv
    spec = json.loads(Path(spec_path).read_text())
    result = ours_worker(spec) if kind == "ours" else peer_worker(spec)
    if kind == "peer":
        Path(result_path).write_text(json.dumps(result))
    else:
        from mpi4py import MPI

        if MPI.COMM_WORLD.rank == 0:
            Path(result_path).write_text(json.dumps(result))


# --- the driver --------------------------------------------------------------------------------


def worker_env():
    env = dict(os.environ)
    env.update({name: "1" for name in THREAD_VARS})
    return env


def run_worker(kind, ranks, spec, tmp, tag, timeout):
    """Run one worker process (under mpiexec for ranks > 1); its result dict, or
    {"error": ...} if it failed."""
    spec_path, result_path = tmp / f"{tag}.spec.json", tmp / f"{tag}.result.json"
    spec_path.write_text(json.dumps(spec))
    result_path.unlink(missing_ok=True)
    command = [sys.executable, "-m", "tissuebench.workflows.bench", "--worker", kind,
               str(spec_path), str(result_path)]
    if ranks > 1:
        mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
        command = [mpiexec, "-n", str(ranks)] + command
    try:
        proc = subprocess.run(command, env=worker_env(), capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"error": f"timed out after {timeout:.0f} s", "cases": {}}
    if proc.returncode != 0 or not result_path.exists():
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        return {"error": f"exit {proc.returncode}: {' | '.join(tail)}", "cases": {}}
    return json.loads(result_path.read_text())


def block_size_for(dofs):
    """The even block N whose 2 (N + 1)^2 dofs come closest to `dofs`."""
    return max(2, 2 * round((math.sqrt(dofs / 2) - 1) / 2))


def rod_dofs(n):
    return 3 * (2 * n + 1) * (n + 1) ** 2


class Budget:
    """How many steps a case runs at the next size: STEPS, SHORT, or 0 (skipped from then on),
    from its setup and step times at the size before scaled by (dofs ratio)^p: p = 2 (setup)
    and 1.4 (step) for direct solvers on the rod (3D), 1.5 and 1.2 on the block, 1.2 and 1.5
    for the iterative solvers, 1.2 and 1.1 otherwise. The peer is skipped when its assembly
    (scaled by ratio^1.1) would exceed its budget."""

    def __init__(self, mode):
        self.limits = BUDGET[mode]
        self.last = {}
        self.stopped = set()

    def steps(self, side, benchmark, case, dofs):
        k = (side, benchmark, case)
        if k in self.stopped:
            return 0
        if k not in self.last:
            return STEPS
        last_dofs, setup, step = self.last[k]
        r = dofs / last_dofs
        if case[1] in DIRECT:
            p_setup, p_step = (2.0, 1.4) if benchmark == "rod" else (1.5, 1.2)
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

    def record(self, side, benchmark, case, dofs, record):
        if "step_s" in record:
            self.last[(side, benchmark, case)] = (dofs, record["setup_s"], record["step_s"])
        else:
            self.stopped.add((side, benchmark, case))

    def peer_assembly(self, benchmark, dofs, result=None):
        """Whether the peer runs at `dofs`; with `result`, record its assembly time."""
        k = ("peer-assembly", benchmark)
        if result is not None:
            if "assembly_s" in result:
                self.last[k] = (dofs, sum(result["assembly_s"].values()))
            return True
        if k in self.stopped:
            return False
        if k in self.last and self.last[k][1] * (dofs / self.last[k][0]) ** 1.1 > self.limits["assembly"]:
            self.stopped.add(k)
            return False
        return True


def relative_difference(u_ref, x_ref, u, x):
    """||u - u_ref|| / ||u_ref|| over all nodal components, nodes matched by coordinates."""
    if u_ref.shape != u.shape or np.abs(x_ref - x).max() > 1e-9:
        return math.nan
    norm = np.linalg.norm(u_ref)
    return float(np.linalg.norm(u - u_ref) / norm) if norm > 0 else math.nan


def compare_displacements(path_ref, path, pairs):
    """{peer key: rel. difference} for (ref key, key) pairs of two saved displacement files."""
    if not (Path(path_ref).exists() and Path(path).exists()):
        return {}
    a, b = np.load(path_ref), np.load(path)
    return {k: relative_difference(a[r], a["x"], b[k], b["x"]) for r, k in pairs if r in a and k in b}


def measure(mode, out, log):
    """Run every worker; a list of records, one per (benchmark, size)."""
    tmp = out / ".bench-tmp"
    tmp.mkdir(parents=True, exist_ok=True)
    budget = Budget(mode)
    from tissuebench.workflows.peer_skfem import pardiso_available

    all_peer_cases = peer_cases(pardiso_available())
    timeout = 2 * sum(BUDGET[mode].values()) + 300  # a worker that hangs, not one that is slow
    records = []
    sizes = [("rod", n, rod_dofs(n)) for n in ROD_SIZES[mode]]
    sizes += [("block", block_size_for(d), 2 * (block_size_for(d) + 1) ** 2) for _, _, d in sizes]
    for benchmark, size, dofs in sizes:
        tag = f"{benchmark}-{size}"
        rec = {"benchmark": benchmark, "size": size, "dofs": dofs}
        start = time.perf_counter()
        ocases = [(*c, budget.steps("ours", benchmark, c, dofs)) for c in OURS_CASES]
        ocases = [c for c in ocases if c[2]]
        spec = {"benchmark": benchmark, "size": size, "cases": ocases,
                "mesh_out": str(tmp / f"{tag}.mesh.npz"), "u_out": str(tmp / f"{tag}.ours1.npz")}
        rec["ours1"] = run_worker("ours", 1, spec, tmp, tag + "-ours1", timeout)
        for c in ocases:
            budget.record("ours", benchmark, c[:2], dofs, rec["ours1"]["cases"].get(key(c), {}))
        h = rec["ours1"].get("h", {})
        spec.update(h=h, mesh_out=None, u_out=str(tmp / f"{tag}.ours2.npz"))
        rec["ours2"] = run_worker("ours", 2, spec, tmp, tag + "-ours2", timeout)
        pcases = []
        if budget.peer_assembly(benchmark, dofs):
            pcases = [(*c, budget.steps("peer", benchmark, c, dofs)) for c in all_peer_cases]
            # pyamg is the reference of our iterative solvers: it runs wherever one of them ran
            ran_iterative = any(get(rec, "ours1", ("implicit", s), "step_s") for s in OURS_ITERATIVE)
            pcases = [(a, s, SHORT) if (a, s) == ("implicit", "pyamg") and not n and ran_iterative
                      else (a, s, n) for a, s, n in pcases]
            pcases = [c for c in pcases if c[2]]
        if pcases and Path(tmp / f"{tag}.mesh.npz").exists() and h:
            pspec = {"benchmark": benchmark, "cases": pcases, "h": h,
                     "mesh_in": str(tmp / f"{tag}.mesh.npz"), "u_out": str(tmp / f"{tag}.peer.npz")}
            rec["peer"] = run_worker("peer", 1, pspec, tmp, tag + "-peer", timeout)
            budget.peer_assembly(benchmark, dofs, rec["peer"])
        else:
            rec["peer"] = {"skipped": "over budget" if not pcases else "no mesh from the 1-rank run",
                           "cases": {}}
        for c in pcases:
            budget.record("peer", benchmark, c[:2], dofs, rec["peer"]["cases"].get(key(c), {}))
        # same displacement after STEPS steps: the peer against ours (1 rank), 2 ranks against 1
        pairs = []
        for a, s, n in pcases:
            ref = (a, "cg") if s == "pyamg" else (a, "-" if s == "-" else "direct")
            if n == STEPS and get(rec, "ours1", ref, "steps") == STEPS:
                pairs.append((key(ref), key((a, s))))
        rec["diff_peer"] = compare_displacements(tmp / f"{tag}.ours1.npz", tmp / f"{tag}.peer.npz", pairs)
        rec["diff_2ranks"] = compare_displacements(tmp / f"{tag}.ours1.npz", tmp / f"{tag}.ours2.npz",
                                                   [(key(c), key(c)) for c in ocases])
        for path in tmp.glob(f"{tag}.*.npz"):
            path.unlink()
        rec["wall_s"] = time.perf_counter() - start
        records.append(rec)
        (out / "performance.json").write_text(json.dumps({"mode": mode, "partial": True, "records": records}))
        errors = [f"{side}: {rec[side]['error']}" for side in ("ours1", "ours2", "peer") if "error" in rec[side]]
        log(f"{benchmark:5s} size {size:4d}  {dofs:7d} dofs  {rec['wall_s']:6.1f} s  "
            f"ours {len(ocases)} cases, peer {len(pcases)}"
            + (f"  ({'; '.join(errors)})" if errors else ""))
    probes = refine_capacity(records, tmp, timeout, log)
    paper = time_paper(tmp, log) if mode == "full" else {}
    shutil.rmtree(tmp, ignore_errors=True)
    return records, probes, paper


def time_paper(tmp, log):
    """Wall times (s) of the whole `tissuebench paper` study into scratch directories: serial
    twice (the first also warms the form cache; the second is the one reported) and under
    `mpiexec -n 2` with the cache warm."""
    command = [sys.executable, "-m", "tissuebench.workflows.cli", "paper"]
    mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
    times = {}
    for name, prefix in (("serial, cold", []), ("serial", []), ("2 ranks", [mpiexec, "-n", "2"])):
        out = tmp / f"paper-{len(times)}"
        shutil.rmtree(out, ignore_errors=True)
        start = time.perf_counter()
        proc = subprocess.run(prefix + command + ["--out", str(out)], env=worker_env(), capture_output=True,
                              text=True, timeout=1800)
        times[name] = time.perf_counter() - start if proc.returncode == 0 else None
        log(f"tissuebench paper, {name}: " + (f"{times[name]:.1f} s" if proc.returncode == 0
                                             else f"failed (exit {proc.returncode})"))
        shutil.rmtree(out, ignore_errors=True)
    return times


# --- tables -------------------------------------------------------------------------------------


def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if isinstance(x, str):
        return x
    if x == 0:
        return "0"
    if abs(x) >= 1000 or abs(x) < 1e-3:
        return f"{x:.2e}"
    return f"{x:.{digits}g}"


def ratio(a, b):
    return a / b if a is not None and b is not None and b > 0 else None


def get(rec, side, case, field):
    return rec.get(side, {}).get("cases", {}).get(key(case), {}).get(field)


def best_peer_direct(rec, algorithm):
    """(solver, record) of the peer's fastest direct solver per step for `algorithm`."""
    best = None
    for solver in ("pardiso", "superlu"):
        r = rec.get("peer", {}).get("cases", {}).get(key((algorithm, solver)))
        if r and "step_s" in r and (best is None or r["step_s"] < best[1]["step_s"]):
            best = (solver, r)
    return best


def peer_for(rec, case):
    """The peer case compared with our `case`: the same step, its best solver of that kind."""
    algorithm, solver = case
    if solver == "-":
        return ("explicit-lumped", "-")
    if solver in OURS_ITERATIVE:
        return (algorithm, "pyamg")
    best = best_peer_direct(rec, algorithm)
    return (algorithm, best[0]) if best else (algorithm, "superlu")


def markdown_table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def text_table(header, rows):
    cells = [header] + [[fmt(c) for c in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells)


def assembly_rows(records):
    rows = []
    for rec in records:
        o1, o2, p = (rec.get(s, {}).get("assembly_s") for s in ("ours1", "ours2", "peer"))
        t1 = sum(o1.values()) if o1 else None
        t2 = sum(o2.values()) if o2 else None
        tp = sum(p.values()) if p else None
        rows.append([rec["benchmark"], rec["size"], rec["dofs"], o1 and o1["K"], o1 and o1["M"],
                     o1 and o1.get("block CSR"), p and p["K"], p and p["M"], ratio(t1, tp), t2, ratio(t1, t2)])
    return ["bench", "size", "dofs", "K ours s", "M ours s", "block CSR copies s", "K peer s", "M peer s",
            "ours/peer (all)", "all 2r s", "1r/2r"], rows


def step_rows(records):
    rows = []
    for rec in records:
        for case in OURS_CASES:
            s1 = get(rec, "ours1", case, "step_s")
            if s1 is None:
                continue
            pc = peer_for(rec, case)
            sp = get(rec, "peer", pc, "step_s")
            s2 = get(rec, "ours2", case, "step_s")
            diff = rec.get("diff_peer", {}).get(key(pc))
            rows.append([rec["benchmark"], rec["size"], rec["dofs"], case[0],
                         f"{case[1]}|{pc[1]}" if case[1] != "-" else "-",
                         get(rec, "ours1", case, "setup_s"), get(rec, "peer", pc, "setup_s"),
                         ratio(get(rec, "ours1", case, "setup_s"), get(rec, "peer", pc, "setup_s")),
                         s1, s2, sp, ratio(s1, sp), ratio(s1, s2),
                         (get(rec, "ours1", case, "peak_bytes") or 0) / 2**20,
                         (get(rec, "ours2", case, "peak_bytes") or 0) / 2**20,
                         (get(rec, "peer", pc, "peak_bytes") or 0) / 2**20 if sp else None,
                         diff])
    return ["bench", "size", "dofs", "algorithm", "solver ours|peer", "setup ours s", "setup peer s",
            "ours/peer", "step 1r s", "step 2r s", "step peer s", "ours/peer", "1r/2r",
            "peak 1r MiB", "peak 2r MiB", "peak peer MiB", "u diff"], rows


def extra_peer_rows(records):
    """Every peer solver at every size (SuperLU and PARDISO both), with CG iterations."""
    rows = []
    for rec in records:
        for k, r in rec.get("peer", {}).get("cases", {}).items():
            if "step_s" in r:
                rows.append([rec["benchmark"], rec["size"], rec["dofs"], k, r["setup_s"], r["step_s"],
                             r.get("iterations"), r["peak_bytes"] / 2**20, rec.get("diff_peer", {}).get(k)])
    return ["bench", "size", "dofs", "peer case", "setup s", "step s", "CG its", "peak MiB",
            "u diff vs ours"], rows


def bandwidth_rows(records):
    rows = []
    case = ("explicit-lumped", "-")
    for rec in records:
        o1, o2, p = rec.get("ours1", {}), rec.get("ours2", {}), rec.get("peer", {})
        s1, s2, sp = (get(rec, side, case, "step_s") for side in ("ours1", "ours2", "peer"))
        if s1 is None:
            continue
        b = get(rec, "ours1", case, "bytes")
        lim1 = b / o1["triad_Bps"]
        lim2 = b / o2["triad_Bps"] if o2.get("triad_Bps") else None
        limp = p["explicit_lumped_bytes"] / o1["triad_Bps"] if p.get("explicit_lumped_bytes") else None
        rows.append([rec["benchmark"], rec["size"], rec["dofs"], get(rec, "ours1", case, "matrix_type"),
                     b / rec["dofs"],
                     o1["triad_Bps"] / 1e9, o2.get("triad_Bps", 0) / 1e9, lim1, s1, ratio(s1, lim1),
                     s2, ratio(s2, lim2), sp, ratio(sp, limp)])
    return ["bench", "size", "dofs", "matrix", "bytes/dof", "triad 1r GB/s", "triad 2r GB/s",
            "limit 1r s", "step 1r s", "meas/limit 1r", "step 2r s", "meas/limit 2r",
            "peer step s", "peer meas/limit (CSR)"], rows


def rod_points(records, probes, case, side):
    """[(n, dofs, step_s, h)] of `case` on the rod from the sweep and the capacity probes,
    sorted by n."""
    ranks = 1 if side == "ours1" else 2
    points = {}
    for rec in records:
        if rec["benchmark"] == "rod" and get(rec, side, case, "step_s") is not None:
            points[rec["size"]] = (rec["size"], rec["dofs"], get(rec, side, case, "step_s"), get(rec, side, case, "h"))
    for p in probes:
        if p["case"] == key(case) and p["ranks"] == ranks and p.get("step_s") is not None:
            points[p["n"]] = (p["n"], p["dofs"], p["step_s"], p["h"])
    return [points[n] for n in sorted(points)]


def refine_capacity(records, tmp, timeout, log):
    """For the cases with a real-time target, on 1 and 2 ranks: bisect the rod size n between
    the largest size of the sweep that runs in real time (step time <= h) and the next size,
    with runs of SHORT steps. The probes: [{case, ranks, n, dofs, step_s, h}]."""
    probes = []
    for case in (("explicit-lumped", "-"), ("implicit", "direct")):
        for ranks, side in ((1, "ours1"), (2, "ours2")):
            points = rod_points(records, [], case, side)
            passing = [n for n, _, step, h in points if step <= h]
            sizes = sorted(r["size"] for r in records if r["benchmark"] == "rod")
            if not passing or max(passing) == sizes[-1]:
                continue
            lo = max(passing)
            hi = min(n for n in sizes if n > lo)
            while hi - lo > 1:
                n = (lo + hi) // 2
                spec = {"benchmark": "rod", "size": n, "cases": [(*case, SHORT)]}
                result = run_worker("ours", ranks, spec, tmp, f"capacity-{n}-{ranks}", timeout)
                r = result.get("cases", {}).get(key(case), {})
                probes.append({"case": key(case), "ranks": ranks, "n": n, "dofs": result.get("dofs"),
                               "step_s": r.get("step_s"), "h": r.get("h")})
                ok = r.get("step_s") is not None and r["step_s"] <= r["h"]
                log(f"capacity {key(case)} {ranks} rank(s): rod n={n} "
                    + (f"step/h = {r['step_s'] / r['h']:.3g}" if r.get("step_s") else f"failed: {result.get('error', r.get('error'))}"))
                lo, hi = (n, hi) if ok else (lo, n)
    return probes


def capacity(records, probes=()):
    """Per ours case and rank count: the largest rod size with step time <= h (one simulated
    second in at most one wall second), over the sweep and the capacity probes, and whether
    the largest size measured still passed."""
    rows = []
    for case in OURS_CASES:
        row = [case[0], case[1]]
        for side in ("ours1", "ours2"):
            points = rod_points(records, probes, case, side)
            passing = [p for p in points if p[2] <= p[3]]
            if not passing:
                row += ["none", None, None]
                continue
            n, dofs, step, h = passing[-1]
            more = " (largest run)" if passing[-1] is points[-1] else ""
            row += [f"n={n}{more}", dofs, step / h]
        rows.append(row)
    return ["algorithm", "solver", "1 rank: largest rod", "dofs", "wall/simulated",
            "2 ranks: largest rod", "dofs", "wall/simulated"], rows


def targets(records, probes=(), paper=None):
    """The issue's targets, each with the measured worst case over the sizes it covers."""
    rows = []

    def worst(values, larger_is_worse=True):
        values = [v for v in values if v is not None and math.isfinite(v)]
        if not values:
            return None
        return max(values) if larger_is_worse else min(values)

    def check(name, value, limit, larger_is_worse=True, where=""):
        if value is None:
            rows.append([name, where, "not measured", fmt(limit), "not measured"])
            return
        met = value <= limit if larger_is_worse else value >= limit
        rows.append([name, where, fmt(value), fmt(limit), "met" if met else "NOT met"])

    el = ("explicit-lumped", "-")
    big = [r for r in records if r["dofs"] >= 2e5]
    meas_lim = []
    for rec in big:
        s, o = get(rec, "ours1", el, "step_s"), rec.get("ours1", {})
        if s is not None:
            meas_lim.append(s / (get(rec, "ours1", el, "bytes") / o["triad_Bps"]))
    where = "dofs >= 2e5: " + ", ".join(f"{r['benchmark']} {r['size']}" for r in big if get(r, "ours1", el, "step_s"))
    check("explicit-lumped step: measured/limit (1 rank)", worst(meas_lim), 1.3, where=where)
    check("explicit-lumped step: ours/peer", worst(ratio(get(r, "ours1", el, "step_s"),
                                                          get(r, "peer", el, "step_s")) for r in big), 0.7,
          where=where)
    imp = ("implicit", "direct")
    mid = [r for r in records if r["dofs"] >= 1e5 and get(r, "ours1", imp, "step_s") and best_peer_direct(r, "implicit")]
    where = "dofs >= 1e5: " + ", ".join(f"{r['benchmark']} {r['size']}" for r in mid)
    check("implicit direct step: ours/best peer direct", worst(
        ratio(get(r, "ours1", imp, "step_s"), best_peer_direct(r, "implicit")[1]["step_s"]) for r in mid), 0.7, where=where)
    check("implicit direct setup: ours/best peer direct", worst(
        ratio(get(r, "ours1", imp, "setup_s"), min(get(r, "peer", ("implicit", s), "setup_s") or math.inf
                                                   for s in ("pardiso", "superlu"))) for r in mid), 1.0, where=where)
    for cg in (("implicit", s) for s in OURS_ITERATIVE):
        largest = [r for r in records if r["dofs"] >= 6e5 and get(r, "ours1", cg, "step_s")
                   and get(r, "peer", ("implicit", "pyamg"), "step_s")]
        where = ", ".join(f"{r['benchmark']} {r['size']}" for r in largest) or "7e5 dofs not reached by both"
        check(f"implicit {cg[1]} step: ours/pyamg at 7e5 dofs", worst(
            ratio(get(r, "ours1", cg, "step_s"), get(r, "peer", ("implicit", "pyamg"), "step_s")) for r in largest),
            0.8, where=where)
    for case in OURS_CASES:
        sp = [ratio(get(r, "ours1", case, "step_s"), get(r, "ours2", case, "step_s"))
              for r in records if r["dofs"] >= 1e5]
        check(f"2 ranks vs 1: {case[0]} {case[1]} step speed-up", worst(sp, larger_is_worse=False), 1.7,
              larger_is_worse=False, where="dofs >= 1e5")
    cap_header, cap = capacity(records, probes)
    for row in cap:
        if row[0] in ("explicit-lumped", "implicit"):
            need = 1e5 if row[0] == "explicit-lumped" else 3e4
            dofs = [d for d in (row[3], row[6]) if d is not None]
            value = max(dofs) if dofs else None
            rows.append([f"real time: {row[0]} {row[1]} (best of 1, 2 ranks)", "rod", fmt(value), fmt(need),
                         "met" if value is not None and value >= need else "NOT met"])
    if paper:  # serial and 2 ranks, warm form cache: the faster of the two is what a user gets
        warm = [t for name, t in paper.items() if name != "serial, cold" and t is not None]
        check("tissuebench paper, wall s (best of serial, 2 ranks; warm cache)", min(warm) if warm else None,
              60.0, where=", ".join(f"{name} {fmt(t)}" for name, t in paper.items()))
    return ["target", "sizes", "measured (worst)", "target", "status"], rows


# --- report ---------------------------------------------------------------------------------------


def plot(records, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(16, 5.5), sharey=True)
    styles = {("explicit-lumped", "-"): "C0", ("implicit", "direct"): "C1", ("implicit", "cg"): "C2",
              ("implicit", "gamg"): "C6",
              ("implicit-lumped", "direct"): "C3", ("explicit", "direct"): "C4", ("quasi-static", "direct"): "C5"}
    peer_styles = {("explicit-lumped", "-"): "C0", ("implicit", "pardiso"): "C1", ("implicit", "superlu"): "C7",
                   ("implicit", "pyamg"): "C2"}
    for ax, bench in zip(axes, ("rod", "block")):
        recs = [r for r in records if r["benchmark"] == bench]
        for side, dash, label in (("ours1", "-", "ours 1 rank"), ("ours2", "--", "ours 2 ranks")):
            for case, color in styles.items():
                pts = [(r["dofs"], get(r, side, case, "step_s")) for r in recs if get(r, side, case, "step_s")]
                if pts and (side == "ours1" or case in MAIN_CASES):
                    ax.loglog(*zip(*pts), dash, color=color, marker="o", ms=3,
                              label=f"{label}: {case[0]} {case[1] if case[1] != '-' else ''}")
        for case, color in peer_styles.items():
            pts = [(r["dofs"], get(r, "peer", case, "step_s")) for r in recs if get(r, "peer", case, "step_s")]
            if pts:
                ax.loglog(*zip(*pts), ":", color=color, marker="s", ms=3,
                          label=f"peer: {case[0]} {case[1] if case[1] != '-' else 'CSR'}")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(f"{bench}: time per step (median)")
        ax.set_xlabel("degrees of freedom")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("wall time per step (s)")
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0))  # clear of the curves
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def machine_description():
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{cpu}, {os.cpu_count()} cores, {mem:.0f} GiB"


def write_report(records, probes, paper, mode, wall, out):
    sizes = {b: [r["size"] for r in records if r["benchmark"] == b] for b in ("rod", "block")}
    ran = {}
    for rec in records:
        for side in ("ours1", "ours2", "peer"):
            for k, r in rec.get(side, {}).get("cases", {}).items():
                if "step_s" in r:
                    mark = "" if r.get("steps") == STEPS else "*"
                    ran.setdefault((rec["benchmark"], side, k), []).append(f"{rec['size']}{mark}")
    parts = [
        "# Performance",
        "",
        f"`tissuebench bench{' --quick' if mode == 'quick' else ''}`: {mode} mode, {wall:.0f} s wall. "
        f"Machine: {machine_description()}. Every worker process ran with "
        f"{', '.join(THREAD_VARS)} = 1 (one BLAS/OpenMP thread per MPI rank); the 2-rank column "
        "ran under `mpiexec -n 2`. The machine is shared: timings are noisy, and every ratio "
        "below comes from measurements taken in this one run.",
        "",
        f"Sizes: rod n = {sizes['rod']}; block N = {sizes['block']} (the dofs closest to the rod's). "
        f"Per step: median of steps {WARMUP[STEPS] + 1}..{STEPS} of {STEPS} (or, where {STEPS} "
        f"steps would exceed the case's budget, of steps {WARMUP[SHORT] + 1}..{SHORT} of {SHORT}, "
        "without the displacement check). Setup: everything before "
        "the first step (step matrix, factorisation or preconditioner, initial acceleration). "
        f"Explicit schemes run at {SAFETY} x their critical step 2/omega_max (at most 1/30 s; "
        "omega_max by SLEPc as in solvers/stability.py), the others at h = 1/30 s. Peak memory: the peak resident set "
        "during that case, summed over ranks (the whole process: mesh, matrices and all).",
        "",
        "Peer: scikit-fem assembly (2x2(x2) Gauss points), SciPy CSR; direct = SuperLU (splu, "
        "MMD_AT_PLUS_A, symmetric mode) or MKL PARDISO (pypardiso, SPD Cholesky, solve phase "
        "called directly), iterative = SciPy CG + pyamg smoothed aggregation with rigid-body "
        "modes, relative residual 1e-12, warm start. Ours: the defaults of `tissuebench run` "
        "(matrix-vector products by the block-CSR loop of solvers/blockcsr.py, compiled here with "
        "-O3 -march=native; factorisations, solves and preconditioners by the wheel's PETSc and "
        "MUMPS, built -O2 for a generic x86-64). "
        "'u diff': relative difference of all nodal displacements after "
        f"{STEPS} steps, nodes matched by coordinates (peer against ours on 1 rank; "
        f"direct solvers must agree to {DIRECT_TOL:g}).",
        "",
        "## Targets",
        "",
        markdown_table(*targets(records, probes, paper)),
        "",
        "## Real-time capacity (rod)",
        "",
        "The largest rod mesh measured whose time per step is at most its step h (one simulated "
        "second in at most one wall second); 'wall/simulated' is step time / h there. For "
        "explicit-lumped and implicit direct (the cases with a target), the rod size n is also "
        "bisected between the sweep's last size in real time and the next one, with runs of "
        f"{SHORT} steps: " + (", ".join(f"{p['case']} {p['ranks']}r n={p['n']}: "
                                        + (fmt(p['step_s'] / p['h']) if p.get('step_s') else "failed")
                                        for p in probes) or "no probe was needed") + ".",
        "",
        markdown_table(*capacity(records, probes)),
        "",
        "## Explicit-lumped step against the memory-bandwidth limit",
        "",
        "limit = bytes / triad bandwidth; bytes = the stiffness matrix as the step reads it (the "
        "compiled block-CSR loop of solvers/blockcsr.py: gdim x gdim blocks of values, one 4-byte "
        "column index per block, row starts) + 8 vectors (u, v, a read and written, f and M_L "
        "read), a lower bound for any implementation with this storage. The peer's limit uses "
        "its CSR bytes and the 1-rank triad.",
        "",
        markdown_table(*bandwidth_rows(records)),
        "",
        "## Steps: ours against the peer, 1 rank against 2",
        "",
        "The peer column is its fastest solver of the same kind (direct: PARDISO or SuperLU; "
        "cg and gamg: pyamg).",
        "",
        markdown_table(*step_rows(records)),
        "",
        "## Assembly of K and M",
        "",
        markdown_table(*assembly_rows(records)),
        "",
        "## Every peer solver",
        "",
        markdown_table(*extra_peer_rows(records)),
        "",
        "## Which sizes ran",
        "",
        "A case stops at the first size whose predicted cost exceeds its budget "
        f"({BUDGET[mode]['main']:.0f} s for the targets' cases, {BUDGET[mode]['iterative']:.0f} s for "
        f"the implicit step's iterative solvers, {BUDGET[mode]['other']:.0f} s for the others; the peer's "
        "pyamg runs, if only for a short run, wherever one of our iterative solvers ran); the peer "
        f"stops when its assembly would exceed {BUDGET[mode]['assembly']:.0f} s. "
        f"Sizes marked * ran {SHORT} steps instead of {STEPS}.",
        "",
        markdown_table(["bench", "side", "case", "sizes"],
                       [[b, s, k, ", ".join(map(str, v))] for (b, s, k), v in sorted(ran.items())]),
        "",
    ]
    errors = [f"- {r['benchmark']} {r['size']} {side}: {r[side]['error']}"
              for r in records for side in ("ours1", "ours2", "peer") if "error" in r.get(side, {})]
    errors += [f"- {r['benchmark']} {r['size']} {side} {k}: {c['error']}" for r in records
               for side in ("ours1", "ours2", "peer") for k, c in r.get(side, {}).get("cases", {}).items()
               if "error" in c]
    if errors:
        parts += ["## Failures", ""] + errors + [""]
    parts += ["![time per step](performance.png)", ""]
    (out / "performance.md").write_text("\n".join(parts))


def add_parser(subparsers):
    p = subparsers.add_parser(
        "bench", help="speed against a scikit-fem + SciPy peer, the bandwidth limit and 2 ranks",
        description="Measure assembly, setup and step times of every algorithm against a scikit-fem "
                    "+ SciPy peer, the memory-bandwidth limit and 2 MPI ranks; write "
                    "DIR/performance.md, .png and .json. Needs the 'bench' extra.")
    p.add_argument("--quick", action="store_true", help="small sizes only (a minute or two)")
    p.add_argument("--out", default="results", type=Path, help="output directory (default results)")
    p.set_defaults(func=main)


def main(args):
    from tissuebench.workflows.cli import UsageError

    if int(os.environ.get("PMI_SIZE", os.environ.get("OMPI_COMM_WORLD_SIZE", "1"))) > 1:
        raise UsageError("run `tissuebench bench` without mpiexec: it starts its own 2-rank runs")
    try:
        import pyamg  # noqa: F401
        import scipy  # noqa: F401
        import skfem  # noqa: F401
    except ImportError as err:
        raise UsageError(f"the bench needs the 'bench' extra (pip install -e '.[bench]'): {err}") from None
    mode = "quick" if args.quick else "full"
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    print(f"tissuebench bench ({mode}): workers pinned to 1 BLAS/OpenMP thread per rank", flush=True)
    records, probes, paper = measure(mode, out, lambda line: print(line, flush=True))
    wall = time.perf_counter() - start
    (out / "performance.json").write_text(json.dumps({"mode": mode, "wall_s": wall, "records": records,
                                                      "capacity_probes": probes, "paper_s": paper}))
    plot(records, out / "performance.png")
    write_report(records, probes, paper, mode, wall, out)
    for title, table in (("targets", targets(records, probes, paper)), ("explicit-lumped vs bandwidth", bandwidth_rows(records)),
                         ("steps", step_rows(records)), ("assembly", assembly_rows(records)),
                         ("real-time capacity (rod)", capacity(records, probes))):
        print(f"\n{title}\n{text_table(*table)}")
    print(f"\nwall {wall:.0f} s; wrote {out / 'performance.md'} and {out / 'performance.png'}")
    return 0


if __name__ == "__main__" and len(sys.argv) == 5 and sys.argv[1] == "--worker":
    worker_main(sys.argv[2:])
