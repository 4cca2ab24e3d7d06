"""Samples of the truth (solvers/truth/store.py sample()) printed as JSON by rank 0, run in
serial and under mpiexec by test_truth_store.py: a known quadratic field interpolated into a
Q2 space on a small box, and two tiny truth runs (the rod, n = 1; the block with MP2, Taylor-
Hood, N = 10), a few steps each."""

import json

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
from dolfinx import fem

from tissuebench.solvers.truth import case_truth
from tissuebench.solvers.truth.solver import TruthRun
from tissuebench.solvers.truth.store import sample


def field(x):
    """A quadratic displacement (m) in Q2: exact after interpolation."""
    return np.stack([x[0] * x[1] + 0.5, x[0] ** 2 - x[2], x[1] * x[2] - 0.25 * x[0]])


def arrays(s):
    names = ("vertices", "cells", "boundary", "points", "weights", "u_vertices", "u_points")
    return {name: getattr(s, name).tolist() for name in names}


out = {}
mesh = dolfinx.mesh.create_box(
    MPI.COMM_WORLD, [[0, 0, 0], [1.0, 0.5, 0.25]], [3, 2, 2], dolfinx.mesh.CellType.hexahedron
)
V = fem.functionspace(mesh, ("Lagrange", 2, (3,)))
u = fem.Function(V)
u.interpolate(field)
n = V.dofmap.index_map.size_local * 3
run = TruthRun(V, np.array([0.0, 1.0]), np.array([u.x.array[:n], 2 * u.x.array[:n]]), None, 0, 0)
s = sample(None, run)
if s is not None:
    out["field"] = arrays(s)
for case, size, steps in [("rod", 1, 4), ("block-MP2-w0.2", 10, 3)]:
    truth, bench = case_truth(case, size)
    s = sample(truth, truth.run(bench.dt, steps))
    if s is not None:
        out[case] = arrays(s)
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
