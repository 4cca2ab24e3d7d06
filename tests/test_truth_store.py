"""Where the truth lives (solvers/truth/store.py, workflows/commands/truth.py): its samples on the
vertices and quadrature points of its mesh (cells in VTK order, boundary facets, weights,
the Q2 values of a known field), serial against mpiexec -n 2, the cache (a second call
reads it; a change of input changes the key), and `tissuebench truth`."""

import csv
from pathlib import Path

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from helpers import run_script, tissuebench

from tissuebench.metrics.cells import boundary_facets, measures
from tissuebench.solvers.truth import Problem, Truth, store
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.solver import TruthRun
from tissuebench.workflows.io.output import write_owned

COMM = MPI.COMM_WORLD
BOX = {2: [1.0, 0.5], 3: [1.0, 0.5, 0.25]}  # m
CELLS = {2: [3, 2], 3: [3, 2, 2]}


def field(x, gdim):
    """A quadratic displacement (m), in Q2: its interpolation is exact."""
    if gdim == 2:
        return np.stack([x[0] * x[1] + 0.5, x[0] ** 2 - 0.3 * x[1] ** 2])
    return np.stack([x[0] * x[1] + 0.5, x[0] ** 2 - x[2], x[1] * x[2] - 0.25 * x[0] ** 2])


def agreed(failures: list) -> list:
    """Rank 0's failures on every rank (the samples are on rank 0)."""
    return COMM.bcast(failures if COMM.rank == 0 else None)


@pytest.mark.parallel
@pytest.mark.parametrize("gdim", [2, 3])
@pytest.mark.parametrize("nu", [0.3, 0.49])  # Q2 alone; Taylor-Hood (V collapsed from W)
def test_samples_of_a_known_field(gdim, nu):
    kind = dolfinx.mesh.CellType.quadrilateral if gdim == 2 else dolfinx.mesh.CellType.hexahedron
    if gdim == 2:
        mesh = dolfinx.mesh.create_rectangle(COMM, [[0, 0], BOX[2]], CELLS[2], kind)
    else:
        mesh = dolfinx.mesh.create_box(COMM, [[0, 0, 0], BOX[3]], CELLS[3], kind)
    mu, lmbda = 1.0 / (2 * (1 + nu)), nu / ((1 + nu) * (1 - 2 * nu))
    truth = Truth(
        Problem(
            mesh,
            mu,
            lmbda,
            1.0,
            0.0,
            0.0,
            "linear",
            lambda x, t: ufl.as_vector([0.0] * gdim),
            lambda V: [],
        )
    )
    assert truth.kind == ("mixed" if nu > 0.45 else "displacement")
    u = fem.Function(truth.V)
    u.interpolate(lambda x: field(x, gdim))
    owned = truth.n_owned
    run = TruthRun(
        truth.V,
        np.array([0.0, 0.5]),
        np.array([u.x.array[:owned], -2 * u.x.array[:owned]]),
        None,
        0,
        0.0,
    )
    s = store.sample(truth, run, "box")
    failures = []
    if COMM.rank == 0:
        volume = np.prod(BOX[gdim])
        cell_type = s.cell_type
        q = 3**gdim
        if len(s.vertices) != np.prod(np.array(CELLS[gdim]) + 1):
            failures.append(f"{len(s.vertices)} vertices")
        m = measures(s.vertices, s.cells, cell_type)
        # a cell with its vertices out of VTK order folds: |det J| then covers less than it
        if m.min() <= 0 or not np.isclose(m.sum(), volume, rtol=1e-12, atol=0):
            failures.append(f"measures {m.min()}, sum {m.sum()} (volume {volume})")
        if s.weights.min() <= 0 or not np.isclose(s.weights.sum(), volume, rtol=1e-12, atol=0):
            failures.append(f"weights sum {s.weights.sum()}")
        if len(s.points) != q * len(s.cells):
            failures.append(f"{len(s.points)} points for {len(s.cells)} cells")
        X = s.vertices[s.cells]  # each cell's points inside its box
        P = s.points.reshape(len(s.cells), q, gdim)
        if not (np.all(P >= X.min(axis=1)[:, None]) and np.all(P <= X.max(axis=1)[:, None])):
            failures.append("a quadrature point outside its cell")
        expected = store.canonical_cycles(boundary_facets(s.vertices, s.cells, cell_type))
        if s.boundary.shape != expected.shape or not np.array_equal(s.boundary, expected):
            failures.append("boundary facets differ from metrics.cells.boundary_facets")
        for k, scale in enumerate((1.0, -2.0)):
            at_vertices = scale * field(s.vertices.T, gdim).T
            at_points = scale * field(s.points.T, gdim).T
            if not np.allclose(s.u_vertices[k], at_vertices, rtol=0, atol=1e-14):
                failures.append(
                    f"vertices, step {k}: {np.abs(s.u_vertices[k] - at_vertices).max()}"
                )
            if not np.allclose(s.u_points[k], at_points, rtol=0, atol=1e-14):
                failures.append(f"points, step {k}: {np.abs(s.u_points[k] - at_points).max()}")
    else:
        assert s is None
    assert agreed(failures) == []


