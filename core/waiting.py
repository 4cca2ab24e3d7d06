"""The other ranks' wait for rank 0's work (figures, reports, a grading on one process): asleep,
not in a blocking collective, in which MPICH polls at full speed, a core per waiting rank, for
as long as rank 0 works (seconds, on cores that rank 0's own threads or other jobs could use)."""

from __future__ import annotations

import time

from mpi4py import MPI

POLL_SECONDS = 0.002  # s: how often the other ranks look whether rank 0 has come


def wait_for_rank0(comm: MPI.Comm) -> None:
    """Return on every rank once rank 0 has come here: the other ranks sleep between looks
    (every POLL_SECONDS). Signals are only recorded under mpiexec (core/interrupt.py), so a
    rank sleeping here never leaves alone."""
    if comm.size == 1:
        return
    request = comm.Ibarrier()
    if comm.rank == 0:
        request.Wait()
        return
    while not request.Test():
        time.sleep(POLL_SECONDS)
