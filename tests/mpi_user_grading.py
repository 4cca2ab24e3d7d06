"""The users' rows of a leaderboard case graded by grade_users over COMM_WORLD (run by
tests/test_user_grading.py in serial and under mpiexec -n 2): a synthetic rod truth (an
affine field on the reference grid, at the case's t_i = i h, so that no truth is computed;
every rank makes the same one), and 9 user rows, three fields on each of three meshes of the
rod, each with its error budget (our implicit run on its mesh). Prints, on rank 0, every row's
truth columns, note and budget, the order in which rank 0 took them, how many rows each rank
graded, and (in serial) the same rows graded one by one without the caches (the old path).

    python tests/mpi_user_grading.py FOLDER
"""

import json
import sys
from dataclasses import replace
from pathlib import Path

from mpi4py import MPI

import numpy as np
from test_crossmesh import MESHES, write_xdmf
from test_truth_grading import affine, candidate, make_truth

from tissuebench.meshes import get_entry
from tissuebench.solvers.truth import store
from tissuebench.workflows.leaderboard import grading
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys

COMM = MPI.COMM_WORLD
STEPS = 5
folder = Path(sys.argv[1])
h = get_entry("rod").dt
times = np.arange(STEPS + 1) * h
u = affine(3)
truth = make_truth(MESHES[3]["reference"], u, times=times)
store.load_cached = lambda case, quick=False, comm=None: truth if case == "rod" else None
board = Board("rod-MP3", "rod", "MP3", "linear", simulators=(), end_time=STEPS * h, truth="rod")

fields = {
    "exact": u,
    "scaled": lambda X, t: 1.1 * u(X, t),
    "shifted": lambda X, t: u(X, t) + np.array([0.003, -0.004, 0.001]) * t,
}
meshes = ["coarser hexahedra", "tetrahedra", "moved tetrahedra"]
rows = []
for k, (field, mesh) in enumerate((f, m) for f in fields for m in meshes):
    path = folder / f"{field}-{mesh.replace(' ', '-')}.xdmf"
    if COMM.rank == 0:
        write_xdmf(path, MESHES[3][mesh], candidate(MESHES[3][mesh], fields[field], times))
    rows.append(
        Row(
            "rod-MP3",
            f"user-{k}",
            "user",
            "",
            mesh,
            0,
            "ok",
            None,
            dict.fromkeys(error_keys()),
            1.0 + k,
            STEPS * h,
            "reported by the user",
            series=str(path),
        )  # fmt: skip
    )
COMM.barrier()

graded_here = []
grade_user_row = grading.grade_user_row


def counted(board, board_rows, row, truth, caches):
    graded_here.append(row.label)
    return grade_user_row(board, board_rows, row, truth, caches)


grading.grade_user_row = counted
taken = []
mine = [replace(r) for r in rows] if COMM.rank == 0 else []
grading.grade_users(
    [board],
    {board.name: []},
    {board.name: mine},
    None,
    folder,
    on_graded=lambda b, row, seconds: taken.append(row.label),
    comm=COMM,
)
per_rank = COMM.gather(len(graded_here), root=0)
grading.grade_user_row = grade_user_row
out = {}
if COMM.rank == 0:
    out["rows"] = {r.label: [r.truth, r.truth_note, r.budget] for r in mine}
    out["taken"] = taken
    out["per_rank"] = per_rank
    if COMM.size == 1:  # each row alone, without the caches: the numbers before them
        alone = {}
        for r in (replace(r) for r in rows):
            grading.grade_row_truth(truth, r)
            grading.error_budget([r], only=[r], board=board, truth=truth)
            alone[r.label] = [r.truth, r.truth_note, r.budget]
        out["alone"] = alone
    print(json.dumps(out))