@pytest.mark.serial
def test_samples_serial_equal_two_ranks():
    one = run_script("mpi_truth_store.py", ranks=1)
    two = run_script("mpi_truth_store.py", ranks=2)
    assert one.keys() == two.keys() == {"field", "rod", "block-MP2-w0.2"}
    for case, parts in one.items():
        for name, a in parts.items():
            a, b = np.array(a), np.array(two[case][name])
            assert a.shape == b.shape, (case, name)
            if name.startswith("u_"):  # the solves' round-off (MUMPS on 1 or 2 ranks)
                scale = np.abs(a).max()
                assert np.allclose(a, b, rtol=0, atol=1e-14 * max(scale, 1.0)), (case, name)
            else:  # the mesh, its cells and facets, the points and weights: the same numbers
                assert np.array_equal(a, b), (case, name)


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return Path(COMM.bcast(str(tmp_path_factory.mktemp("cache")) if COMM.rank == 0 else None))


@pytest.mark.parallel
def test_the_cache_is_read_back_and_keyed_by_the_inputs(cache, monkeypatch):
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))
    first = store.truth_samples("rod", quick=True)
    path = store.cache_path("rod", quick=True)
    assert COMM.bcast(path.is_file() if COMM.rank == 0 else None)

    def no(*args, **kwargs):
        raise AssertionError("computed again")

    monkeypatch.setattr(store, "compute", no)
    again = store.truth_samples("rod", quick=True)
    failures = []
    if COMM.rank == 0:
        for name in ("vertices", "cells", "points", "weights", "u_vertices", "u_points"):
            if not np.array_equal(getattr(first, name), getattr(again, name)):
                failures.append(name)
        if again.inputs != store.inputs("rod", quick=True) or again.own_error != first.own_error:
            failures.append("inputs or own error")
        h = again.hierarchy
        if h["levels"] != list(store.levels_of("rod", quick=True)) or len(h["tip"]) != 3:
            failures.append(f"hierarchy {h['levels']}")
    assert agreed(failures) == []
    monkeypatch.undo()  # compute again: a cache file cut short is computed again, not an error
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))
    if COMM.rank == 0:
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    COMM.barrier()
    third = store.truth_samples("rod", quick=True)
    if COMM.rank == 0:  # the same numbers (MUMPS on 2 ranks: round-off from run to run)
        scale = np.abs(first.u_points).max()
        if not np.allclose(third.u_points, first.u_points, rtol=0, atol=1e-14 * scale):
            failures.append("computed again: other numbers")
        if store.load_cached("rod", quick=True) is None:
            failures.append("not cached again")
    assert agreed(failures) == []
    # a change of any input is another key
    keys = {store.fingerprint_of("rod", True), store.fingerprint_of("rod", False)}
    keys.add(store.fingerprint_of("rod-nh-s1", True))
    monkeypatch.setattr(store, "QUICK_STEPS", 29)
    keys.add(store.fingerprint_of("rod", True))
    monkeypatch.setitem(CASES, "rod", ("rod", "MP1", "linear", 1.0, None))
    keys.add(store.fingerprint_of("rod", True))
    monkeypatch.setattr(store, "SOURCES", store.SOURCES[:-1])
    keys.add(store.fingerprint_of("rod", True))
    assert len(keys) == 6
    assert store.cache_path("rod", True) != path


