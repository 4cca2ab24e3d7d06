"""Norms of K, M, M_L and f for both benchmarks, printed as JSON by rank 0 (run in serial and
under mpiexec by test_system.py)."""

import json

from mpi4py import MPI

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.system import System

out = {}
for name, size, material in [("block", 8, "MP1"), ("block", 8, "MP2"), ("rod", 2, "MP3")]:
    s = System(get_benchmark(name, mesh_size=size), material)
    key = f"{name}-{material}"
    out[key + "-K"] = s.K.norm()
    out[key + "-M"] = s.M.norm()
    out[key + "-ML"] = s.ML.norm()
    out[key + "-f"] = s.f.norm()
    out[key + "-constrained"] = MPI.COMM_WORLD.allreduce(len(s.constrained))
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
