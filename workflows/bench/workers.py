"""The worker processes of `tissuebench bench` (workflows/bench/measure.py runs them): `python -m
tissuebench.workflows.bench.workers --worker ours|peer|explicit SPEC.json RESULT.json`, each in a
fresh process (under `mpiexec -n 2` for the 2-rank column) with one BLAS/OpenMP thread per rank,
so that peak memory is per process and nothing is shared between the sides.

- ours_worker: our assembly, set-up and steps of every case of the spec (and the displacements
  after them, for the comparisons), with peak memory and the STREAM-like triad;
- explicit_worker: the explicit-lumped step with each elastic model and remedy, in rounds;
- peer_worker: the scikit-fem + SciPy peer (workflows/bench/peer_skfem.py) on the same mesh.

Units: seconds, bytes, degrees of freedom.
"""

from __future__ import annotations

import gc
import json
import math
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from tissuebench.workflows.bench.measure import (
    BLOCK,
    BLOCK_WARM,
    EXPLICIT,
    OURS_ITERATIVE,
    ROUNDS,
    SAFETY,
    STEPS,
    WARMUP,
    case_scheme,
    key,
    split_case_label,
)
from tissuebench.workflows.bench.triad import keep_samples, sampler, timed_steps, triad_bandwidth

if TYPE_CHECKING:
    from tissuebench.solvers.system import System


def reset_peak_memory() -> None:
    """Start a new peak-resident-set measurement for this process (Linux: clear_refs 5)."""
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:
        pass


def peak_memory() -> int:
    """This process's peak resident set since the last reset, bytes."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    return 0


def median_step(times: list[float]) -> float:
    """Median time per step (s) of the steps after the warm-up (that of STEPS for a run of
    another length)."""
    return float(np.median(times[WARMUP.get(len(times), WARMUP[STEPS]) :]))


# --- the worker for tissuebench (ours), 1 or 2 ranks ------------------------------------------


def explicit_lumped_bytes(matrix_bytes: int, n: int) -> int:
    """Bytes one explicit-lumped step moves at least: the matrix once (as stored), and 9
    vectors of n doubles once: u (ubar), f, 1 / S, alpha M_L, v and a read, v, a and the next
    step's predictor of u written (solvers/explicit_lumped.py: one pass a step)."""
    return matrix_bytes + 9 * 8 * n


def stable_steps(system: System, names: Iterable[str]) -> tuple[dict, dict, float]:
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


