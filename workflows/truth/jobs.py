"""`tissuebench truth all --jobs N`: the truths not yet cached, computed N at a time.

Each case runs in a worker process of its own (`tissuebench truth CASE --compute-only`, one
rank, one BLAS/OpenMP thread), longest first, so that two cases share a 2-core machine
instead of one leaving a core idle. A linear case (solvers/truth/split.py) takes every
process free when it starts and runs its own levels and steps side by side on them (its worker
starts one process per run, --jobs at a time), so that its longest run, not the case, sets
its wall time. Beside other busy processes (`beside`: the paper's own, running its cases), the
workers share the cores with them: every estimate, the workers' own included (their
TISSUEBENCH_SLOWDOWN, core/speed.py), is then longer by (jobs + beside) / jobs. A worker caches
its case as `tissuebench truth CASE`
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
from tissuebench.core.speed import slowdown
from tissuebench.solvers.truth.split import THREAD_VARS, splittable
from tissuebench.solvers.truth.store import expected_seconds, expected_wall

POLL_SECONDS = 0.5


@dataclass
class Job:
    """One case's worker process and when it started (time.time())."""

    case: str
    process: subprocess.Popen
    slots: int = 1  # the processes it runs at once (a linear case's runs side by side)
    started: float = field(default_factory=time.time)
    reader: threading.Thread | None = None
    stopped: bool = False  # stopped by a signal: its last lines (its own end) are not said


def worker_command(case: str, quick: bool, slots: int = 1) -> list[str]:
    """The command line of one case's worker, its runs `slots` at a time."""
    command = [sys.executable, "-m", "tissuebench.workflows.cli", "truth", case]
    return command + ["--compute-only", "--jobs", str(slots)] + (["--quick"] if quick else [])


def slots_for(case: str, quick: bool, free: int) -> int:
    """The processes a case takes of the `free` ones: all of them for a case whose runs go side
    by side (solvers/truth/split.py), else one."""
    return free if splittable(case, quick) else 1


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


def sharing(jobs: int, beside: int) -> float:
    """How much longer everything takes on `jobs` worker processes, one a core, when `beside`
    other busy processes share those cores: (jobs + beside) / jobs."""
    return (jobs + beside) / jobs


def left_seconds(
    pending: list[str], running: list[Job], quick: bool, jobs: int, beside: int = 0
) -> float:
    """About how long the cases pending and running still take on `jobs` processes beside
    `beside` other busy ones, s: the order compute_in_parallel takes them in, played out with
    each case's expected wall time (store.expected_wall: a linear case's runs side by side on
    the processes it takes) times sharing(jobs, beside)."""
    now, factor = time.time(), sharing(jobs, beside)
    busy = [
        (max(factor * expected_wall(j.case, quick, j.slots) - (now - j.started), 0.0), j.slots)
        for j in running
    ]
    t = 0.0
    for case in pending:
        while sum(slots for _, slots in busy) >= jobs:  # until the first to end frees its own
            busy.sort()
            t = max(t, busy.pop(0)[0])
        slots = slots_for(case, quick, jobs - sum(n for _, n in busy))
        busy.append((t + factor * expected_wall(case, quick, slots), slots))
    return max((end for end, _ in busy), default=0.0)


class TruthJobs:
    """The workers of `cases`, `jobs` processes at a time (longest first), driven from outside:
    start() says the plan and starts the first; poll() starts and reaps workers (call it often,
    as between a paper's cases); wait() polls until every worker has ended and returns the cases
    whose worker failed (each said in one line with its exit code); stop() ends those still
    running (a signal stopped the parent). `beside`: the busy processes beside the workers (the
    paper's own), which the estimates count (sharing)."""

    def __init__(
        self, cases: list[str], quick: bool, jobs: int, say: Callable[[str], None], beside: int = 0
    ):
        self.pending = sorted(cases, key=lambda c: -expected_seconds(c, quick))
        self.quick, self.jobs, self.say, self.beside = quick, jobs, say, beside
        self.env = {
            **os.environ,
            "TISSUEBENCH_PROGRESS_BARS": "0",
            **dict.fromkeys(THREAD_VARS, "1"),
            # the workers' own estimates: this machine's speed as measured here, shared
            "TISSUEBENCH_SLOWDOWN": repr(slowdown() * sharing(jobs, beside)),
        }
        self.total = len(self.pending)
        self.running: list[Job] = []
        self.failed: list[str] = []
        self.succeeded: list[str] = []  # in the order their workers ended
        self.done = 0
        self.started = time.time()

    def start(self) -> None:
        left = left_seconds(self.pending, [], self.quick, self.jobs, self.beside)
        self.say(
            f"truth: computing {self.total} cases, {self.jobs} processes at a time, longest "
            f"first (about {left / 60:.0f} min here): {', '.join(self.pending)}"
        )
        self.started = time.time()
        self.poll()

    def _launch(self) -> None:
        while self.pending and sum(j.slots for j in self.running) < self.jobs:
            case = self.pending.pop(0)
            slots = slots_for(case, self.quick, self.jobs - sum(j.slots for j in self.running))
            process = subprocess.Popen(
                worker_command(case, self.quick, slots),
                stdout=subprocess.PIPE,
                stderr=subprocess.STDOUT,
                text=True,
                env=self.env,
            )
            job = Job(case, process, slots)
            job.reader = threading.Thread(target=_forward, args=(job, self.say), daemon=True)
            job.reader.start()
            self.running.append(job)
            runs = f", its runs {slots} at a time" if slots > 1 else ""
            about = sharing(self.jobs, self.beside) * expected_wall(case, self.quick, slots)
            self.say(f"truth: started {case} (about {about:.0f} s{runs})")

    def poll(self) -> bool:
        """Reap the workers that ended and start the next; whether any is left."""
        for job in list(self.running):
            ended = ended_with_cpu(job.process)
            if ended is None:
                continue
            code, cpu = ended
            self.running.remove(job)
            if job.reader is not None:
                job.reader.join()
            self.done += 1
            (self.failed if code != 0 else self.succeeded).append(job.case)
            left = left_seconds(self.pending, self.running, self.quick, self.jobs, self.beside)
            self.say(
                f"truth: {job.case} {'done' if code == 0 else f'FAILED (exit {code})'} in "
                f"{time.time() - job.started:.0f} s ({cpu:.0f} s of CPU; {self.done} of "
                f"{self.total}, {time.time() - self.started:.0f} s in all; "
                f"about {left / 60:.0f} min left)"
            )
        self._launch()
        return bool(self.pending or self.running)

    def wait(self) -> list[str]:
        while self.poll():
            time.sleep(POLL_SECONDS)
            interrupt.checkpoint(MPI.COMM_SELF)
        return self.failed

    def stop(self) -> None:
        stop(self.running)
        self.running = []


def compute_in_parallel(
    cases: list[str], quick: bool, jobs: int, say: Callable[[str], None]
) -> list[str]:
    """Compute and cache `cases`, `jobs` processes at a time (longest first); returns the cases
    whose worker failed (each said in one line with its exit code)."""
    work = TruthJobs(cases, quick, jobs, say)
    try:
        work.start()
        return work.wait()
    finally:
        work.stop()


def stop(running: list[Job]) -> None:
    """Stop the workers still running (a signal stopped the parent): SIGTERM, then SIGKILL
    (interrupt.stop_children); each ends as a command ends on SIGTERM (its partial output and
    its lock removed, one line, which is not said here: the parent says its own)."""
    for job in running:
        job.stopped = True
    interrupt.stop_children([job.process for job in running])
    for job in running:
        if job.reader is not None:
            job.reader.join(timeout=1.0)
