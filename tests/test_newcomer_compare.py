"""A newcomer's compare (issue 36): the candidate's path recorded so that the leaderboard finds
its series from any working folder; the metrics printed as E_n, E_s, E_i with their units and
--wall-time defined; a symbolic-link loop refused in one line (exit 2); a diverged reference
said in one line on stderr (exit 3); the memory checked before anything is read, and the
series held in one copy."""

import csv
import json
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem
from dolfinx import mesh as dmesh
from helpers import tissuebench
from test_compare import mesh_data, write_meshio_xdmf

from tissuebench.metrics import InputError
from tissuebench.metrics.series import series_of
from tissuebench.workflows.compare.grading import candidate_file, compare
from tissuebench.workflows.io import limits
from tissuebench.workflows.io.manifest import seal
from tissuebench.workflows.io.series import read_series, series_size
from tissuebench.workflows.leaderboard import rows as ranking

pytestmark = pytest.mark.serial  # files written in serial, command lines run as subprocesses

H = 1 / 30  # the block's time step (s)
TIMES = [k * H for k in range(7)]  # 6 steps to T = 0.2 s
# the block's case at N = 4 and T = 0.2 s, with a truth (SPEC 10)
BOARD = ranking.Board("block-tiny", "block", "MP1", "linear", simulators=(), mesh_size=4,
                      end_time=0.2, truth="block-MP1-w0.2")  # fmt: skip


def block_series(folder: Path, huge: float | None = None, at: int = 2) -> dict[str, Path]:
    """A reference and a candidate on the unit square's 4 x 4 quadrilaterals (25 nodes) over
    TIMES, in `folder`; with `huge`, a third reference whose displacement is `huge` (m) at
    every node from step `at` on."""
    mesh = dmesh.create_unit_square(MPI.COMM_SELF, 4, 4, dmesh.CellType.quadrilateral)
    V = fem.functionspace(mesh, ("Lagrange", 1, (2,)))
    points, cells, cell_type = mesh_data(V)
    X = points[:, :2]
    ref = [t * np.c_[0.1 * X[:, 1], -0.05 * X[:, 0] ** 2] for t in TIMES]
    cand = [u * 1.1 for u in ref]
    folder.mkdir(parents=True, exist_ok=True)
    files = {"reference": folder / "ref.xdmf", "candidate": folder / "cand.xdmf"}
    write_meshio_xdmf(files["reference"], points, cells, cell_type, ref, TIMES)
    write_meshio_xdmf(files["candidate"], points, cells, cell_type, cand, TIMES)
    if huge is not None:
        blown = [u if k < at else np.full_like(u, huge) for k, u in enumerate(ref)]
        files["huge"] = folder / "huge.xdmf"
        write_meshio_xdmf(files["huge"], points, cells, cell_type, blown, TIMES)
    return files


def test_the_leaderboard_finds_the_candidate_from_any_folder(tmp_path, monkeypatch):
    """compare run with relative paths records the candidate's absolute path; the
    leaderboard's reading of the user row, from another working folder, finds the series."""
    work = tmp_path / "work"
    block_series(work)
    out = tmp_path / "results" / "block-tiny" / "user" / "mine"
    monkeypatch.chdir(work)
    compare("ref.xdmf", "cand.xdmf", out, label="mine", wall_time=2.5, comm=MPI.COMM_SELF)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["candidate"]["file"] == str((work / "cand.xdmf").resolve())
    # graded as if against the case's truth (the file reference has no case of its own)
    summary["reference"]["fingerprint"].update(source="truth", truth=BOARD.truth)
    (out / "summary.json").write_text(json.dumps(summary))
    seal(out)  # as compare against the truth would have written it

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    rows, skipped = ranking.user_rows(BOARD, out.parent)
    assert skipped == [] and [r.label for r in rows] == ["mine"]
    series = Path(rows[0].series)
    assert series.is_absolute() and series.is_file()  # the leaderboard's test of the row
    assert len(read_series(series, rows[0].series_field).times) == len(TIMES)
    assert rows[0].wall_time_s == 2.5 and rows[0].cost == pytest.approx(2.5 / 0.2)


