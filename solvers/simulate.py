"""Run an integrator for n steps, detecting divergence as SPEC section 3 defines it."""

import time
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np

from tissuebench.solvers.linear import SolveError


@dataclass
class Run:
    """What a run computed. `u` and `v` hold the owned dof values at steps 0..steps (m, m/s);
    a diverged run holds the steps before the one where it diverged."""

    algorithm: str
    status: str = "ok"  # "ok" or "diverged"
    diverged_step: int | None = None
    diverged_time: float | None = None
    steps: int = 0  # the last step computed and kept
    wall_time_s: float = 0.0
    u: list = field(default_factory=list)
    v: list = field(default_factory=list)


def max_nodal_displacement(u, gdim, comm):
    """The largest nodal displacement magnitude over all ranks (m); inf if any is not finite."""
    local = u.reshape(-1, gdim)
    finite = bool(np.isfinite(local).all())
    largest = float(np.linalg.norm(local, axis=1).max(initial=0.0)) if finite else np.inf
    return comm.allreduce(largest, op=MPI.MAX)


def simulate(integrator, n_steps, extent, name="", on_step=None, keep=True):
    """Advance `integrator` n_steps steps from its initial state.

    A step whose displacement is not finite or exceeds 100 x `extent` (m), or whose linear
    solve fails, stops the run: it is recorded as diverged at that step and time and the
    steps before it are kept. `on_step(state)` is called at step 0 and after every kept step.
    """
    system = integrator.system
    comm, gdim = system.comm, system.gdim
    run = Run(name)
    limit = 100.0 * extent
    start = time.perf_counter()
    state = integrator.start()
    for i in range(n_steps + 1):
        if i > 0:
            try:
                state = integrator.step(state)
                bad = max_nodal_displacement(state.u.array_r, gdim, comm) > limit
            except (SolveError, PETSc.Error, FloatingPointError):
                bad = True
            bad = comm.allreduce(bad, op=MPI.LOR)
            if bad:
                run.status, run.diverged_step, run.diverged_time = "diverged", i, i * integrator.h
                break
        run.steps = i
        if keep:
            run.u.append(state.u.array_r.copy())
            run.v.append(state.v.array_r.copy())
        if on_step is not None:
            on_step(state)
    run.wall_time_s = time.perf_counter() - start
    return run
