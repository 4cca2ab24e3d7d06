"""Shared helpers for the tests: running a script in serial or under mpiexec."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent


def needs_ccx(test):
    """A test that runs CalculiX (ccx), an outside simulator: marked `outside` (make test leaves
    it to make external-tests, which runs it once make external-tools has installed ccx) and
    skipped where ccx is not on PATH."""
    missing = shutil.which("ccx") is None
    skip = pytest.mark.skipif(missing, reason="CalculiX (ccx) is not on PATH")
    return pytest.mark.outside(skip(test))


def mpiexec():
    """The mpiexec beside this Python (the venv's MPICH), else the one on PATH."""
    local = Path(sys.executable).parent / "mpiexec"
    return str(local) if local.exists() else "mpiexec"


def job(argv: list, ranks: int = 1) -> tuple[list[str], dict]:
    """The command line and environment of a fresh job running `python argv...` with `ranks`
    MPI processes: the launcher variables of the calling (singleton MPI) process dropped."""
    cmd = [sys.executable, *map(str, argv)]
    if ranks > 1:
        cmd = [mpiexec(), "-n", str(ranks), *cmd]
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("PMI_", "PMIX_", "OMPI_", "HYDRA_", "MPIR_"))
    }
    env["OMP_NUM_THREADS"] = "1"
    return cmd, env


def tissuebench(
    *args, ranks: int = 1, timeout: int = 600, cwd: Path | None = None
) -> subprocess.CompletedProcess:
    """`tissuebench args...` in a fresh job (under mpiexec with `ranks` > 1), in folder `cwd`
    (default: this process's)."""
    cmd, env = job(["-m", "tissuebench.workflows.cli", *args], ranks)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=cwd)


def run_script(script, *args, ranks=1, timeout=600):
    """Run tests/<script> with `ranks` MPI processes; return the JSON it prints last."""
    cmd, env = job([HERE / script, *args], ranks)
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])
