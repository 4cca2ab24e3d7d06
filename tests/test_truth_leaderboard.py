"""The leaderboard graded against the truth (SPEC 10, issue 25 item 3): the truth columns of a
row are metrics/truth.py's grade of the row's own series (checked against an exact identity:
a candidate off the truth by a uniform shift c(t) has E_i(t) = |Omega|^((d-1)/d) |c(t)|); a case
without a truth, or whose truth is not computed, gets empty truth columns and one line; NaN
never ranks on the front against the truth; the error budget's parts. Synthetic truths
(test_truth_grading.make_truth): no truth is computed. The grading is rank 0's serial work
(the leaderboard writes on rank 0): under mpiexec every rank does it on the files rank 0 wrote.
"""

import csv
import json
import math

from mpi4py import MPI

import numpy as np
import pytest
from test_crossmesh import MESHES, ROD, write_xdmf
from test_truth_grading import TIMES, affine, candidate, make_truth

from tissuebench.metrics.truth import grade_truth
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard import grading, runs
from tissuebench.workflows.leaderboard.figures import markdown
from tissuebench.workflows.leaderboard.rows import (
    Board,
    Row,
    error_keys,
    mark_truth_pareto,
    write_csv,
)

pytestmark = pytest.mark.parallel  # every rank grades the files rank 0 wrote
COMM = MPI.COMM_WORLD
SHIFT = np.array([0.003, -0.004, 0.0])  # m per s: the candidate is off the truth by SHIFT t


def row(label, cost=1.0, **kw):
    """A finished row of the rod case with a wall time of cost s per simulated second."""
    base = dict(
        case="rod-MP3",
        label=label,
        source="tissuebench",
        description="",
        mesh="reference",
        dofs=336,
        status="ok",
        reason=None,
        errors=dict.fromkeys(error_keys()),
        wall_time_s=10.0 * cost,
        end_time=10.0,
        timing="this session",
    )
    return Row(**{**base, **kw})


@pytest.fixture
def cached(monkeypatch):
    """solvers/truth/store.load_cached replaced: the synthetic rod truth (an affine field on
    the 3D reference grid) for "rod", nothing for any other case; `calls` lists the cases."""
    truth = make_truth(MESHES[3]["reference"], affine(3))
    calls = []

    def load_cached(case, quick=False, comm=MPI.COMM_WORLD):
        calls.append(case)
        return truth if case == "rod" else None

    monkeypatch.setattr("tissuebench.solvers.truth.store.load_cached", load_cached)
    return truth, calls


def written(tmp_path, name, u, mesh_name="coarser hexahedra"):
    """A candidate series of u on one of test_crossmesh's rod meshes, written by rank 0."""
    path = tmp_path / name
    if COMM.rank == 0:
        write_xdmf(path, MESHES[3][mesh_name], candidate(MESHES[3][mesh_name], u))
    COMM.barrier()
    return path


