"""The paper's part 2 (the large-deformation cases) shared with a worker process beside the
paper's own, when every truth is cached: on two cores the warm study then takes about half the
sum of its parts (each case is one core's work, most of it E_s's booleans).

The worker is `tissuebench paper --out OUT --cases NAME ... --folders-only --claims DIR`: it
takes part 2's cases from the first on, the paper (after its part 1 and the truth's) from the
last on, each case run by whichever claims it first (`claim`: a file created in DIR, which
only one process can create); the worker writes no report, and the paper reads the worker's
folders as they are (summary.json). The worker's lines are said here as they come; its
progress bars are off (TISSUEBENCH_PROGRESS_BARS=0). A worker that fails is said in one line
with its exit code and its last line; the paper then runs what it left itself, so that its
error, if it is one of the inputs', comes out there as it would alone.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import threading
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.solvers.truth.split import THREAD_VARS

POLL_SECONDS = 0.2  # s, between looks at the worker while waiting for it


def claim(claims: Path, name: str) -> bool:
    """Whether this process is the first to claim case `name` in the folder `claims`."""
    try:
        os.close(os.open(claims / name, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
    except FileExistsError:
        return False
    return True


def worker_command(
    out: Path, names: list[str], solver: str, petsc: str, force: bool, claims: Path
) -> list[str]:
    """The worker's command line: the named cases of `tissuebench paper` into OUT, those it
    claims first in `claims`, no report."""
    command = [sys.executable, "-m", "tissuebench.workflows.cli", "paper", "--out", str(out)]
    command += ["--solver", solver, "--cases", *names, "--folders-only", "--claims", str(claims)]
    return command + (["--petsc", petsc] if petsc else []) + (["--force"] if force else [])


class CasesWorker:
    """One worker process running those of `names` into OUT that it claims first (in
    self.claims, a temporary folder); `say` gets each of its lines."""

    def __init__(
        self,
        out: Path,
        names: list[str],
        solver: str,
        petsc: str,
        force: bool,
        say: Callable[[str], None],
    ):
        self.names, self.say = names, say
        env = {
            **os.environ,
            "TISSUEBENCH_PROGRESS_BARS": "0",
            "PYTHONUNBUFFERED": "1",
            **dict.fromkeys(THREAD_VARS, "1"),
        }
        self.errors = tempfile.TemporaryFile("w+")  # its error lines, said if it fails
        self.claims = Path(tempfile.mkdtemp(prefix="tissuebench-claims-"))
        self.process = subprocess.Popen(
            worker_command(out, names, solver, petsc, force, self.claims),
            stdout=subprocess.PIPE,
            stderr=self.errors,
            text=True,
            env=env,
        )
        self.stopped = False
        self.reader = threading.Thread(target=self._forward, daemon=True)
        self.reader.start()
        say(f"paper: {', '.join(names)} shared with a second process beside this one")

    def _forward(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            if line.strip() and not self.stopped:
                self.say(line.rstrip())

    def wait(self) -> bool:
        """Wait for the worker (a signal meanwhile stops both); whether it ended well."""
        while self.process.poll() is None:
            try:
                self.process.wait(timeout=POLL_SECONDS)
            except subprocess.TimeoutExpired:
                pass
            interrupt.checkpoint(MPI.COMM_SELF)
        self.reader.join()
        code = self.process.returncode
        if code != 0:
            self.errors.seek(0)
            last = [line.strip() for line in self.errors if line.strip()][-1:]
            self.say(
                f"paper: the second process ended with exit {code}"
                + (f" ({last[0]})" if last else "")
                + f"; running what it left of {', '.join(self.names)} here"
            )
        self.errors.close()
        return code == 0

    def stop(self) -> None:
        """End the worker if it still runs (a signal stopped the paper): its partial folders
        are removed as any command's are on SIGTERM. The claims go in any case."""
        if self.process.poll() is None:
            self.stopped = True
            interrupt.stop_children([self.process])
        self.reader.join(timeout=1.0)
        shutil.rmtree(self.claims, ignore_errors=True)
