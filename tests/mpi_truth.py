"""Truth runs of SPEC 10 (solvers/truth.py) on small meshes, a few steps each: the tip, the
last displacement in an order fixed by node coordinates, and the E_i differences between
levels and time steps, printed as JSON by rank 0 (run in serial and under mpiexec by
test_truth.py)."""

import json

from mpi4py import MPI

from tissuebench.solvers.system import gather_by_coordinates
from tissuebench.solvers.truth import case_truth, interior_difference

out = {}
for case, sizes, steps in [
    ("rod", (1, 2), 8),
    ("block-MP2-w0.2", (10, 20), 6),
    ("rod-nh-s1", (1,), 4),  # the mixed form with the (J - 1)^2 law
    ("rod-nhb-s3", (1,), 4),  # and with the barrier law
]:
    runs = []
    for n in sizes:
        truth, bench = case_truth(case, n)
        run = truth.run(bench.dt, steps)
        runs.append(run)
        history = gather_by_coordinates(run.V, run.u[-1])
        if MPI.COMM_WORLD.rank == 0:
            out[f"{case}-{n}-u"] = history[1].tolist()
            if run.tip is not None:
                out[f"{case}-{n}-tip"] = run.tip.tolist()
            if run.min_jacobian is not None:
                out[f"{case}-{n}-min-J"] = run.min_jacobian.values.tolist()
    if len(runs) == 2:
        out[f"{case}-levels"] = interior_difference(runs[0], runs[1]).tolist()
        half = truth.run(bench.dt / 2, 2 * steps)
        out[f"{case}-time"] = interior_difference(runs[-1], half, time_ratio=2).tolist()
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
