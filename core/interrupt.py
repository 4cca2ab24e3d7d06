"""Ending a job on SIGINT or SIGTERM at any moment: exit 130 or 143 with one line, on every
MPI rank alike, with nothing half-written left behind.

The command line (workflows/cli.py) records a signal from its first line on and installs the
handlers below once MPI is up (`install`); they stay in force for the whole command.

In serial a signal raises at once: KeyboardInterrupt for SIGINT, `Terminated` for SIGTERM;
except inside a critical section (`deferred`), which records it and raises it as soon as the
section ends. Critical sections are the code that a signal must not cut half-way:
- the start-up imports (a library half-imported can crash the process as it exits);
- compiling forms (`guard_jit`): FFCx creates NAME.c in its cache before it compiles and
  leaves it there when interrupted, so that every later run of that form waits 10 s and
  fails ("JIT compilation timed out");
- drawing figures (VTK and matplotlib): a signal in VTK's rendering crashed the process
  (leaving its lock and partial folder) or was swallowed and the run went on.

Under mpiexec, MPICH's launcher passes the signal on to every rank, each at its own moment,
and a rank raising alone would leave the others waiting in a collective. So a signal is only
recorded, and all ranks raise it together where they meet:
- `checkpoint(comm)`, collective: at every time step (`simulate`), after start-up, before a
  case folder is moved into place, after each outside simulator's run, and at the end of the
  command, so that no signal is lost when a job ends before its next step;
- `check()`, on rank 0 inside an action of `output.collective` (figures, the files of
  `compare` and the leaderboard): raises `Interrupted`, an Exception, which `collective`
  broadcasts, so that every rank raises it at the same point.
When no such point comes within `GRACE` seconds (a long mesh or compile), rank 0 raises
alone and the command line ends the job with MPI_Abort.

A child process (an outside simulator, `run_child`) is stopped at once on a signal.

A signal raised inside a Python callback of PETSc or SLEPc (a Newton solve's residual) comes
out of the solve as the library's error with the signal as its cause: `calling_back` raises
the signal again instead, around the solves (`guard_solves` for DOLFINx's) and around the
whole command; one raised there and swallowed, or turned into an error that does not name it,
is raised by `calling_back` when the solve returns.

No signal is lost at the end: one that nothing acted on (recorded after the last checkpoint,
raised and lost, or come while the handlers are put back) is returned by `install`'s restore,
and the command line ends with its status (workflows/cli.py). A worker process of the command
(`run_worker`) ends likewise.

This module imports nothing heavy (no MPI): the command line uses it before its imports.
"""

from __future__ import annotations

import functools
import gc
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, NoReturn

if TYPE_CHECKING:
    from mpi4py import MPI

GRACE = 10.0  # s: how long rank 0 waits for a point where all ranks can stop together

# keyed by signal number (a handler's signum is an int)
STATUS: dict[int, int] = {signal.SIGINT: 130, signal.SIGTERM: 143}  # command line's exit status
SAID: dict[int, str] = {
    signal.SIGINT: "interrupted (SIGINT)",
    signal.SIGTERM: "terminated (SIGTERM)",
}

_pending = 0  # the signal received and not yet raised, 0 if none
_raised = 0  # the signal last raised and not yet acknowledged by the command line
_parallel = False  # under mpiexec (more than one rank): record, never raise in the handler
_rank0 = True
_depth = 0  # critical sections open (`deferred`)
_late = False  # GRACE passed inside a critical section: rank 0 raises when it ends
_together = False  # the last signal was raised on every rank at one point
_unwritten: list[str] = []  # what the command has still to write (`will_write`)
_restoring = False  # the old handlers are being put back (`install`'s restore): record only


class Terminated(BaseException):
    """SIGTERM, raised in the main thread as KeyboardInterrupt is for SIGINT."""


