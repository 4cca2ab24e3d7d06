"""A user's run on the case's own mesh says so (issue 59, item 7d): a run on the mesh that
`tissuebench export` hands out was described as "quadrilaterals: 400 cells, 441 nodes", as
any mesh of that size would be. Now the leaderboard checks the run's mesh against the case's
(the same cell type, points and cells, in any numbering) and its row's mesh says "(the case's
mesh)"; a run on another mesh of the body is described as before.

The case: the rod to T = 5 h, its reference run as `tissuebench export` runs it (about a
second); the users' series are the reference's own displacements on its mesh (as exported,
and renumbered) and an affine field on tetrahedra of the same body."""

from dataclasses import replace

from mpi4py import MPI

import numpy as np
import pytest
from test_crossmesh import MESHES
from test_truth_grading import affine, candidate

from tissuebench.meshes import get_entry
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.posing import export, reference_path
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.leaderboard import grading
from tissuebench.workflows.leaderboard.rows import UNGRADED, Board, Row, error_keys

pytestmark = pytest.mark.serial  # rank 0's work: the leaderboard grades in serial

H = get_entry("rod").dt
STEPS = 5
BOARD = Board("rod-tiny", "rod", "MP3", "linear", simulators=(), end_time=STEPS * H,
              truth="rod", description="the rod to 5 h")  # fmt: skip


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The case's exported reference series (rank 0's)."""
    tmp = tmp_path_factory.mktemp("case-mesh")
    export("rod", "json", tmp / "rod.json", mesh_size=3, options={},
           material=get_material("MP3"), model="linear", h=H, steps=STEPS,
           comm=MPI.COMM_SELF, log=lambda line: None)  # fmt: skip
    return read_series(reference_path(tmp / "rod.json"))


class Caches:
    """What grade_row_reference asks of the leaderboard's caches: the case's reference and
    the row's series."""

    def __init__(self, reference, series):
        self._reference, self._series = reference, series

    def reference(self, board):
        return self._reference

    def series(self, path, field):
        return self._series


def graded_mesh(reference, series) -> str:
    """The mesh a user's row of `series` is described with once graded."""
    row = Row(BOARD.name, "mine", "user", "", "?", 0, UNGRADED, None,
              dict.fromkeys(error_keys()), 1.0, STEPS * H, "reported by the user",
              series="mine.xdmf")  # fmt: skip
    grading.grade_row_reference(BOARD, row, Caches(reference, series))
    assert row.status == "ok", row.reason
    return row.mesh


def renumbered(series, seed=0):
    """The same series with its nodes numbered otherwise (and its cells renumbered to match)."""
    order = np.random.default_rng(seed).permutation(len(series.points))  # new node k: old order[k]
    new = np.empty_like(order)
    new[order] = np.arange(len(order))
    return replace(
        series,
        points=series.points[order],
        cells=new[series.cells],
        displacements=[u[order] for u in series.displacements],
    )


def test_a_run_on_the_exported_mesh_is_said_to_be_on_the_cases_mesh(reference):
    cells, nodes = len(reference.cells), len(reference.points)
    said = f"hexahedra: {cells:,} cells, {nodes:,} nodes (the case's mesh)"
    assert graded_mesh(reference, reference) == said
    assert graded_mesh(reference, renumbered(reference)) == said


def test_a_run_on_another_mesh_is_described_as_before(reference):
    mesh = MESHES[3]["tetrahedra"]
    times = np.arange(STEPS + 1) * H
    tets = candidate(mesh, affine(3), times)
    said = graded_mesh(reference, tets)
    assert said == f"tetrahedra: {len(mesh[1]):,} cells, {len(mesh[0]):,} nodes"
    moved = replace(reference, points=reference.points * np.array([1.0, 1.0, 1.001]))
    assert not grading.on_case_mesh(moved, reference)  # the same numbers, other points
    assert not grading.on_case_mesh(
        replace(reference, cells=np.roll(reference.cells, 1, axis=0)[:-1]), reference
    )
    assert grading.on_case_mesh(renumbered(reference, seed=1), reference)


def test_a_row_on_the_cases_mesh_stays_in_the_closed_division(reference):
    """The words added keep the row's cell kind first: the Closed division (the case's cells
    and nodes) still takes it."""
    from tissuebench.workflows.leaderboard.page_words import closed

    row = Row(BOARD.name, "mine", "user", "", graded_mesh(reference, reference),
              3 * len(reference.points), "ok", None, dict.fromkeys(error_keys()), 1.0,
              STEPS * H, "reported by the user")  # fmt: skip
    assert closed(row, BOARD, 3 * len(reference.points))
