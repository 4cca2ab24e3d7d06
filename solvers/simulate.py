"""Run an integrator for n steps, detecting divergence as SPEC section 3 defines it."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mpi4py import MPI
from petsc4py import PETSc

import numpy as np

from tissuebench.core import interrupt
from tissuebench.solvers.algorithm import Integrator, State
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
    reason: str | None = None  # why it diverged, in a few words
    u: list = field(default_factory=list)
    v: list = field(default_factory=list)


def max_nodal_displacement(u: np.ndarray, gdim: int, comm: MPI.Comm) -> float:
    """The largest nodal displacement magnitude over all ranks (m); inf if any is not finite."""
    local = u.reshape(-1, gdim)
    finite = bool(np.isfinite(local).all())
    largest = float(np.linalg.norm(local, axis=1).max(initial=0.0)) if finite else np.inf
    return comm.allreduce(largest, op=MPI.MAX)


def simulate(
    integrator: Integrator,
    n_steps: int,
    extent: float,
    name: str = "",
    on_step: Callable[[State], None] | None = None,
    keep: bool = True,
) -> Run:
    """Advance `integrator` n_steps steps from its initial state.

    A step whose displacement is not finite or exceeds 100 x `extent` (m), or whose linear
    solve fails, stops the run: it is recorded as diverged at that step and time, with the
    reason, and the steps before it are kept (none if the initial state, step 0, fails).
    A SIGINT or SIGTERM under mpiexec is raised here, on all ranks at the same step.
    `on_step(state)` is called at step 0 and after every kept step.
    """
    system = integrator.system
    comm, gdim = system.comm, system.gdim
    run = Run(name)
    limit = 100.0 * extent
    start = time.perf_counter()
    state: State | None = None
    for i in range(n_steps + 1):
        reason, largest = None, 0.0
        try:  # no communication inside: one rank failing must not leave the others waiting
            with interrupt.calling_back():  # a signal in a PETSc callback is not a divergence
                if i == 0:
                    state = integrator.start()
                else:
                    assert state is not None  # the last step's: a failed step ends the run
                    state = integrator.step(state)
            local = state.u.array_r.reshape(-1, gdim)
            largest = (
                float(np.linalg.norm(local, axis=1).max(initial=0.0))
                if np.isfinite(local).all()
                else np.inf
            )
        except SolveError as err:
            reason = str(err)
        except (PETSc.Error, FloatingPointError) as err:
            reason = f"{type(err).__name__}: {' '.join(str(err).split())[:200]}"
        reports = comm.allgather((reason, largest, interrupt.pending()))
        interrupt.stop_together(r[2] for r in reports)  # a signal: all ranks stop here
        largest = max(r[1] for r in reports)
        reason = next((r[0] for r in reports if r[0]), None)
        if reason is None and not np.isfinite(largest):
            reason = "displacement not finite"
        elif reason is None and largest > limit:
            reason = f"largest displacement {largest:.3g} m > 100 x the domain's extent"
        if reason is not None:
            run.status, run.diverged_step, run.diverged_time = "diverged", i, i * integrator.h
            run.reason = reason
            break
        run.steps = i
        assert state is not None  # the step just taken
        if keep:
            run.u.append(state.u.array_r.copy())
            run.v.append(state.v.array_r.copy())
        if on_step is not None:
            on_step(state)
    run.wall_time_s = time.perf_counter() - start
    return run