def ours_worker(spec: dict) -> dict:
    """Assembly, triad (unless spec["triad"] is false) and every case of `spec` with
    tissuebench, on this process's ranks. A case (label, solver, steps) runs the label's
    algorithm with its model (split_case_label); a nonlinear model's implicit step records its
    Newton iterations per step, even up to a divergence."""
    from mpi4py import MPI
    from petsc4py import PETSc

    import dolfinx.fem.petsc

    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.system import System, gather_by_coordinates

    comm = MPI.COMM_WORLD
    out: dict[str, Any] = {"ranks": comm.size, "cases": {}}
    if spec.get("triad", True):
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

    # h per case label; a model case runs at its algorithm's (linear) stable step
    h = {label: bench.dt for label, _, _ in spec["cases"]}
    explicit = sorted({split_case_label(a)[0] for a, _, _ in spec["cases"]} & set(EXPLICIT))
    if spec.get("h"):
        h.update(spec["h"])
    elif explicit:
        stable, out["omega_from"], out["eigen_s"] = stable_steps(system, explicit)
        for label in h:
            if split_case_label(label)[0] in stable:
                h[label] = min(bench.dt, stable[split_case_label(label)[0]])
    out["h"] = h

    if comm.rank == 0 and spec.get("mesh_out"):
        n = system.V.dofmap.index_map.size_local
        np.savez(
            spec["mesh_out"],
            points=system.V.tabulate_dof_coordinates()[:n, : system.gdim],
            cells=system.V.dofmap.list,
            mu=float(system.mu.value),
            lmbda=float(system.lmbda.value),
            rho=system.material.rho,
            alpha=system.material.alpha,
            beta=system.material.beta,
        )

    systems = {"standard": system}  # a case with '@SCHEME' runs on that scheme's system
    displacements = {}
    for label, solver, steps in spec["cases"]:
        algorithm, model = split_case_label(label)
        newton = model != "linear" and algorithm not in EXPLICIT
        scheme = case_scheme(label)
        if scheme not in systems:
            comm.Barrier()
            start = time.perf_counter()
            systems[scheme] = System(bench, scheme=scheme)
            out.setdefault("assembly_s", {})[f"system {scheme}"] = time.perf_counter() - start
        record = {"h": h[label], "steps": steps}
        times: list[float] = []
        iterations: list[int] = []
        step_bytes = explicit_lumped_bytes(comm.allreduce(system.K_csr.nbytes), system.num_dofs())
        triad = sampler(label == "explicit-lumped", step_bytes, comm)  # before the peak's reset
        gc.collect()
        reset_peak_memory()
        try:
            comm.Barrier()
            start = time.perf_counter()
            integrator = get_integrator(
                algorithm,
                systems[scheme],
                h[label],
                solver="direct" if solver == "-" else solver,
                model=model,
            )
            state = integrator.start()
            comm.Barrier()
            record["setup_s"] = time.perf_counter() - start
            if label == "explicit-lumped":  # the matrix its one product per step reads
                A = system.K_csr  # solvers/blockcsr.py: blocks, block columns, row starts
                record["matrix_type"] = "block CSR"
                record["bytes"] = explicit_lumped_bytes(comm.allreduce(A.nbytes), system.num_dofs())
            count = solver in OURS_ITERATIVE or newton

            def count_iterations(it: Any = integrator) -> None:
                iterations.append(it.iterations())

            state, samples = timed_steps(
                integrator.step,
                state,
                steps,
                comm,
                times,
                triad,
                after=count_iterations if count else None,
            )
            keep_samples(record, samples)
            record["step_s"] = median_step(times)
            record["steps_s"] = times
            finite = bool(np.isfinite(state.u.array_r).all())
            record["finite"] = bool(comm.allreduce(finite, op=MPI.LAND))
            gathered = gather_by_coordinates(systems[scheme].V, state.u.array_r, comm)
            if comm.rank == 0:
                assert gathered is not None  # gathered on rank 0
                displacements[key((label, solver))] = gathered[1]
                displacements["x"] = gathered[0][:, : system.gdim]
            integrator.destroy()
            del integrator, state
        except (PETSc.Error, RuntimeError, np.linalg.LinAlgError) as err:
            record["error"] = str(err)[:200]
            if "setup_s" in record:  # the step that failed
                record["steps_done"] = len(times)
                record["diverged_t"] = (len(times) + 1) * h[label]
                if len(times) >= WARMUP[STEPS] + 5:  # the cost of the steps before it
                    record["step_s"] = median_step(times)
                    record["steps_s"] = times
        if iterations:
            record["iterations"] = float(np.mean(iterations))
        if newton:  # Newton iterations of each step that converged
            record["newton_iterations"] = iterations
        record["peak_bytes"] = comm.allreduce(peak_memory()) - (triad.nbytes if triad else 0)
        if triad:
            triad.destroy()
        out["cases"][key((label, solver))] = record
    if comm.rank == 0 and spec.get("u_out"):
        np.savez(spec["u_out"], **displacements)  # type: ignore[arg-type]  # numpy's stubs: ** may hold allow_pickle
    return out


# --- the worker of `bench --only explicit-models` (1 rank) -------------------------------------


