"""Displacement histories of the nonlinear elastic models (SPEC section 8) with a few
algorithms each, on the large-load cases, in an order fixed by node coordinates, printed as
JSON by rank 0 (run in serial and under mpiexec by test_models.py)."""

import json

from mpi4py import MPI

import numpy as np

from tissuebench.meshes import get_benchmark
from tissuebench.solvers import get_integrator
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.system import System, gather_by_coordinates

# every model with an implicit (Newton) and an explicit scheme, and each of the other three
# algorithms once
CASES = {
    "svk": ("implicit", "explicit-lumped", "implicit-lumped"),
    "neo-hookean": ("implicit", "explicit-lumped", "quasi-static"),
    "neo-hookean-barrier": ("implicit", "explicit"),
    "corotational": ("implicit", "explicit-lumped", "explicit"),
}
N_STEPS = 20

out = {}
# SPEC 8's large cases: block MP1 at s = 2 with a 0.2 m needle, rod MP3 at s = 3
for name, size, options in [
    ("block", 8, {"load_scale": 2.0, "needle_width": 0.2}),
    ("rod", 2, {"load_scale": 3.0}),
]:
    bench = get_benchmark(name, mesh_size=size, **options)
    system = System(bench)
    for model, algorithms in CASES.items():
        for algorithm in algorithms:
            integrator = get_integrator(algorithm, system, bench.dt, model=model)
            run = simulate(integrator, N_STEPS, bench.extent, algorithm)
            integrator.destroy()
            key = f"{name}-{algorithm}+{model}"
            history = [gather_by_coordinates(system.V, u) for u in run.u[::5]]
            if MPI.COMM_WORLD.rank == 0:
                out[key] = np.array([values for _, values in history]).tolist()
                out[key + "-status"] = [run.status, run.diverged_step]
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
