"""The STREAM-like triad the bench holds the explicit step against (its memory-bandwidth
limit = the bytes a step moves / the triad's bandwidth), and the step timed between triad
samples, so that both are measured under the same conditions on a shared machine. Units:
bytes, bytes/s, seconds."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI

TRIAD_SIZE = 2**24  # entries of each triad vector (128 MiB): far beyond the caches
# The explicit-lumped step that moves at least TRIAD_AROUND_BYTES a step (this machine's 32 MiB
# L3: its data passes through memory every step, so a triad between its steps evicts nothing it
# would have kept) is timed between triad samples: one before its first step and one after
# every TRIAD_EVERY steps, each the best of TRIAD_REPEATS triads; its limit uses their median
# (timed_steps). The sweep's sizes of 2e5 dofs and more are all above it.
TRIAD_AROUND_BYTES = 32 * 2**20
TRIAD_EVERY = 5
TRIAD_REPEATS = 3


class Triad:
    """The STREAM-like triad w = 3 x + y on `size` entries spread over comm's ranks (24 bytes
    per entry: two reads, one write), its vectors made once; sample() is one measurement."""

    def __init__(self, comm: MPI.Comm, size: int = TRIAD_SIZE) -> None:
        from petsc4py import PETSc

        self.comm, self.size = comm, size
        self.x = PETSc.Vec().createMPI((PETSc.DECIDE, size), comm=comm)  # type: ignore[arg-type]  # petsc4py's stubs: it takes an mpi4py Comm
        self.y, self.w = self.x.duplicate(), self.x.duplicate()
        self.x.set(1.0)
        self.y.set(2.0)
        self.w.set(0.0)

    @property
    def nbytes(self) -> int:
        """Bytes its three vectors hold on all ranks together."""
        return 3 * 8 * self.size

    def sample(self, repeats: int = 10) -> float:
        """Best bandwidth over `repeats` triads on all ranks at once, bytes/s."""
        best = math.inf
        for _ in range(repeats):
            self.comm.Barrier()
            start = time.perf_counter()
            self.w.waxpy(3.0, self.x, self.y)
            self.comm.Barrier()
            best = min(best, time.perf_counter() - start)
        return 24 * self.size / best

    def destroy(self) -> None:
        for v in (self.x, self.y, self.w):
            v.destroy()


def triad_bandwidth(comm: MPI.Comm, size: int = TRIAD_SIZE, repeats: int = 10) -> float:
    """Best STREAM-like triad bandwidth over all ranks at once, bytes/s (Triad.sample)."""
    triad = Triad(comm, size)
    try:
        return triad.sample(repeats)
    finally:
        triad.destroy()


def timed_steps(
    step: Callable[[Any], Any],
    state: Any,
    steps: int,
    comm: MPI.Comm,
    times: list[float],
    triad: Triad | None = None,
    after: Callable[[], None] | None = None,
) -> tuple[Any, list[float]]:
    """`steps` steps of `step` from `state`, each timed (s) between barriers into `times` (kept
    up to a step that raises), `after` called after each outside the timing; with `triad`, a
    triad sample (bytes/s) before the first step and after every TRIAD_EVERY steps, so that the
    step and the bandwidth it is held against are measured under the same conditions (a
    shared machine's bandwidth swings within minutes). Returns (state, samples)."""
    samples = [triad.sample(TRIAD_REPEATS)] if triad else []
    for i in range(steps):
        comm.Barrier()
        start = time.perf_counter()
        state = step(state)
        comm.Barrier()
        times.append(time.perf_counter() - start)
        if after:
            after()
        if triad and (i + 1) % TRIAD_EVERY == 0:
            samples.append(triad.sample(TRIAD_REPEATS))
    return state, samples


def sampler(explicit_lumped: bool, step_bytes: int, comm: MPI.Comm) -> Triad | None:
    """A Triad to sample between the steps of an explicit-lumped step moving at least
    TRIAD_AROUND_BYTES (collective: every rank passes the same), else None. Made before the
    case's peak-memory reset: its bytes (Triad.nbytes) are taken off that peak."""
    return Triad(comm) if explicit_lumped and step_bytes >= TRIAD_AROUND_BYTES else None


def keep_samples(record: dict, samples: list[float]) -> None:
    """Record a case's triad samples (bytes/s) and their median, which its limit uses."""
    if samples:
        record["triad_Bps"] = float(np.median(samples))
        record["triad_samples_Bps"] = samples
