"""Truth runs of SPEC 13's cylinder cases on the meridian (solvers/truth/), on small levels, a
few steps each: the axial force (N) at every step, the last displacement in an order fixed by
node coordinates, and the smallest J of the neo-Hookean one, printed as JSON by rank 0 (run in
serial and under mpiexec by test_truth_cylinder.py)."""

import json

from mpi4py import MPI

from tissuebench.solvers.system import gather_by_coordinates
from tissuebench.solvers.truth import case_truth, interior_difference

out = {}
for case, sizes, steps in [("cylinder-MP1", (4, 8), 8), ("cylinder-MP1-nhb", (4,), 6)]:
    runs = []
    for n in sizes:
        truth, bench = case_truth(case, n)
        run = truth.run(bench.dt, steps)
        runs.append(run)
        history = gather_by_coordinates(run.V, run.u[-1])
        if MPI.COMM_WORLD.rank == 0:
            out[f"{case}-{n}-u"] = history[1].tolist()
            out[f"{case}-{n}-force"] = run.force.tolist()
            if run.min_jacobian is not None:
                out[f"{case}-{n}-min-J"] = run.min_jacobian.values.tolist()
    if len(runs) == 2:
        out[f"{case}-levels"] = interior_difference(runs[0], runs[1]).tolist()
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
