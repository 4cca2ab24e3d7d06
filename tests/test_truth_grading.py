"""Grading against the truth (SPEC 10, metrics/truth.py; `compare truth:CASE`): exact identities
on synthetic truths sampled from analytic fields on structured grids, so that no truth has to
be computed. Collective tests (grade_truth computes on rank 0 and broadcasts): under mpiexec
every rank must get the serial numbers."""

import importlib
import json
import sys
import types
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from test_crossmesh import MESHES, ROD, SQUARE, grid, write_xdmf

from tissuebench.metrics.cells import boundary_facets
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.truth import grade_truth, located_on, truth_case, truth_series
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.cli import main
from tissuebench.workflows.compare.grading import compare

TIMES = np.array([0.0, 0.25, 0.5, 0.75])  # s, t_i = i h
OWN = 4.7e-6  # the synthetic truths' own error, m^d
LENGTHS = {2: SQUARE, 3: ROD}
pytestmark = pytest.mark.parallel  # every rank must get the serial numbers
COMM = MPI.COMM_WORLD


def gauss(points, cells):
    """3 Gauss points per direction on each axis-aligned box cell (independent of
    metrics/cells.py: the tensor rule on [lo, hi]): points (n_q, d), weights (n_q,)."""
    g, w = np.polynomial.legendre.leggauss(3)
    g, w = 0.5 * (g + 1), 0.5 * w
    d = points.shape[1]
    xi = np.stack(np.meshgrid(*[g] * d, indexing="ij"), -1).reshape(-1, d)
    wq = np.prod(np.stack(np.meshgrid(*[w] * d, indexing="ij"), -1).reshape(-1, d), axis=1)
    lo, hi = points[cells].min(axis=1), points[cells].max(axis=1)
    x = lo[:, None, :] + (hi - lo)[:, None, :] * xi[None]
    weights = np.prod(hi - lo, axis=1)[:, None] * wq[None]
    return x.reshape(-1, d), weights.ravel()


def make_truth(mesh, u, times=TIMES, case="rod"):
    """A TruthSamples of the field u(X, t) (m) on a structured grid mesh."""
    points, cells, cell_type = mesh
    x, w = gauss(points, cells)
    return TruthSamples(
        case,
        cell_type,
        np.asarray(times, dtype=float),
        points,
        cells,
        boundary_facets(points, cells, cell_type),
        x,
        w,
        np.stack([u(points, t) for t in times]),
        np.stack([u(x, t) for t in times]),
        {"interior_error_max": OWN, "levels": 3},
        {"case": case, "synthetic": True},
    )


def candidate(mesh, u, times=TIMES, name="cand.xdmf"):
    points, cells, cell_type = mesh
    return Series(Path(name), points, cells, cell_type, np.asarray(times, dtype=float),
                  [u(points, t) for t in times])  # fmt: skip


def affine(dim):
    A = {
        2: np.array([[0.1, 0.05], [-0.03, 0.02]]),
        3: np.array([[0.1, 0.05, 0.0], [-0.03, 0.02, 0.01], [0.0, 0.04, -0.02]]),
    }[dim]
    b = np.array([0.01, -0.02, 0.005][:dim])
    return lambda X, t: (1 + t) * t * (X @ A.T + b)


def same_on_every_rank(g):
    """The curves, checked equal (NaN included) on every rank."""
    table = np.array([g.curves[n] for n in sorted(g.curves)])
    for other in COMM.allgather(table):
        np.testing.assert_array_equal(other, table)
    return g.curves


OTHER_MESHES = {
    2: ["coarser quadrilaterals", "triangles", "moved triangles", "finer quadrilaterals"],
    3: ["coarser hexahedra", "tetrahedra", "moved tetrahedra", "moved interior nodes"],
}


@pytest.mark.parametrize(
    "dim, name", [(d, n) for d in (2, 3) for n in OTHER_MESHES[d]], ids=lambda v: str(v)
)
def test_an_affine_field_on_another_mesh_is_graded_exactly(dim, name):
    """u = f(t) (A X + b) as the truth on one grid, as the candidate on another mesh of the body
    (P1 and Q1 interpolate it exactly): E_n = E_i = nodal E_i = E_s = 0 to round-off at every
    step (E_n NaN at t = 0, where the truth is zero)."""
    u = affine(dim)
    truth = make_truth(MESHES[dim]["reference"], u)
    g = grade_truth(truth, candidate(MESHES[dim][name], u))
    curves = same_on_every_rank(g)
    assert g.status == ["ok"] * len(TIMES)
    assert np.isnan(curves["relative_error"][0])
    assert np.all(curves["relative_error"][1:] < 1e-13)
    for metric in ("interior_error", "interior_error_nodal", "surface_error"):
        assert np.all(curves[metric] < 1e-13), (metric, curves[metric])
    assert "the truth's own error: 4.7e-06" in g.summaries["interior_error"]


