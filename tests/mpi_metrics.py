"""Run by tests/test_metrics.py and tests/test_compare.py, serially and under mpiexec: print
(rank 0) one JSON line with the metrics of fixed deformations on block_mesh(8) and
rod_mesh(2) and their histories over five steps (histories() shares E_s out between the
ranks by step), or, given REFERENCE CANDIDATE OUT_DIR, the metrics.csv that compare() writes."""

import json
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from tissuebench.meshes.block import block_mesh
from tissuebench.meshes.rod import rod_mesh
from tissuebench.metrics import Metrics
from tissuebench.workflows.compare.grading import compare


def reference(x):
    return np.array([0.05 * x[1] * np.sin(np.pi * x[0]), -0.03 * x[0] ** 2, 0.02 * x[0] * x[2]])


def candidate(x):
    return reference(x) * (1 + 0.2 * x[1]) + np.array(
        [0.004 * np.cos(3 * x[1]), 0.002 * x[0], -0.001 * x[2]]
    )


def owned(V, f):
    u = fem.Function(V)
    d = V.mesh.geometry.dim
    u.interpolate(lambda x: f(x)[:d])
    return u.x.array[: V.dofmap.index_map.size_local * d].copy()


def main():
    comm = MPI.COMM_WORLD
    result = {}
    if len(sys.argv) == 4:
        compare(*sys.argv[1:4], comm=comm)
        if comm.rank == 0:
            result["compare"] = Path(sys.argv[3], "metrics.csv").read_text()
    else:
        for name, mesh in [("block", block_mesh(8, comm).mesh), ("rod", rod_mesh(2, comm).mesh)]:
            V = fem.functionspace(mesh, ("Lagrange", 1, (mesh.geometry.dim,)))
            metrics = Metrics(V)
            result[name] = metrics.evaluate(owned(V, reference), owned(V, candidate))
            ref = [k * owned(V, reference) for k in range(5)]
            cands = {"a": [k * owned(V, candidate) for k in range(5)], "b": ref[:3]}
            curves = metrics.histories(ref, cands)
            result[f"{name} histories"] = {
                label: {m: v.tolist() for m, v in c.items()} for label, c in curves.items()
            }
    if comm.rank == 0:
        print(json.dumps(result))


if __name__ == "__main__":
    main()
