"""Ending a job on SIGINT or SIGTERM, with every MPI rank stopping at the same step.

In serial a signal raises at once: KeyboardInterrupt for SIGINT, `Terminated` for SIGTERM.

Under mpiexec, MPICH's launcher passes the signal on to every rank, each at its own moment.
A rank raising at once would leave the others waiting for it in a collective, and MPI_Abort,
the only way to end them then, kills the processes before their last lines of output have
reached the terminal. So under mpiexec a signal is only recorded, and `simulate` asks every
rank once a step (`stop_together`): when any rank holds one, all raise at that step and the
job unwinds and ends normally. When no step comes within `GRACE` seconds (meshing, compiling
forms, writing output), rank 0 raises alone and the command line ends the job with MPI_Abort.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Iterable

from mpi4py import MPI

GRACE = 10.0  # s: how long rank 0 waits for a step at which all ranks can stop together

_pending = 0  # the signal received and not yet raised, 0 if none
_together = False  # the last signal was raised on every rank at one step


class Terminated(BaseException):
    """SIGTERM, raised in the main thread as KeyboardInterrupt is for SIGINT."""


def exception(signum: int) -> BaseException:
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


def _raise(signum, frame):
    raise exception(signum)


def _record(signum, frame):
    global _pending
    if not _pending and MPI.COMM_WORLD.rank == 0:
        signal.setitimer(signal.ITIMER_REAL, GRACE)
    _pending = _pending or signum


def _alarm(signum, frame):
    raise exception(_pending)


def install(comm: MPI.Comm) -> Callable[[], None]:
    """Install the handlers for a job on `comm`; return the function that restores the old."""
    global _pending, _together
    _pending, _together = 0, False
    names = (signal.SIGINT, signal.SIGTERM, signal.SIGALRM)
    previous = {s: signal.getsignal(s) for s in names}
    handler = _raise if comm.size == 1 else _record
    signal.signal(signal.SIGINT, handler)
    signal.signal(signal.SIGTERM, handler)
    if comm.size > 1 and comm.rank == 0:
        signal.signal(signal.SIGALRM, _alarm)

    def restore():
        signal.setitimer(signal.ITIMER_REAL, 0)
        for number, old in previous.items():
            signal.signal(number, old)

    return restore


def pending() -> int:
    """The signal this rank received and has not raised yet, 0 if none."""
    return _pending


def stop_together(received: Iterable[int]) -> None:
    """Raise the signal if any rank received one. `received` is every rank's `pending()`,
    gathered, so that all ranks decide alike and raise at the same point."""
    global _pending, _together
    signum = max(received, default=0)
    if signum:
        signal.setitimer(signal.ITIMER_REAL, 0)
        _pending, _together = 0, True
        raise exception(signum)


def raised_together() -> bool:
    """Whether the signal being handled was raised on every rank at one step."""
    return _together
