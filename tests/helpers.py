"""Shared helpers for the tests: running a script in serial or under mpiexec."""

import json
import os
import subprocess
import sys
from pathlib import Path


HERE = Path(__file__).parent


def mpiexec():
    """The mpiexec beside this Python (the venv's MPICH), else the one on PATH."""
    local = Path(sys.executable).parent / "mpiexec"
    return str(local) if local.exists() else "mpiexec"


def run_script(script, *args, ranks=1, timeout=600):
    """Run tests/<script> with `ranks` MPI processes; return the JSON it prints last."""
    cmd = [sys.executable, str(HERE / script), *map(str, args)]
    if ranks > 1:
        cmd = [mpiexec(), "-n", str(ranks), *cmd]
    # a fresh MPI job: drop the launcher variables of the calling (singleton MPI) process
    env = {
        k: v
        for k, v in os.environ.items()
        if not k.startswith(("PMI_", "PMIX_", "OMPI_", "HYDRA_", "MPIR_"))
    }
    env["OMP_NUM_THREADS"] = "1"
    out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])