def test_an_older_relative_candidate_path_is_taken_from_the_compare_folder(tmp_path):
    """A summary.json of an older compare records the candidate as typed: its absolute path
    is the one its inputs record, else the path relative to the compare folder."""
    folder = tmp_path / "user" / "old"
    summary = {"candidate": {"file": "cand.xdmf"}, "inputs": {"candidate": {"file": "/a/c.xdmf"}}}
    assert candidate_file(summary, folder) == "/a/c.xdmf"
    del summary["inputs"]
    assert candidate_file(summary, folder) == str(folder.resolve() / "cand.xdmf")
    assert candidate_file({"candidate": {"file": "/b/c.xdmf"}}, folder) == "/b/c.xdmf"
    assert candidate_file({"candidate": {}}, folder) is None
    # the leaderboard's rows take it so (ranking.candidate_of with the compare folder)
    row = ranking.candidate_of({"candidate": {"file": "cand.xdmf", "field": "u"}}, folder)
    assert row == {
        "series": str(folder.resolve() / "cand.xdmf"),
        "series_field": "u",
        "model": None,
    }


def test_metrics_are_named_with_their_units(tmp_path):
    """The printed lines name E_n, E_s (dimensionless) and E_i (m^2 on a 2D body);
    summary.json states each metric's symbol and unit beside the keys that other code reads;
    --wall-time is defined as the total wall seconds, setup included."""
    files = block_series(tmp_path)
    lines = compare(files["reference"], files["candidate"], tmp_path / "out", comm=MPI.COMM_SELF)
    assert lines["relative_error"].startswith("E_n relative_error: max ")
    # its maximum's step is said (a user's third day: E_n is large where |u| is tiny)
    assert "(dimensionless; steps 1..6, the max at step 3, cand)" in lines["relative_error"]
    assert lines["surface_error"].startswith("E_s surface_error: max ")
    assert "dimensionless" in lines["surface_error"]
    peak, mean = (
        lines["interior_error"].removeprefix("E_i interior_error: max ").split(" (")[0].split(", ")
    )
    assert peak.endswith(" m^2") and mean.startswith("time-mean ") and mean.endswith(" m^2")
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["metrics"]["relative_error"] == {"symbol": "E_n", "unit": "dimensionless"}
    assert summary["metrics"]["surface_error"] == {"symbol": "E_s", "unit": "dimensionless"}
    assert summary["metrics"]["interior_error"] == {"symbol": "E_i", "unit": "m^2"}
    assert float(peak.split()[0]) == pytest.approx(summary["runs"]["cand"]["interior_error_max"],
                                                   rel=1e-3)  # fmt: skip

    from tissuebench.workflows.cli import parser

    text = " ".join(parser()._subparsers._group_actions[0].choices["compare"].format_help().split())
    assert "wall time in seconds from its posed problem to its last step, set-up included" in text
    assert "divides it by the simulated time" in text
    assert "3 the reference diverged" in text


def test_a_symbolic_link_loop_is_refused_in_one_line(tmp_path):
    """loop1.xdmf -> loop2.xdmf -> loop1.xdmf, as the candidate or the reference: one line on
    stderr naming it, exit status 2, nothing written."""
    files = block_series(tmp_path)
    (tmp_path / "loop1.xdmf").symlink_to("loop2.xdmf")
    (tmp_path / "loop2.xdmf").symlink_to("loop1.xdmf")
    for n, (reference, candidate) in enumerate(
        [
            (files["reference"], tmp_path / "loop1.xdmf"),
            (tmp_path / "loop2.xdmf", files["candidate"]),
        ]
    ):
        out = tmp_path / f"out{n}"
        r = tissuebench("compare", reference, candidate, "--out", out)
        loop = candidate if n == 0 else reference
        assert r.returncode == 2, r.stderr[-2000:]
        assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
        assert r.stderr.startswith(f"tissuebench compare: error: {loop}: a symbolic-link loop")
        assert not out.exists()
    with pytest.raises(InputError, match="symbolic-link loop"):
        read_series(tmp_path / "loop1.xdmf")


def statuses(path: Path) -> list[str]:
    with open(path) as f:
        return [row["status"] for row in csv.DictReader(f)]