def q1_error(points, cells, x):
    """|u − its Q1 interpolant| at the points x of each cell (rows of x cell by cell, as gauss
    gives them) for u = (X_1^2, ..., X_d^2): on the cell [lo, hi], component j of the
    interpolant minus u is (x_j − lo_j)(hi_j − x_j), exactly."""
    lo, hi = points[cells].min(axis=1), points[cells].max(axis=1)
    per_cell = len(x) // len(cells)
    lo, hi = np.repeat(lo, per_cell, axis=0), np.repeat(hi, per_cell, axis=0)
    return np.linalg.norm((x - lo) * (hi - x), axis=1)


@pytest.mark.parametrize("dim", [2, 3])
def test_the_truth_vertex_values_of_a_quadratic_field_give_its_q1_error(dim):
    """The candidate is the truth's own vertices and values of u = t (X_1^2, ..., X_d^2): E_n =
    nodal E_i = E_s = 0 exactly, and E_i is |Ω|^(−1/d) Σ_q w_q |u − I_Q1 u|(X_q), computed here
    from the interpolation error's closed form."""
    mesh = grid((5, 3) if dim == 2 else (4, 3, 2), LENGTHS[dim])
    points, cells, _ = mesh
    truth = make_truth(mesh, lambda X, t: t * X**2)
    cand = candidate(mesh, lambda X, t: t * X**2)
    curves = same_on_every_rank(grade_truth(truth, cand))
    x, w = gauss(points, cells)
    volume = np.prod(LENGTHS[dim])
    expected = TIMES * volume ** (-1 / dim) * (w @ q1_error(points, cells, x))
    np.testing.assert_allclose(curves["interior_error"], expected, rtol=1e-12, atol=0)
    assert np.all(curves["relative_error"][1:] == 0)
    assert np.all(curves["interior_error_nodal"] == 0)
    assert np.all(curves["surface_error"] < 1e-14)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_shifted_candidate(dim):
    """u′ = u + c on another mesh (u affine): E_n = |c| sqrt(n_v) / ‖u‖ at the truth's n_v
    vertices and E_i = nodal E_i = |Ω|^(1 − 1/d) |c| at every step."""
    u = affine(dim)
    c = np.array([0.003, -0.004, 0.012][:dim])
    mesh = MESHES[dim]["reference"]
    truth = make_truth(mesh, u)
    other = "triangles" if dim == 2 else "tetrahedra"
    curves = same_on_every_rank(
        grade_truth(truth, candidate(MESHES[dim][other], lambda X, t: u(X, t) + c))
    )
    n_v = len(mesh[0])
    norms = np.array([np.linalg.norm(u(mesh[0], t)) for t in TIMES[1:]])
    np.testing.assert_allclose(
        curves["relative_error"][1:], np.linalg.norm(c) * np.sqrt(n_v) / norms, rtol=1e-12
    )
    volume = np.prod(LENGTHS[dim])
    shifted = volume ** (1 - 1 / dim) * np.linalg.norm(c)
    for metric in ("interior_error", "interior_error_nodal"):
        np.testing.assert_allclose(curves[metric], shifted, rtol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
def test_another_body_is_refused_naming_the_farthest_node(dim):
    u = affine(dim)
    truth = make_truth(MESHES[dim]["reference"], u)
    longer = grid((4, 2) if dim == 2 else (2, 1, 1), (LENGTHS[dim][0] * 1.01, *LENGTHS[dim][1:]))
    with pytest.raises(InputError, match=r"not a mesh of the body of truth:rod: .*node \d+ at"):
        grade_truth(truth, candidate(longer, u))


@pytest.mark.parametrize(
    "times",
    [TIMES * 1.5, np.arange(7) * 0.125, np.r_[TIMES, 1.0]],
    ids=["other h", "h/2", "longer"],
)
def test_a_candidate_at_other_times_is_refused(times):
    u = affine(2)
    truth = make_truth(MESHES[2]["reference"], u)
    with pytest.raises(InputError, match=r"needs the candidate at every t_i = i h, h = 0.25 s"):
        grade_truth(truth, candidate(MESHES[2]["triangles"], u, times))


def test_a_candidate_that_stops_or_diverges_or_starts_at_h():
    """As compare: a candidate with fewer steps is "missing" from there, one with a NaN has
    "diverged" from that step (NaN metrics), one without t = 0 starts from u = 0."""
    u = affine(2)
    truth = make_truth(MESHES[2]["reference"], u)
    mesh = MESHES[2]["triangles"]
    full = same_on_every_rank(grade_truth(truth, candidate(mesh, lambda X, t: 1.1 * u(X, t))))
    short = grade_truth(truth, candidate(mesh, lambda X, t: 1.1 * u(X, t), TIMES[:3]))
    assert short.status == ["ok", "ok", "ok", "missing"]
    assert "steps 3..3 missing" in short.summaries["candidate"]
    broken = candidate(mesh, lambda X, t: 1.1 * u(X, t))
    broken.displacements[2] = broken.displacements[2].copy()
    broken.displacements[2][5, 0] = np.nan
    diverged = grade_truth(truth, broken)
    assert diverged.status == ["ok", "ok", "diverged", "diverged"]
    assert diverged.candidate_diverged == 2
    later = grade_truth(truth, candidate(mesh, lambda X, t: 1.1 * u(X, t), TIMES[1:]))
    assert "zero initial state" in later.notes[0]
    for name, curve in full.items():
        np.testing.assert_array_equal(short.curves[name][:3], curve[:3])
        np.testing.assert_array_equal(diverged.curves[name][:2], curve[:2])
        assert np.isnan(diverged.curves[name][2:]).all()
        np.testing.assert_array_equal(later.curves[name], curve)
    assert np.all(full["relative_error"][1:] > 0.09)  # 10 % off: E_n = 0.1 (affine, exact)
    np.testing.assert_allclose(full["relative_error"][1:], 0.1, rtol=1e-12)


def test_truth_case_names():
    assert truth_case("rod") is None and truth_case(Path("ref.xdmf")) is None
    assert truth_case(Path("truth:block-MP2-w0.2")) == "block-MP2-w0.2"
    for name in ("block-MP1", "block-MP2-w0"):
        with pytest.raises(InputError, match="this case has no converged reference.*w = 0.2 m: "
                           "block-MP1-w0.2, block-MP2-w0.2$"):  # fmt: skip
            truth_case(f"truth:{name}")
    for name in ("block-MP1-nh-s2-w0.2", "block-MP1-nhb-s2-w0.2"):  # SPEC 10: dropped
        with pytest.raises(InputError, match="no large-deformation truth.*linear: "
                           "block-MP1-w0.2, block-MP2-w0.2$"):  # fmt: skip
            truth_case(f"truth:{name}")
    assert truth_case("truth:rod-nhb-s3") == "rod-nhb-s3"
    with pytest.raises(InputError, match="no such truth case"):
        truth_case("truth:rod-nh-s3")  # the (J - 1)^2 law at s = 3: no solution to converge to
    with pytest.raises(InputError, match="no such truth case; the cases .* are rod, rod-nh-s1"):
        truth_case("truth:beam")


@pytest.fixture
def store(monkeypatch):
    """solvers/truth/store.py's truth_samples, replaced by a synthetic rod truth (the affine
    field on the 3D reference grid); `calls` records the cases asked for."""
    truth = make_truth(MESHES[3]["reference"], affine(3))
    calls = []

    def truth_samples(case, quick=False, comm=MPI.COMM_WORLD, log=print):
        calls.append(case)
        return truth

    try:
        module = importlib.import_module("tissuebench.solvers.truth.store")
    except ImportError:  # not written yet
        module = types.ModuleType("tissuebench.solvers.truth.store")
        monkeypatch.setitem(sys.modules, "tissuebench.solvers.truth.store", module)
    monkeypatch.setattr(module, "truth_samples", truth_samples, raising=False)
    return truth, calls


def test_compare_against_the_truth_writes_a_compare_folder(tmp_path, store, capsys):
    """`tissuebench compare truth:rod CAND --out DIR` (in process, so collective under
    mpiexec): metrics.csv with the curves of grade_truth, summary.json with the truth's case,
    own error and fingerprint; the E_i lines say the truth's own error; again: skipped."""
    truth, calls = store
    u = affine(3)
    mesh = MESHES[3]["tetrahedra"]
    cand = candidate(mesh, lambda X, t: u(X, t) + 0.001)
    if COMM.rank == 0:
        write_xdmf(tmp_path / "cand.xdmf", mesh, cand)
    COMM.barrier()
    out = tmp_path / "graded"
    assert main(["compare", "truth:rod", str(tmp_path / "cand.xdmf"), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert calls == ["rod"]
    if COMM.rank == 0:
        assert "interior_error: max" in printed and "(the truth's own error: 4.7e-06)" in printed
    expected = grade_truth(truth, cand)
    rows = np.genfromtxt(out / "metrics.csv", delimiter=",", names=True, dtype=None,
                         encoding="utf-8")  # fmt: skip
    np.testing.assert_allclose(
        rows["interior_error"], expected.curves["interior_error"], rtol=1e-14
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["truth"]["case"] == "rod"
    assert summary["truth"]["own_error"]["interior_error_max"] == OWN
    assert summary["reference"]["file"] == "truth:rod"
    assert summary["inputs"]["reference"]["truth"] == "rod"
    assert len(summary["inputs"]["reference"]["fingerprint"]) == 64
    assert summary["runs"]["cand"]["interior_error_max"] == pytest.approx(
        np.nanmax(expected.curves["interior_error"][1:]), rel=1e-14
    )
    again = compare("truth:rod", tmp_path / "cand.xdmf", out)
    assert "skipped" in again


def test_compare_says_what_it_does_and_skips_a_graded_folder_unread(tmp_path, store, capsys):
    """Issue 59, item 7b: `compare truth:rod` said nothing for 20 s (reading the truth,
    locating, grading), and read the truth (200 MB, 6 s) before it said that a graded folder
    is skipped. Now each phase is said as it starts, and a complete folder of the same inputs
    is skipped without reading the truth."""
    truth, calls = store
    mesh = MESHES[3]["tetrahedra"]
    if COMM.rank == 0:
        write_xdmf(tmp_path / "cand.xdmf", mesh, candidate(mesh, affine(3)))
    COMM.barrier()
    argv = ["compare", "truth:rod", str(tmp_path / "cand.xdmf"), "--out", str(tmp_path / "g")]
    assert main(argv) == 0
    printed = capsys.readouterr().out.splitlines()
    assert calls == ["rod"]
    if COMM.rank == 0:
        said = [
            f"reading the candidate {tmp_path / 'cand.xdmf'}",
            f"grading it against the truth rod: locating its {len(mesh[0]):,} nodes "
            f"({len(mesh[1]):,} tetrahedra) in the truth's mesh, then E_n, E_i and E_s at each "
            f"of its {len(TIMES)} time steps",
            f"graded {len(TIMES) - 1} steps against",
            "E_i interior_error: max",
        ]
        at = [next(i for i, line in enumerate(printed) if line.startswith(s)) for s in said]
        assert at == sorted(at), printed  # in this order, the metrics last
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert calls == ["rod"]  # not read again
    if COMM.rank == 0:
        assert printed.splitlines() == [
            f"{tmp_path / 'g'}: complete results for the same inputs exist, skipped (--force "
            "grades again)"
        ]


def test_compare_refuses_a_point_needle_case(tmp_path, store, capsys):
    with pytest.raises(SystemExit) as stop:  # refused as the arguments are parsed
        main(["compare", "truth:block-MP1", "x.xdmf", "--out", str(tmp_path / "o")])
    assert stop.value.code == 2 and store[1] == []
    if COMM.rank == 0:
        err = capsys.readouterr().err.strip()
        assert "truth:block-MP1: this case has no converged reference" in err
        assert len(err.splitlines()) == 1


@pytest.mark.parametrize("dim", [2, 3])
def test_the_steps_in_chunks_give_the_numbers_of_step_by_step(dim):
    """grade_truth evaluates E_n, E_i and nodal E_i of the steps in chunks (the compiled loop
    of TruthMetrics.evaluate_steps): the numbers of TruthMetrics.evaluate, numpy step by step,
    to round-off, and its E_s; without the surface E_s is NaN and the rest unchanged; a
    diverged candidate's steps from its divergence are NaN as before."""
    u = affine(dim)
    truth = make_truth(MESHES[dim]["reference"], u)
    other = "triangles" if dim == 2 else "tetrahedra"
    cand = candidate(MESHES[dim][other], lambda X, t: 1.1 * u(X, t) + 0.001 * t)
    full = same_on_every_rank(grade_truth(truth, cand))
    fast = same_on_every_rank(grade_truth(truth, cand, surface=False))
    grader = located_on(truth, truth_series(truth), cand, None)
    steps = [grader.evaluate(i, cand.displacements[i]) for i in range(len(cand.times))]
    for name in ("relative_error", "interior_error", "interior_error_nodal", "surface_error"):
        one = [step[name] for step in steps]
        np.testing.assert_allclose(full[name], one, rtol=1e-13, atol=0)
        if name != "surface_error":
            np.testing.assert_array_equal(fast[name], full[name])
    assert np.isnan(fast["surface_error"]).all()
    cand.displacements[2] = cand.displacements[2].copy()
    cand.displacements[2][0, 0] = np.nan
    broken = same_on_every_rank(grade_truth(truth, cand, surface=False))
    np.testing.assert_allclose(broken["interior_error"][:2], full["interior_error"][:2], rtol=1e-13)
    assert np.isnan(broken["interior_error"][2:]).all()