@pytest.mark.serial
def test_command_writes_the_summary_and_refuses_bad_input(cache, tmp_path, monkeypatch):
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))
    out = tmp_path / "out"
    done = tissuebench("truth", "rod", "--quick", "--out", str(out))
    assert done.returncode == 0, done.stderr[-2000:]
    text = (out / "truth.md").read_text()
    assert text.startswith("# The truth (SPEC 10) (quick check, not the truth)")
    with open(out / "truth.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["case", "level", "dofs", "time", "u_x", "u_y", "u_z"]
    assert [(r["case"], r["level"], r["time"]) for r in rows] == [
        ("rod", level, "1") for level in ("1", "2", "truth")
    ]
    samples = store.load_cached("rod", quick=True)
    if samples is not None:  # the cache the command wrote (or read): the same numbers
        tip = np.asarray(samples.hierarchy["tip"][-1])[30]
        assert np.allclose([float(rows[-1][c]) for c in ("u_x", "u_y", "u_z")], tip, rtol=1e-9)
    # a case outside CASES: one line naming the cases
    bad = tissuebench("truth", "block-MP1-w0", "--quick", "--out", str(out))
    assert bad.returncode == 2
    assert len(bad.stderr.strip().splitlines()) == 1 and "rod-nh-s1" in bad.stderr
    # a quick run never replaces a full truth.md
    full = tmp_path / "full"
    write_owned(full / "truth.md", lambda tmp: tmp.write_text("# The truth (SPEC 10)\n"))
    refused = tissuebench("truth", "rod", "--quick", "--out", str(full))
    assert refused.returncode == 2
    assert len(refused.stderr.strip().splitlines()) == 1 and "--force" in refused.stderr
    assert (full / "truth.md").read_text() == "# The truth (SPEC 10)\n"


@pytest.mark.serial  # it writes copies of the sources: one process
def test_the_cache_key_follows_the_code_not_its_text(tmp_path, monkeypatch):
    """Moving imports, editing docstrings or type hints, reformatting: the same truth, the
    same key (a rod truth costs minutes, a neo-Hookean one an hour); a changed number or
    statement: another key."""
    for name in store.SOURCES:
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text((store.PACKAGE / name).read_text())
    monkeypatch.setattr(store, "PACKAGE", tmp_path)
    before = store.code_hash()
    solver = tmp_path / "solvers/truth/solver.py"
    text = solver.read_text()
    edited = text.replace('"""', '"""An edited docstring. ', 1)
    edited = edited.replace("import time\n", "import os  # a new import\nimport time\n", 1)
    edited = edited.replace("-> None:", "-> 'None':")
    assert edited != text
    solver.write_text(edited)
    assert store.code_hash() == before
    numbers = store.SOURCES.index("solvers/materials.py")
    materials = tmp_path / store.SOURCES[numbers]
    changed = materials.read_text().replace("0.47", "0.471", 1)
    assert changed != materials.read_text()
    materials.write_text(changed)
    assert store.code_hash() != before


def test_the_report_says_what_the_smallest_jacobian_means():
    """truth.md names an inverted state (some J <= 0, SPEC 8) and, where the levels move
    apart while J falls on every finer level, the crushed material and the bound kappa of
    the neo-Hookean volumetric stress (MP3: lambda + 2 mu / 3 = 3,889 Pa); for the barrier
    law, whose volumetric stress has no such bound, not that bound."""
    from tissuebench.workflows.truth.report import jacobian_cell, jacobian_lines

    h = {
        "min_jacobian": [[1.0, 0.6], [1.0, 0.3], [1.0, 0.05]],
        "min_jacobian_at": [[10.0, 0.0, 0.0, 0.0]] * 2 + [[9.5, 0.004, 0.004, 0.246]],
    }
    assert jacobian_cell(h, 2) == "0.05 (t = 9.5 s, X = (0.004, 0.004, 0.246) m)"
    crushed = " ".join(jacobian_lines("rod-nh-s1", h, [2e-4, 6e-4]))
    assert "0.6, 0.3, 0.05" in crushed and "kappa = 3889 Pa" in crushed
    barrier = " ".join(jacobian_lines("rod-nhb-s3", h, [2e-4, 6e-4]))
    assert "0.6, 0.3, 0.05" in barrier and "grows without bound" in barrier
    assert "cannot exceed" not in barrier and "crushed further" not in barrier
    assert jacobian_lines("rod-nh-s1", h, [6e-4, 2e-4]) == []  # the levels converge: no word
    h["min_jacobian"][1] = [1.0, 0.7]  # J does not fall on every level: no word either
    assert jacobian_lines("rod-nh-s1", h, [2e-4, 6e-4]) == []
    h["min_jacobian"][2] = [1.0, -0.01]
    assert "inverted" in " ".join(jacobian_lines("rod-nh-s1", h, [6e-4, 2e-4]))


def test_time_order_is_observed_and_capped_by_the_rule():
    """q = log2(d1 / d2) of the differences step/half and half/quarter, at most the trapezoidal
    rule's 2; NaN where they do not fall; 2 where nothing depends on the step."""
    assert store.time_order(1e-4, 5e-5) == pytest.approx(1.0)
    assert store.time_order(4e-4, 1e-4) == pytest.approx(2.0)
    assert store.time_order(1e-4, 1e-6) == 2.0
    assert np.isnan(store.time_order(1e-5, 2e-5)) and np.isnan(store.time_order(1e-5, 0.0))
    assert store.time_order(0.0, 0.0) == 2.0


def test_the_needles_stop_makes_the_block_first_order_in_time():
    """The needle's velocity jumps from -0.08 m/s to 0 at t = 2 s: the block's truth is first
    order in time across it (N = 20 measured 0.99 from h to h/16), while before it (T = 1 s)
    it has the trapezoidal rule's order 2."""
    from tissuebench.solvers.truth.cases import case_truth

    truth, bench = case_truth("block-MP1-w0.2", 6)
    for steps, low, high in ((90, 0.8, 1.25), (30, 1.8, 2.3)):
        run = truth.run(bench.dt, steps)
        d1, d2 = store.time_differences(truth, run, bench.dt, 1, steps, MPI.COMM_WORLD, {})
        assert low < np.log2(d1 / d2) < high, (steps, d1, d2)


def test_the_target_is_a_fraction_of_the_truths_size():
    """SPEC 10: target = 0.2 % of the truth's E_i against rest (maximum over steps). On a box of
    volume V with u = (a t, 0, 0) at every point, E_i against rest at step i is V^(-1/3) V a t_i."""
    from tissuebench.solvers.truth.samples import TruthSamples

    steps, a = 4, 0.01
    times = np.arange(steps + 1) / 30
    V = 0.5 * 0.25 * 0.25
    u = np.zeros((steps + 1, 27, 3))
    u[:, :, 0] = a * times[:, None]
    samples = TruthSamples(
        case="rod", cell_type="hexahedron", times=times, vertices=np.zeros((8, 3)),
        cells=np.array([[0, 1, 3, 2, 4, 5, 7, 6]]), boundary=np.array([[0, 2, 3, 1]]),
        points=np.zeros((27, 3)), weights=np.full(27, V / 27),
        u_vertices=np.zeros((steps + 1, 8, 3)), u_points=u,
        own_error={"interior_error_max": 1e-6}, inputs={}, hierarchy={},
    )  # fmt: skip
    size = V ** (2 / 3) * a * times[-1]
    assert store.size_of(samples) == pytest.approx(size, rel=1e-12)
    store.judge(samples)
    assert samples.own_error["target"] == pytest.approx(0.002 * size, rel=1e-12)
    assert samples.own_error["meets_target"] is bool(1e-6 <= 0.002 * size)
    samples.own_error["interior_error_max"] = 0.5 * 0.002 * size
    store.judge(samples)
    assert samples.own_error["meets_target"] is True
    samples.own_error["interior_error_max"] = 2 * 0.002 * size
    store.judge(samples)
    assert samples.own_error["meets_target"] is False


@pytest.mark.serial  # one file written and read back
def test_a_failed_computation_is_kept_as_evidence_for_todays_inputs(tmp_path, monkeypatch):
    """store.record_failure keeps where a case failed (its level, the time of the step, the
    last state's smallest J and where) under today's inputs' key, load_failure reads it back,
    and a record written for other inputs is not read."""
    from types import SimpleNamespace

    from mpi4py import MPI

    from tissuebench.solvers.truth import store

    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path))
    truth = SimpleNamespace(
        _jacobian=lambda: (0.07, np.array([0.04, 0.001, 0.001])), t=SimpleNamespace(value=4.3)
    )
    info = {"levels": [2, 4], "wall": [1.0, 2.0], "min_jacobian": [[1.0, 0.7], [1.0, 0.2]]}
    err = RuntimeError("truth: Newton did not converge at t = 4.3 s (-6)")
    store.record_failure("rod-nhb-s2", False, 8, truth, info, err, MPI.COMM_SELF)
    got = store.load_failure("rod-nhb-s2")
    assert got is not None
    assert (got["level"], got["t"], got["smallest_J"]) == (8, 4.3, 0.07)
    assert got["levels_done_smallest_J"] == [0.7, 0.2]
    assert store.load_failure("rod-nhb-s1.75") is None
    path = store.failure_path("rod-nhb-s2")
    path.write_text(path.read_text().replace(got["fingerprint"], "another"))
    assert store.load_failure("rod-nhb-s2") is None


def test_each_stage_says_the_whole_cases_time_so_far_and_left():
    """Issue 59.5: `truth` gave per-level bars, no time left in all. Each stage's line (a
    level, the time order, the half step) now ends with the whole case's seconds so far, which
    never fall, and the time left of its estimate (or that it is past it)."""
    import re

    said: list[str] = []
    store.compute("rod", quick=True, log=said.append)
    tail = re.compile(
        r"\((\d+) s in all, (about \d+ (s|min) left|past its estimate, \d+ (s|min))\)$"
    )
    stages = [line for line in said if re.search(r"n=\d+(:| half step)", line)]
    assert len(stages) >= 3, said  # two levels, the time order, the half step
    spent = [int(tail.search(line)[1]) for line in stages if tail.search(line)]
    assert len(spent) == len(stages), stages
    assert spent == sorted(spent)