def test_a_diverged_reference_is_said_with_exit_status_3(tmp_path):
    """A reference of 1e300 m from step 2 (SPEC 3: beyond 100 x the extent) and one of NaN:
    one line on stderr naming the step and the value, exit status 3, the results written with
    status "reference diverged"; the same again (skipped) says it again."""
    files = block_series(tmp_path, huge=1e300)
    out = tmp_path / "huge"
    for _ in range(2):  # graded, then skipped as the same inputs
        r = tissuebench("compare", files["huge"], files["candidate"], "--out", out)
        assert r.returncode == 3, r.stderr[-2000:]
        assert r.stderr.count("\n") == 1
        line = r.stderr
        assert line.startswith(
            "tissuebench compare: the reference diverged at step 2 (t = 0.0666667 s): "
        )
        assert "largest nodal displacement 1.41e+300 exceeds 100 x" in line
        assert "(exit status 3)" in line
    assert statuses(out / "metrics.csv") == ["ok"] * 2 + ["reference diverged"] * 5

    nan = block_series(tmp_path / "nan", huge=float("nan"), at=4)
    r = tissuebench("compare", nan["huge"], nan["candidate"], "--out", tmp_path / "nan-out")
    assert r.returncode == 3 and r.stderr.count("\n") == 1
    assert "the reference diverged at step 4 (t = 0.133333 s): non-finite displacement" in r.stderr
    good = tissuebench("compare", files["reference"], files["candidate"], "--out", tmp_path / "ok")
    assert good.returncode == 0 and good.stderr == ""


def test_memory_is_checked_before_reading(tmp_path, monkeypatch):
    """The estimate from the datasets' shapes (no data read) is the series' float64 values
    and mesh; series that do not fit in the available memory are refused in one line before
    anything is read or written."""
    files = block_series(tmp_path)
    size, nodes, steps = series_size(files["candidate"])
    assert (nodes, steps) == (25, 7)
    # the values as read (3 columns, float64, each step read before it is kept with 2), the
    # points (2 columns) and cells, in bytes
    assert size == 8 * (7 * 25 * 3 + 25 * 2 + 16 * 4)
    both = 2 * size

    def read_nothing(*args):
        raise AssertionError("a series was read")

    monkeypatch.setattr(limits, "available_memory", lambda: both - 1.0)
    monkeypatch.setattr("tissuebench.workflows.io.series.read_series", read_nothing)
    with pytest.raises(InputError) as refused:
        compare(files["reference"], files["candidate"], tmp_path / "out", comm=MPI.COMM_SELF)
    line = str(refused.value)
    assert "\n" not in line and line.startswith(
        f"reading the series needs at least {both / 1e9:.3g} GB"
    )
    assert f"{files['candidate']}: 25 nodes x 7 steps" in line and "is available" in line
    assert not (tmp_path / "out").exists()
    monkeypatch.undo()
    monkeypatch.setattr(limits, "available_memory", lambda: both)  # just enough: graded
    compare(files["reference"], files["candidate"], tmp_path / "out", comm=MPI.COMM_SELF)
    assert (tmp_path / "out" / "summary.json").is_file()


def test_a_series_is_held_once():
    """series_of keeps float64 steps as they are read (no copy) and releases each step of the
    list it is given once converted, so that the peak stays near one copy of the data."""
    points = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    values = [t * np.ones((4, 3)) for t in (0.0, 0.1, 0.2)]
    given = list(values)
    s = series_of(Path("x.xdmf"), "displacement", points, [[0, 1, 2, 3]], "tetra",
                  [0.0, 0.1, 0.2], given)  # fmt: skip
    assert given == [None, None, None]
    assert all(u is v for u, v in zip(s.displacements, values, strict=True))


def test_reading_holds_one_copy(tmp_path):
    """A 3D series read from XDMF peaks at one copy of its values (the mesh's checks aside),
    where it held two before (the steps as read, and their float64 copies)."""
    import tracemalloc

    n = 11  # 10 x 10 x 10 hexahedra of the unit cube, 1331 nodes, 120 steps
    g = np.linspace(0, 1, n)
    points = np.array(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    i = np.arange(n**3).reshape(n, n, n)
    corners = [
        (0, 0, 0),
        (1, 0, 0),
        (1, 1, 0),
        (0, 1, 0),
        (0, 0, 1),
        (1, 0, 1),
        (1, 1, 1),
        (0, 1, 1),
    ]
    cells = np.stack(
        [i[a : n - 1 + a, b : n - 1 + b, c : n - 1 + c].ravel() for a, b, c in corners], axis=1
    )
    times = [0.01 * k for k in range(120)]
    path = tmp_path / "cube.xdmf"
    write_meshio_xdmf(path, points, cells, "hexahedron", [t * points for t in times], times)
    tracemalloc.start()
    try:
        series = read_series(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    data = sum(u.nbytes for u in series.displacements)
    assert data == 120 * 1331 * 3 * 8
    assert peak < 1.35 * data, peak / data
    assert series_size(path)[0] == pytest.approx(data + 8 * (1331 * 3 + 1000 * 8))
