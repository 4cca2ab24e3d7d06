"""The users' rows graded fast and on every rank (issue 35): grade_users shares the rows out
among the ranks of its communicator and rank 0 takes each as it ends; the caches it keeps (the
truth's points located once per mesh, our implicit run once per mesh) and the compiled E_i
loop give the numbers of each row graded alone, and serial and mpiexec -n 2 give the same
numbers, bit for bit (tests/mpi_user_grading.py: 9 rows, three fields on three meshes of the
rod, against a synthetic truth). The speed itself is timed by a benchmark, not here:
`tissuebench bench --only leaderboard-users` (results/performance-leaderboard.md)."""

import math

from mpi4py import MPI

import numpy as np
import pytest
from helpers import run_script
from test_crossmesh import MESHES
from test_truth_grading import affine, candidate, make_truth

from tissuebench.metrics.kernels import interior_norms
from tissuebench.metrics.truth import grade_truth

PARTS = ("total", "discretisation", "algorithm", "model")


def close(a, b, rel=1e-12):
    """Every number of a row (truth columns and budget parts) within rel of the other's, the
    texts equal."""
    if isinstance(a, dict):
        assert a.keys() == b.keys()
        for key in a:
            close(a[key], b[key], rel)
    elif isinstance(a, float) and isinstance(b, float):
        assert math.isclose(a, b, rel_tol=rel, abs_tol=1e-300), (a, b)
    else:
        assert a == b


@pytest.mark.serial
def test_serial_and_two_ranks_grade_the_users_rows_alike(tmp_path):
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    one = run_script("mpi_user_grading.py", tmp_path / "one", ranks=1)
    two = run_script("mpi_user_grading.py", tmp_path / "two", ranks=2)
    labels = [f"user-{k}" for k in range(9)]
    assert sorted(one["rows"]) == sorted(two["rows"]) == labels
    assert one["per_rank"] == [9] and two["per_rank"] == [5, 4]  # both ranks graded rows
    assert sorted(one["taken"]) == sorted(two["taken"]) == labels  # each recorded once
    for label in labels:  # the same numbers whichever rank graded a row, file paths aside
        truth, note, budget = one["rows"][label]
        assert [truth, note] == two["rows"][label][:2]
        assert budget == two["rows"][label][2]
        # every part measured: our implicit ran on each mesh, its parts shared by its rows
        assert all(isinstance(budget[p], float) for p in PARTS), budget
        assert "run here on its mesh" in budget["discretisation_how"]
        # and the caches and the compiled loop change nothing: each row graded alone as before
        close(one["rows"][label], one["alone"][label])
    # rows on one mesh share our implicit's parts; other meshes have their own
    budgets = {label: one["rows"][label][2] for label in labels}
    assert budgets["user-0"]["discretisation"] == budgets["user-3"]["discretisation"]
    assert budgets["user-0"]["discretisation"] != budgets["user-1"]["discretisation"]


def test_the_compiled_loop_is_the_numpy_sum():
    """metrics/kernels.py's E_i loop against the plain numpy expression, on random data: the
    candidate interpolated at each point from its cell's nodes, its distance to the truth's
    value there, weighted and summed per step."""
    rng = np.random.default_rng(35)
    steps, n, k, d, nodes = 7, 1000, 4, 3, 50
    cells = rng.integers(0, nodes, (n, k))
    phi = rng.random((n, k))
    u, uq, w = rng.random((steps, nodes, d)), rng.random((steps, n, d)), rng.random(n)
    expected = np.linalg.norm(np.einsum("pk,spkd->spd", phi, u[:, cells]) - uq, axis=2) @ w
    np.testing.assert_allclose(interior_norms(cells, phi, u, uq, w), expected, rtol=1e-14)
    with pytest.raises(ValueError, match="outside the candidate's nodes"):
        interior_norms(cells + nodes, phi, u, uq, w)


@pytest.mark.parallel
def test_a_located_mesh_is_reused_and_gives_the_same_numbers():
    """grade_truth(located=...) locates a candidate mesh once: a second candidate on it takes
    the same TruthMetrics, and its curves are those of a grading without the dict."""
    u = affine(3)
    truth = make_truth(MESHES[3]["reference"], u)
    located = {}
    for scale in (1.0, 1.2):
        cand = candidate(MESHES[3]["tetrahedra"], lambda X, t, s=scale: s * u(X, t) + 0.001 * t)
        fast = grade_truth(truth, cand, MPI.COMM_WORLD, surface=False, located=located)
        plain = grade_truth(truth, cand, MPI.COMM_WORLD, surface=False)
        for name, curve in plain.curves.items():
            np.testing.assert_array_equal(np.isnan(curve), np.isnan(fast.curves[name]))
            np.testing.assert_allclose(fast.curves[name], curve, rtol=1e-14, atol=0)
    assert len(located) == (1 if MPI.COMM_WORLD.rank == 0 else 0)


def test_the_caches_keep_the_last_meshes_used():
    """grading.Recent keeps its `most` last used entries: a get is a use."""
    from tissuebench.workflows.leaderboard.grading import Recent

    recent = Recent(2)
    recent["a"], recent["b"] = 1, 2
    assert recent.get("a") == 1  # "b" is now the oldest
    recent["c"] = 3
    assert list(recent) == ["a", "c"] and recent.get("b") is None
