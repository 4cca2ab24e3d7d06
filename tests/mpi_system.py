"""Norms of K, M, M_L and f for both benchmarks, and the relative difference between the
compiled block-CSR products (solvers/blockcsr.py) and PETSc's MatMult, printed as JSON by
rank 0 (run in serial and under mpiexec by test_system.py)."""

import json

from mpi4py import MPI

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.system import System

out, kernel = {}, {}
for name, size, material in [("block", 8, "MP1"), ("block", 8, "MP2"), ("rod", 2, "MP3")]:
    s = System(get_benchmark(name, mesh_size=size), material)
    key = f"{name}-{material}"
    out[key + "-K"] = s.K.norm()
    out[key + "-M"] = s.M.norm()
    out[key + "-ML"] = s.ML.norm()
    out[key + "-f"] = s.f.norm()
    out[key + "-constrained"] = MPI.COMM_WORLD.allreduce(len(s.constrained))
    x = s.K.createVecRight()
    x.setRandom()
    for A, csr in (("K", s.K_csr), ("M", s.M_csr)):
        y, y_petsc = s.K.createVecLeft(), s.K.createVecLeft()
        getattr(s, A).mult(x, y_petsc)
        csr.mult(x, y)  # y = A x
        csr.mult(x, y, add=True)  # y = 2 A x
        y.axpy(-2.0, y_petsc)
        kernel[f"{key}-{A}"] = y.norm() / y_petsc.norm()
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps({"norms": out, "kernel": kernel}))
