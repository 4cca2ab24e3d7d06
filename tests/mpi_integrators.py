"""Displacement histories of the five integrators (and of the iterative solvers), in an order
fixed by node coordinates, printed as JSON by rank 0 (run in serial and under mpiexec by
test_integrators.py)."""

import json

from mpi4py import MPI

import numpy as np

from tissuebench.meshes import get_benchmark
from tissuebench.solvers import ALGORITHMS, get_integrator
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System, gather_by_coordinates

out = {}
for name, size, material in [("block", 8, "MP1"), ("block", 8, "MP2"), ("rod", 2, "MP3")]:
    bench = get_benchmark(name, mesh_size=size)
    system = System(bench, material)
    # the five algorithms with the direct solver; the iterative solvers (their preconditioners
    # differ with the partition: block Jacobi ICC, GAMG's aggregates) on the reference
    cases = [(algorithm, "direct") for algorithm in ALGORITHMS] + [
        ("implicit", "cg"),
        ("implicit", "gamg"),
    ]
    for algorithm, solver in cases:
        run = simulate(
            get_integrator(algorithm, system, bench.dt, solver=solver), 60, bench.extent, algorithm
        )
        key = f"{name}-{material}-{algorithm}" + ("" if solver == "direct" else f"-{solver}")
        history = [gather_by_coordinates(system.V, u) for u in run.u[::10]]
        if MPI.COMM_WORLD.rank == 0:
            out[key] = np.array([values for _, values in history]).tolist()
            out[key + "-status"] = [run.status, run.diverged_step]
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
