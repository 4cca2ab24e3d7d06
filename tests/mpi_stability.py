"""Run by tests/test_stability.py, serially and under mpiexec -n 2: print (rank 0) one JSON line
with the extreme frequencies and critical steps of block N = 8 (MP2) and rod n = 2 (MP3), and the
errors of a small space-convergence study (interpolation between meshes, metrics)."""

import json
import os
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.stability import stability_limits
from tissuebench.solvers.system import System
from tissuebench.workflows.convergence import space_study


def main():
    comm = MPI.COMM_WORLD
    result = {}
    for bench, size, material in [("block", 8, "MP2"), ("rod", 2, "MP3")]:
        system = System(get_benchmark(bench, mesh_size=size, comm=comm), material)
        limits = stability_limits(system, ("explicit", "explicit-lumped"))
        result[bench] = {name: [lim.omega_min, lim.omega_max, lim.critical_dt] for name, lim in limits.items()}
    space = space_study("block", "MP1", (4, 8), problems=("quasi-static",), comm=comm, needle_width=0.5)
    result["space"] = space["quasi-static"]["errors"][0]
    if comm.rank == 0:
        print(json.dumps(result))


def run(ranks=None):
    """Run this script in a fresh process (under mpiexec -n ranks if given; mpiexec is looked
    for next to the Python executable) and return the JSON it prints."""
    import pytest

    python = Path(sys.executable)
    command = [str(python), __file__]
    if ranks:
        mpiexec = python.parent / "mpiexec"
        if not mpiexec.exists():
            pytest.skip(f"no mpiexec next to {python}")
        command = [str(mpiexec), "-n", str(ranks), *command]
    # A fresh MPI job: drop the launcher variables of the calling (singleton MPI) process.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMI_", "PMIX_", "OMPI_", "HYDRA_", "MPIR_"))}
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


if __name__ == "__main__":
    main()
