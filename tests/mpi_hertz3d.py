"""SPEC 13's Hertz push on the meridian (solvers/truth/hertz3d.py) on a coarse level: P, p0, a
and the pressure profile of each penalty, printed as JSON by rank 0 (run in serial and under
mpiexec by test_hertz3d.py)."""

import json

from mpi4py import MPI

from tissuebench.solvers.truth.hertz3d import push

out = [
    {"P": p.P, "p0": p.p0, "a": p.a, "rho": p.rho.tolist(), "p": p.p.tolist(), "dofs": p.dofs}
    for p in push(200.0, 0.47, 16)
]
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
