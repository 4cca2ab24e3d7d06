"""`tissuebench truth all --jobs N`: the truths not yet cached, computed N at a time.

Each case runs in a worker process of its own (`tissuebench truth CASE --compute-only`, one
rank, one BLAS/OpenMP thread), longest first, so that two cases share a 2-core machine
instead of one leaving a core idle. A worker caches its case as `tissuebench truth CASE`
does (under the case's lock: any other command that needs the case waits for it and says
so); this module only starts them, forwards their lines prefixed with the case, and says
each one's end with an estimate of what is left. Times in seconds.
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.solvers.truth.store import expected_seconds

THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
POLL_SECONDS = 0.5
STOP_SECONDS = 10.0  # s: how long a worker may take to end on SIGTERM before it is killed


@dataclass
class Job:
    """One case's worker process and when it started (time.time())."""

    case: str
    process: subprocess.Popen
    started: float = field(default_factory=time.time)
    reader: threading.Thread | None = None
    stopped: bool = False  # stopped by a signal: its last lines (its own end) are not said


def worker_command(case: str, quick: bool) -> list[str]:
    """The command line of one case's worker."""
    command = [sys.executable, "-m", "tissuebench.workflows.cli", "truth", case]
    return command + ["--compute-only"] + (["--quick"] if quick else [])


def _forward(job: Job, say: Callable[[str], None]) -> None:
    """Print the worker's lines, each prefixed with its case."""
    assert job.process.stdout is not None
    for line in job.process.stdout:
        line = line.rstrip()
        if line and not job.stopped:
            say(f"  [{job.case}] {line}")


def ended_with_cpu(process: subprocess.Popen) -> tuple[int, float] | None:
    """(exit code, CPU seconds used) of a worker that has ended (reaped here), else None. The
    CPU time says what its wall time would be on a core of its own: the machine may be shared."""
    pid, status, usage = os.wait4(process.pid, os.WNOHANG)
    if pid == 0:
        return None
    process.returncode = os.waitstatus_to_exitcode(status)
    return process.returncode, usage.ru_utime + usage.ru_stime


def left_seconds(pending: list[str], running: list[Job], quick: bool, jobs: int) -> float:
    """About how long the cases pending and running still take, spread over `jobs` workers: at
    least the longest of them, which one worker computes alone."""
    now = time.time()
    running_left = [max(expected_seconds(j.case, quick) - (now - j.started), 0.0) for j in running]
    each = [expected_seconds(c, quick) for c in pending] + running_left
    return max(sum(each) / jobs, max(each, default=0.0))


def compute_in_parallel(
    cases: list[str], quick: bool, jobs: int, say: Callable[[str], None]
) -> list[str]:
    """Compute and cache `cases`, `jobs` at a time (longest first); returns the cases whose
    worker failed (each said in one line with its exit code)."""
    pending = sorted(cases, key=lambda c: -expected_seconds(c, quick))
    env = {**os.environ, "TISSUEBENCH_PROGRESS_BARS": "0", **dict.fromkeys(THREAD_VARS, "1")}
    start = time.time()
    total = len(pending)
    say(
        f"truth: computing {total} cases, {jobs} at a time, longest first "
        f"(about {left_seconds(pending, [], quick, jobs) / 60:.0f} min here): {', '.join(pending)}"
    )
    running: list[Job] = []
    failed: list[str] = []
    done = 0
    try:
        while pending or running:
            while pending and len(running) < jobs:
                case = pending.pop(0)
                process = subprocess.Popen(
                    worker_command(case, quick),
                    stdout=subprocess.PIPE,
                    stderr=subprocess.STDOUT,
                    text=True,
                    env=env,
                )
                job = Job(case, process)
                job.reader = threading.Thread(target=_forward, args=(job, say), daemon=True)
                job.reader.start()
                running.append(job)
                say(f"truth: started {case} (about {expected_seconds(case, quick):.0f} s)")
            time.sleep(POLL_SECONDS)
            interrupt.checkpoint(MPI.COMM_SELF)
            for job in list(running):
                ended = ended_with_cpu(job.process)
                if ended is None:
                    continue
                code, cpu = ended
                running.remove(job)
                if job.reader is not None:
                    job.reader.join()
                done += 1
                if code != 0:
                    failed.append(job.case)
                took = time.time() - job.started
                say(
                    f"truth: {job.case} {'done' if code == 0 else f'FAILED (exit {code})'} in "
                    f"{took:.0f} s ({cpu:.0f} s of CPU; {done} of {total}, "
                    f"{time.time() - start:.0f} s in all; "
                    f"about {left_seconds(pending, running, quick, jobs) / 60:.0f} min left)"
                )
    finally:
        stop(running)
    return failed


def stop(running: list[Job]) -> None:
    """Stop the workers still running (a signal stopped the parent): SIGTERM, then SIGKILL
    after STOP_SECONDS; each ends as a command ends on SIGTERM (its partial output and its lock
    removed, one line, which is not said here: the parent says its own)."""
    with interrupt.deferred():  # a second signal meanwhile leaves no worker behind
        for job in running:
            job.stopped = True
            job.process.terminate()
        end = time.monotonic() + STOP_SECONDS
        for job in running:
            try:
                job.process.wait(timeout=max(end - time.monotonic(), 0.0))
            except subprocess.TimeoutExpired:
                job.process.kill()
                job.process.wait()
    for job in running:
        if job.reader is not None:
            job.reader.join(timeout=1.0)