def explicit_worker(spec: dict) -> dict:
    """The explicit-lumped cases of `spec` (linear and with models or remedies, at the linear
    scheme's stable step on the plain mesh) run side by side: every integrator is built and
    started first, then ROUNDS rounds in which each case takes BLOCK steps in a row, the last
    BLOCK - BLOCK_WARM of them timed. A change of the machine's load during the run then
    weighs on every case alike (the machine is shared), while each case still steps with its
    own data in the caches, as a run of it alone would. step_s: the median of its timed steps;
    cpu_step_s: the median of their CPU times (time.process_time: without the time the process
    waited for a core).
    A case that diverges stops there (its timed steps so far are kept)."""
    from mpi4py import MPI

    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.system import System

    comm = MPI.COMM_WORLD
    out: dict[str, Any] = {"ranks": comm.size, "cases": {}, "assembly_s": {}}
    bench = get_benchmark(spec["benchmark"], mesh_size=spec["size"], comm=comm)
    start = time.perf_counter()
    systems = {"standard": System(bench)}
    out["assembly_s"]["system standard"] = time.perf_counter() - start
    system = systems["standard"]
    out["dofs"] = system.num_dofs()
    stable, out["omega_from"], out["eigen_s"] = stable_steps(system, ["explicit-lumped"])
    h = min(bench.dt, stable["explicit-lumped"])
    out["h"] = {label: h for label, _, _ in spec["cases"]}
    running = {}
    for label, solver, _ in spec["cases"]:
        algorithm, model = split_case_label(label)
        scheme = case_scheme(label)
        if scheme not in systems:
            start = time.perf_counter()
            systems[scheme] = System(bench, scheme=scheme)
            out["assembly_s"][f"system {scheme}"] = time.perf_counter() - start
        record = {"h": h, "steps": ROUNDS * BLOCK, "steps_done": 0, "steps_s": [], "cpu_s": []}
        out["cases"][key((label, solver))] = record
        try:
            start = time.perf_counter()
            integrator = get_integrator(algorithm, systems[scheme], h, model=model)
            state = integrator.start()
            record["setup_s"] = time.perf_counter() - start
            running[key((label, solver))] = (integrator, state)
        except (RuntimeError, ValueError) as err:
            record["error"] = str(err)[:200]
    for _ in range(ROUNDS):
        for k, (integrator, state) in list(running.items()):
            record = out["cases"][k]
            for i in range(BLOCK):
                start, cpu = time.perf_counter(), time.process_time()
                try:
                    state = integrator.step(state)
                except RuntimeError as err:
                    record["error"] = str(err)[:200]
                    record["diverged_t"] = (record["steps_done"] + 1) * h
                    del running[k]
                    break
                record["steps_done"] += 1
                if i >= BLOCK_WARM:
                    record["steps_s"].append(time.perf_counter() - start)
                    record["cpu_s"].append(time.process_time() - cpu)
            else:
                running[k] = (integrator, state)
    for k, record in out["cases"].items():
        if record["steps_s"]:
            record["step_s"] = float(np.median(record["steps_s"]))
            record["cpu_step_s"] = float(np.median(record["cpu_s"]))
            record["timed_steps"] = len(record["steps_s"])
    return out


# --- the worker for the peer (serial) ---------------------------------------------------------


def peer_worker(spec: dict) -> dict:
    """Assembly and every case of `spec` with the scikit-fem + SciPy peer, on the saved mesh
    (its explicit-lumped step timed between triad samples, as ours_worker's)."""
    from mpi4py import MPI

    from tissuebench.workflows.bench import peer_skfem as peer

    data = np.load(spec["mesh_in"])
    material = peer.Material(*(float(data[k]) for k in ("mu", "lmbda", "rho", "alpha", "beta")))
    out: dict[str, Any] = {"ranks": 1, "cases": {}, "pardiso": peer.pardiso_available()}
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
        triad = sampler(algorithm == "explicit-lumped", out["explicit_lumped_bytes"], MPI.COMM_SELF)
        gc.collect()
        reset_peak_memory()
        try:
            start = time.perf_counter()
            integrator = peer.get_peer_integrator(algorithm, system, h, solver)
            state = integrator.start()
            record["setup_s"] = time.perf_counter() - start
            times: list[float] = []
            state, samples = timed_steps(integrator.step, state, steps, MPI.COMM_SELF, times, triad)
            keep_samples(record, samples)
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
        record["peak_bytes"] = peak_memory() - (triad.nbytes if triad else 0)
        if triad:
            triad.destroy()
        out["cases"][key((algorithm, solver))] = record
    np.savez(spec["u_out"], **displacements)  # type: ignore[arg-type]  # numpy's stubs: ** may hold allow_pickle
    return out


def worker_main(argv: list[str]) -> None:
    """`python -m tissuebench.workflows.bench.measure --worker ours|peer SPEC.json RESULT.json`."""
    kind, spec_path, result_path = argv
    spec = json.loads(Path(spec_path).read_text())
    workers = {"ours": ours_worker, "peer": peer_worker, "explicit": explicit_worker}
    result = workers[kind](spec)
    if kind != "ours":  # serial workers
        Path(result_path).write_text(json.dumps(result))
    else:
        from mpi4py import MPI

        if MPI.COMM_WORLD.rank == 0:
            Path(result_path).write_text(json.dumps(result))


if __name__ == "__main__" and len(sys.argv) == 5 and sys.argv[1] == "--worker":
    worker_main(sys.argv[2:])