def test_truth_columns_are_the_grade_of_the_rows_own_series(tmp_path, cached):
    """Two rows of the rod case: the exact field on another mesh (E_i = 0 against the truth)
    and one off it by SHIFT t. Their truth columns are grade_truth's of their own files, the
    truth is loaded once for the case, and the shifted one's E_i is the identity's."""
    truth, calls = cached
    u = affine(3)
    exact = written(tmp_path, "exact.xdmf", u)
    shifted = written(tmp_path, "shifted.xdmf", lambda X, t: u(X, t) + SHIFT * t)
    rows = [
        row("implicit", 1.0, reference=True, series=str(exact)),
        row("explicit", 0.5, series=str(shifted)),
        row("gone", 0.1, series=str(tmp_path / "absent.xdmf")),
    ]
    board = Board("rod-MP3", "rod", "MP3", "linear", truth="rod")
    leaderboard.grade_truths([board], {board.name: rows}, log=lambda line: None)
    assert calls == ["rod"]
    assert board.truth_band == pytest.approx(4.7e-6)
    g = grade_truth(truth, read_series(shifted), MPI.COMM_SELF, surface=False)  # as it grades
    for metric in ("relative_error", "interior_error"):
        curve = g.curves[metric][1:]
        assert rows[1].truth[f"{metric}_max"] == np.nanmax(curve)
        assert rows[1].truth[f"{metric}_mean"] == pytest.approx(np.nanmean(curve), rel=1e-14)
    volume = math.prod(ROD)
    expected = volume ** (2 / 3) * np.linalg.norm(SHIFT) * TIMES[1:]  # m^3
    assert rows[1].truth["interior_error_max"] == pytest.approx(expected.max(), rel=1e-10)
    assert rows[1].truth["interior_error_mean"] == pytest.approx(expected.mean(), rel=1e-10)
    assert rows[0].truth["interior_error_max"] < 1e-13  # P1/Q1 interpolate an affine field
    assert rows[2].truth == {} and "not on this machine" in rows[2].truth_note
    # the implicit reference ranks against the truth: it is the front's cheapest exact run
    assert rows[0].truth_pareto == {"mean": True, "max": True}
    assert rows[1].truth_pareto == {"mean": True, "max": True}  # cheaper than the reference
    # the same-mesh columns are untouched; the budget: total, discretisation, algorithm
    assert rows[1].errors == dict.fromkeys(error_keys())
    assert rows[1].budget["total"] == rows[1].truth["interior_error_mean"]
    assert rows[1].budget["discretisation"] == rows[0].truth["interior_error_mean"]
    text = markdown([board], {board.name: rows}, {}, "now")
    assert "Truth (SPEC 10): `rod`, its own E_i max 4.7e-06 m^3" in text
    assert "### Against the truth `rod`" in text
    assert f"| explicit | tissuebench | reference, 336 | {expected.mean():.3g} |" in text


def test_a_case_without_a_truth_gets_empty_columns_and_one_line(tmp_path, cached):
    """block-MP1 (point needle: no truth) and rod-MP3-s3 (its truth rod-nhb-s3 not computed):
    no truth columns filled in the CSV, one line in the case's header, no truth section."""
    _, calls = cached
    point = next(b for b in leaderboard.BOARDS if b.name == "block-MP1")
    s3 = next(b for b in leaderboard.BOARDS if b.name == "rod-MP3-s3")
    assert point.truth is None and s3.truth == "rod-nhb-s3"
    assert s3.model == "neo-hookean-barrier" and s3.simulator_model == "neo-hookean"
    from dataclasses import replace

    point, s3 = replace(point), replace(s3)  # the module's boards stay as they are
    u = written(tmp_path, "run.xdmf", affine(3))
    rows = {
        point.name: [row("implicit", case=point.name, series=str(u))],
        s3.name: [row("implicit+neo-hookean-barrier", case=s3.name, series=str(u))],
    }
    leaderboard.grade_truths([point, s3], rows, log=lambda line: None)
    assert calls == ["rod-nhb-s3"]  # never the point-needle case; the truth never computed
    path = tmp_path / f"lb-{COMM.rank}.csv"
    write_csv(path, [r for board in rows.values() for r in board])
    with open(path, newline="") as f:
        table = list(csv.DictReader(f))
    for r in table:
        for key in ("truth_relative_error_max", "truth_interior_error_mean"):
            assert r[key] == ""
        assert r["truth_interior_error_max"] == "" and r["truth_pareto_mean"] == "False"
    text = markdown([point, s3], rows, {}, "now")
    lines = [line for line in text.splitlines() if line.startswith("Truth (SPEC 10)")]
    assert len(lines) == 2
    assert "point (w = 0)" in lines[0] and "converges to no solution" in lines[0]
    assert (
        "rod-nhb-s3, not computed on this machine (tissuebench truth rod-nhb-s3: about" in lines[1]
    )
    assert "### Against the truth" not in text


def test_nan_never_on_the_truth_front():
    """A NaN, infinite or missing error against the truth, an unfinished run or a NaN cost
    never ranks; the others' front is the non-dominated set."""
    rows = [
        row("a", 1.0, truth={"interior_error_mean": 1e-3, "interior_error_max": 2e-3}),
        row("b", 2.0, truth={"interior_error_mean": 5e-4, "interior_error_max": 3e-3}),
        row("c", 3.0, truth={"interior_error_mean": 6e-4, "interior_error_max": 1e-3}),
        row("nan", 0.1, truth={"interior_error_mean": math.nan, "interior_error_max": math.nan}),
        row("inf", 0.1, truth={"interior_error_mean": math.inf, "interior_error_max": None}),
        row("none", 0.1),
        row(
            "diverged",
            0.1,
            status="diverged",
            truth={"interior_error_mean": 1e-9, "interior_error_max": 1e-9},
        ),  # fmt: skip
        row("no cost", wall_time_s=math.nan, truth={"interior_error_mean": 1e-9}),
    ]
    mark_truth_pareto(rows)
    front = {k: [r.label for r in rows if r.truth_pareto.get(k)] for k in ("mean", "max")}
    assert front == {"mean": ["a", "b"], "max": ["a", "c"]}
    for r in rows[3:]:
        assert not r.truth_pareto.get("mean") and not r.truth_pareto.get("max")