class Interrupted(Exception):  # noqa: N818 (named for what happened, as KeyboardInterrupt)
    """A signal raised by `check()` on rank 0 inside `output.collective`, which broadcasts
    it to every rank (an Exception, so that `collective` passes it on). `signum` is the
    signal's number."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = int(signum)


def exception(signum: int) -> BaseException:
    return KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


def signal_of(exc: BaseException) -> int:
    """The signal that an exception raised by this module stands for."""
    if isinstance(exc, Interrupted):
        return exc.signum
    return signal.SIGINT if isinstance(exc, KeyboardInterrupt) else signal.SIGTERM


def _take() -> BaseException:
    """The pending signal as an exception, cleared (and kept as raised: `pending`)."""
    global _pending, _late, _raised
    signum, _pending, _late = _pending or _raised, 0, False
    _raised = signum
    signal.setitimer(signal.ITIMER_REAL, 0)
    return exception(signum)


def _lost() -> int:
    """A signal raised earlier that did not reach the command line: an exception raised in a
    handler runs at the next bytecode, and where that is inside a __del__ or a library's broad
    `except`, Python drops it. Outside the handling of an exception (sys.exc_info() empty:
    not while an exception unwinds through `finally` or `except`), it is raised again."""
    return _raised if sys.exc_info()[0] is None else 0


def _unraisable(previous: Callable) -> Callable:
    """A hook for `sys.unraisablehook`: where Python drops our exception (raised in a
    __del__ or a weak reference's callback), it would print "Exception ignored in" and a
    traceback; the signal is raised again at the next point (`_lost`), so say nothing. Nor
    of what the objects that the signal left half-built raise in their __del__ as they go (an
    __init__ cut before it set the attributes its __del__ reads: DOLFINx's Vector), from the
    signal's raising to the command's end (`restore`)."""

    def hook(unraisable):
        if _raised:
            return
        previous(unraisable)

    return hook


def acknowledge() -> None:
    """The command line has taken the signal raised (it ends with its status)."""
    global _raised
    _raised = 0


def _handle(signum, frame):
    global _pending
    first = not _pending
    _pending = _pending or signum
    if _restoring:  # passed on by restore() to the handlers it puts back
        return
    if not _parallel and _depth == 0:
        raise _take()
    if _parallel and first and _rank0:
        signal.setitimer(signal.ITIMER_REAL, GRACE)


def _alarm(signum, frame):
    global _late
    if not _pending or _restoring:
        return
    if _depth:
        _late = True  # raised when the critical section ends
        return
    raise _take()


def install(comm: MPI.Comm, received: int = 0) -> Callable[[], int]:
    """Install the handlers for a job on `comm` (an mpi4py communicator). `received` is a
    signal recorded before, by the command line's first handler, which may also carry it as
    its attribute `received` (taken over here: set back to 0). Return the function that
    restores the old handlers; it returns the signal that nothing acted on (`restore`)."""
    global _pending, _together, _parallel, _rank0, _depth, _late, _unwritten, _raised
    global _restoring
    names = (signal.SIGINT, signal.SIGTERM, signal.SIGALRM)
    previous = {s: signal.getsignal(s) for s in names}
    received = received or getattr(previous[signal.SIGINT], "received", 0)
    if received and hasattr(previous[signal.SIGINT], "received"):
        setattr(previous[signal.SIGINT], "received", 0)  # a function attribute: by name
    _pending, _together, _late, _unwritten, _raised = 0, False, False, [], 0
    _restoring = False
    _parallel, _rank0, _depth = comm.size > 1, comm.rank == 0, 0
    signal.signal(signal.SIGALRM, _alarm)
    signal.signal(signal.SIGINT, _handle)
    signal.signal(signal.SIGTERM, _handle)
    previous_hook = sys.unraisablehook
    sys.unraisablehook = _unraisable(previous_hook)
    if received:
        _pending = received
        if _parallel and _rank0:
            signal.setitimer(signal.ITIMER_REAL, GRACE)

    def restore() -> int:
        """Put the old handlers back. Return the signal received and not raised (under
        mpiexec after the last checkpoint; while restoring), or raised and not yet taken
        (`_lost`), 0 if none: when the caller has not ended with a signal's status, it passes
        it on to the handlers put back (the command line's `_record` ends the process), so
        that no signal is lost."""
        global _pending, _depth, _raised, _restoring
        _restoring = True  # from here on, _handle only records (no exception, no alarm)
        signal.setitimer(signal.ITIMER_REAL, 0)
        for number, old in previous.items():
            signal.signal(number, old)
        left = _pending or _raised  # read after the last of ours is gone: none comes later
        if _raised:  # what the signal left (in reference cycles) goes, unsaid (`_unraisable`)
            gc.collect()
        sys.unraisablehook = previous_hook
        _pending, _depth, _raised, _restoring = 0, 0, 0, False
        return left

    return restore


def pending() -> int:
    """The signal this rank received and has not raised yet (or raised, and lost: `_lost`),
    0 if none."""
    return _pending or _lost()


def stop_together(received: Iterable[int]) -> None:
    """Raise the signal if any rank received one. `received` is every rank's `pending()`,
    gathered, so that all ranks decide alike and raise at the same point."""
    global _pending, _together, _late, _raised
    signum = max(received, default=0)
    if signum:
        signal.setitimer(signal.ITIMER_REAL, 0)
        _pending, _together, _late, _raised = 0, True, False, signum
        raise exception(signum)


def checkpoint(comm: MPI.Comm) -> None:
    """Collective: raise the signal on every rank if any rank received one."""
    if comm.size == 1:
        if (_pending or _lost()) and not _depth:
            raise _take()
        return
    stop_together(comm.allgather(pending()))


def check() -> None:
    """Rank 0 inside an action of `output.collective` (or in serial): raise a signal received
    and not yet raised, as `Interrupted`, which every rank raises with rank 0."""
    global _pending, _together, _late, _raised
    if (_pending or _lost()) and not _depth:
        signum = _pending or _raised
        signal.setitimer(signal.ITIMER_REAL, 0)
        _pending, _together, _late, _raised = 0, True, False, signum
        raise Interrupted(signum)


def raised_together() -> bool:
    """Whether the signal being handled was raised on every rank at one point."""
    return _together


def will_write(parts: Iterable) -> None:
    """Name the parts (files, folders) that a command writes one after the other, so that
    the line said on a signal names those not written; `written` takes one off."""
    _unwritten[:] = [str(part) for part in parts]


def written(part: object) -> None:
    """The part named in `will_write` is complete."""
    if str(part) in _unwritten:
        _unwritten.remove(str(part))


def unwritten() -> list[str]:
    """The parts named in `will_write` and not yet written."""
    return list(_unwritten)


@contextmanager
def deferred() -> Iterator[None]:
    """A critical section: a signal inside it is recorded and raised when it ends (in serial;
    under mpiexec at the next `checkpoint` or `check`, or on rank 0 alone if GRACE passed)."""
    global _depth
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
    if _depth == 0 and _pending and (not _parallel or _late):
        raise _take()


def drawing(draw: Callable) -> Callable:
    """Decorator for code that draws figures on rank 0 inside an action of
    `output.collective` (or in serial): it runs in a critical section, and a signal that
    came meanwhile is raised when it is done (`check`), before its files move into place."""

    @functools.wraps(draw)
    def drawn(*args, **kwargs):
        try:
            with deferred():
                result = draw(*args, **kwargs)
        except (KeyboardInterrupt, Terminated) as late:  # GRACE passed while drawing
            if _parallel:  # raised as Interrupted, so that every rank raises it
                raise Interrupted(signal_of(late)) from None
            raise
        check()
        return result

    return drawn


def signal_behind(exc: BaseException) -> BaseException | None:
    """The signal's exception behind a library's error, None if none: petsc4py turns an
    exception raised in a Python callback of PETSc (SNES's residual and Jacobian, a KSP
    monitor) into PETSc.Error 101, and SLEPc's EPS.solve into SystemError, each with the
    exception as its cause (`raise ... from`), which is followed here."""
    seen: set[int] = set()
    cause = exc.__cause__
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, (KeyboardInterrupt, Terminated, Interrupted)):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__
    return None


@contextmanager
def calling_back() -> Iterator[None]:
    """Around a solve that calls back into Python (PETSc's SNES and KSP, SLEPc's EPS): a
    signal raised inside a callback reaches the caller as the library's error, which the
    caller would take for a failed solve (a divergence, a load step halved, a static solve
    not reported) or print as a traceback; it is raised here as the signal itself. So is a
    signal raised inside and lost there (swallowed by the library, or turned into an error
    that does not name it as its cause): once control is back in Python, at the end of the
    block, whether it ends with an error or not."""
    try:
        yield
    except Exception as err:
        signalled = signal_behind(err)
        if signalled is not None:
            signum = signal_of(signalled)
            if isinstance(signalled, Interrupted):
                fresh: BaseException = Interrupted(signum)
            else:
                fresh = exception(signum)
        elif _raised:  # raised in a callback, lost, and this error came after it
            fresh = exception(_raised)
        else:
            raise
    else:
        if _lost():  # raised in a callback and swallowed: the solve went on to its end
            raise exception(_raised)
        return
    raise fresh  # out of the `except`: the library's error and its frames go now


def guard_jit() -> None:
    """Compile forms in a critical section (see the module docstring): wraps DOLFINx's JIT
    entry point, which dolfinx.fem looks up at every call. Idempotent."""
    import dolfinx.jit

    compile_forms = dolfinx.jit.ffcx_jit
    if getattr(compile_forms, "deferred", False):
        return

    def guarded(*args, **kwargs):
        with deferred():
            return compile_forms(*args, **kwargs)

    setattr(guarded, "deferred", True)  # a function attribute, which mypy does not model
    dolfinx.jit.ffcx_jit = guarded


def guard_solves() -> None:
    """Solve DOLFINx's nonlinear problems (the truth's Newton, solvers/truth/solver.py) inside
    `calling_back`, so that a signal in their residual is raised as the signal, not as a failed
    solve: wraps NonlinearProblem.solve, as guard_jit wraps the JIT (the truth's code, which
    its cache key hashes, stays as it is). Idempotent."""
    import dolfinx.fem.petsc

    solve = dolfinx.fem.petsc.NonlinearProblem.solve
    if getattr(solve, "calling_back", False):
        return

    @functools.wraps(solve)
    def guarded(self, *args, **kwargs):
        with calling_back():
            return solve(self, *args, **kwargs)

    setattr(guarded, "calling_back", True)  # a function attribute, which mypy does not model
    dolfinx.fem.petsc.NonlinearProblem.solve = guarded  # type: ignore[method-assign]


def run_worker(work: Callable[[], None], name: str) -> NoReturn:
    """Run a worker process's work (a split truth's unit, solvers/truth/worker.py) on one rank
    and end the process: 0 when done; on SIGINT or SIGTERM at any moment (in a PETSc
    callback, swallowed there, or as the work ends) 130 or 143 with one line on stderr,
    `name: interrupted (SIGINT)`, never 0. Its parent stops it with SIGTERM (`stop_children`)
    and says its own line."""
    global _depth
    from mpi4py import MPI

    install(MPI.COMM_SELF)  # kept to the end: the handlers before may be PETSc's, not Python's
    signum = 0
    try:
        with deferred():
            guard_jit()
            guard_solves()
        with calling_back():
            work()
        checkpoint(MPI.COMM_SELF)  # one raised and lost, or recorded
    except KeyboardInterrupt:
        _depth += 1  # from here on a signal is only recorded (`_handle`), and read below
        signum = signal.SIGINT
    except Terminated:
        _depth += 1
        signum = signal.SIGTERM
    else:
        _depth += 1
    sys.stdout.flush()
    signum = signum or _pending or _raised
    if signum:
        print(f"{name}: {SAID[signum]}", file=sys.stderr)
    sys.stderr.flush()
    os._exit(STATUS[signum] if signum else 0)


def run_child(command: list[str], timeout: float, **options) -> subprocess.CompletedProcess | None:
    """Run a child process as subprocess.run(command, capture_output=True, text=True, ...)
    does, but stop it (SIGTERM, then SIGKILL after 5 s) as soon as a signal comes or
    `timeout` s pass. Returns None when the timeout stopped it. Under mpiexec the signal is
    left pending for the caller's next `checkpoint`; in serial it is raised."""
    child = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **options
    )
    end = time.monotonic() + timeout
    try:
        while True:
            try:
                out, err = child.communicate(timeout=0.1)
                return subprocess.CompletedProcess(command, child.returncode, out, err)
            except subprocess.TimeoutExpired:
                pass
            if _pending:
                _stop(child)
                out, err = child.communicate()
                return subprocess.CompletedProcess(command, child.returncode, out, err)
            if time.monotonic() > end:
                _stop(child)
                child.communicate()
                return None
    finally:
        if child.poll() is None:  # a signal raised while waiting (serial)
            _stop(child)


def _stop(child: subprocess.Popen) -> None:
    stop_children([child], seconds=5.0)


def stop_children(children: list[subprocess.Popen], seconds: float = 10.0) -> None:
    """End child processes: SIGTERM to each, then SIGKILL to those still running `seconds` s
    later; a signal meanwhile waits until they have ended (`deferred`), so none is left
    behind."""
    with deferred():
        for child in children:
            child.terminate()
        end = time.monotonic() + seconds
        for child in children:
            try:
                child.wait(timeout=max(end - time.monotonic(), 0.0))
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
