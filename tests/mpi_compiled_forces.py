"""f_int and the smallest det F of the compiled element loop (solvers/compiled_forces.py) for
every nonlinear model and F-bar, on the rod and the block under a large deformation given by
the node coordinates, in an order fixed by node coordinates, printed as JSON by rank 0 (run in
serial and under mpiexec by test_compiled_forces.py)."""

import json

from mpi4py import MPI

import numpy as np

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.elastic import ElasticForces
from tissuebench.solvers.models import MODELS
from tissuebench.solvers.system import System, gather_by_coordinates

CASES = [
    ("svk", "standard"),
    ("neo-hookean", "standard"),
    ("neo-hookean-barrier", "standard"),
    ("corotational", "standard"),
    ("neo-hookean", "mean-dilatation"),
]

out = {}
for name, size in [("block", 8), ("rod", 3)]:
    bench = get_benchmark(name, mesh_size=size)
    for model, scheme in CASES:
        system = System(bench, scheme=scheme)
        gdim = system.gdim
        n = system.V.dofmap.index_map.size_local
        X = system.V.tabulate_dof_coordinates()[:n, :gdim]
        c, s = np.cos(0.5), np.sin(0.5)
        Q = np.eye(gdim)
        Q[:2, :2] = [[c, -s], [s, c]]
        u = X @ (Q @ np.diag([1.2, 0.9, 1.1][:gdim]) - np.eye(gdim)).T
        u += 0.01 * np.sin(X @ np.array([41.0, 23.0, 37.0])[:gdim])[:, None]
        forces = ElasticForces(system, MODELS[model], compiled=True)
        x = system.K.createVecLeft()
        x.array[:] = u.ravel()
        f = x.duplicate()
        forces.internal_force(x, f)
        det = forces.min_det()
        gathered = gather_by_coordinates(system.V, f.array_r)
        if MPI.COMM_WORLD.rank == 0:
            out[f"{name}-{model}-{scheme}"] = gathered[1].ravel().tolist()
            out[f"{name}-{model}-{scheme}-min-det"] = [det]
        forces.destroy()
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