def test_an_outside_run_is_graded_from_the_file_its_compare_graded(tmp_path):
    """A simulator variant's compare recorded its candidate inside the folder's partial copy;
    the leaderboard takes the same file under the final folder."""
    variant = tmp_path / "calculix" / "implicit-C3D8I"
    if COMM.rank == 0:
        (variant / "work").mkdir(parents=True)
        (variant / "work" / "job.frd").write_text("")
        recorded = tmp_path / ".calculix.partial" / "implicit-C3D8I" / "work" / "job.frd"
        summary = {"kind": "compare", "candidate": {"file": str(recorded), "field": "U"}}
        (variant / "summary.json").write_text(json.dumps(summary))
    COMM.barrier()
    series, field = runs.external_series(tmp_path / "calculix", "implicit-C3D8I")
    assert series == str(variant / "work" / "job.frd") and field == "U"
    assert runs.external_series(tmp_path / "calculix", "C3D20") == (None, None)


def test_the_error_budget_takes_our_implicit_on_the_rows_mesh():
    """On our grid: discretisation is implicit's against the truth, algorithm the same-mesh
    column; CalculiX C3D8I says that its discretisation is our element's; a user's run has
    none; on a mesh of ours with no implicit run, none with the reason."""
    t = lambda mean: {"interior_error_mean": mean, "interior_error_max": 2 * mean}  # noqa: E731
    ref = row("implicit", reference=True, truth=t(4e-4), errors={"interior_error_mean": 0.0})
    c3d8i = row("calculix:implicit-C3D8I", source="CalculiX 2.20", truth=t(3e-4),
                errors={"interior_error_mean": 1.6e-4})  # fmt: skip
    user = row("mine", source="user", mesh="?", truth=t(1e-3), errors={})
    lone = row("x (prism grid)", mesh="prism grid: 9 nodes", group="g", truth=t(1e-3))
    grading.error_budget([ref, c3d8i, user, lone])
    assert ref.budget["discretisation"] == 4e-4 and ref.budget["algorithm"] == 0.0
    assert c3d8i.budget["total"] == 3e-4 and c3d8i.budget["discretisation"] == 4e-4
    assert c3d8i.budget["algorithm"] == 1.6e-4
    assert "our element's (Q1) on its mesh: C3D8I" in c3d8i.budget["discretisation_how"]
    assert "C3D8I's difference included" in c3d8i.budget["algorithm_how"]
    assert (
        user.budget["discretisation"] is None and "not known" in user.budget["discretisation_how"]
    )
    assert (
        lone.budget["discretisation"] is None
        and "no run of our implicit" in (lone.budget["discretisation_how"])
    )


def test_a_truth_whose_levels_do_not_converge_grades_nothing(tmp_path, monkeypatch):
    """A cached truth that states no own error (its levels' differences grow) is no
    yardstick: no row is graded against it and the case's header says why in one line."""
    from dataclasses import replace

    truth = make_truth(MESHES[3]["reference"], affine(3))
    truth.own_error = {"interior_error_max": float("nan")}
    monkeypatch.setattr(
        "tissuebench.solvers.truth.store.load_cached", lambda case, quick=False, comm=None: truth
    )
    s3 = replace(next(b for b in leaderboard.BOARDS if b.name == "rod-MP3-s3"))
    u = written(tmp_path, "run.xdmf", affine(3))
    rows = {s3.name: [row("implicit+neo-hookean-barrier", case=s3.name, series=str(u))]}
    leaderboard.grade_truths([s3], rows, log=lambda line: None)
    assert rows[s3.name][0].truth == {} and s3.truth_band is None
    assert "its levels do not converge and it states no own error" in s3.truth_note
