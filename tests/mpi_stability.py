"""Run by tests/test_stability.py, serially and under mpiexec -n 2: print (rank 0) one JSON line
with the extreme frequencies and critical steps of block N = 8 (MP2) and rod n = 2 (MP3), and the
errors of a small space-convergence study (interpolation between meshes, metrics)."""

import json

from mpi4py import MPI

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.stability import stability_limits
from tissuebench.solvers.system import System
from tissuebench.workflows.study.convergence import space_study


def main():
    comm = MPI.COMM_WORLD
    result = {}
    for bench, size, material in [("block", 8, "MP2"), ("rod", 2, "MP3")]:
        system = System(get_benchmark(bench, mesh_size=size, comm=comm), material)
        limits = stability_limits(system, ("explicit", "explicit-lumped"))
        result[bench] = {
            name: [lim.omega_min, lim.omega_max, lim.critical_dt] for name, lim in limits.items()
        }
    space = space_study(
        "block", "MP1", (4, 8), problems=("quasi-static",), comm=comm, needle_width=0.5
    )
    result["space"] = space["quasi-static"]["errors"][0]
    if comm.rank == 0:
        print(json.dumps(result))


if __name__ == "__main__":
    main()
