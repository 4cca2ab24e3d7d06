"""The Python API (`import tissuebench`, workflows/api.py; issue 44): the README's "Grade from
Python" block, run as written, grades as `tissuebench compare` does.

The block is parsed out of README.md and executed verbatim in a fresh folder, so that the README
cannot go stale without this test failing. Its toy solver is our implicit's series scaled by
1.01, so E_n is 0.01 at every step (||0.01 u|| / ||u||): a number known beforehand. The same
arrays are then written by another writer (meshio's XDMF) and graded by the command line's
compare (cli.main): every number of the API's compare folder must equal the command's to
round-off, against the reference and, where its truth is cached here, against the truth. On
tetrahedra with the same nodes (its own mesh, graded across meshes) E_n is 0.01 again. The
API's folder must be a user's row for the leaderboard (rows.user_rows reads it, leaving nothing
out), the same arrays again are skipped, and other arrays over the series are refused in one
line.
"""

import re
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest

import tissuebench as tb
from tissuebench.core.errors import UserError
from tissuebench.metrics.table import METRICS
from tissuebench.workflows.cli import main as cli
from tissuebench.workflows.io.tables import read_curves

pytestmark = pytest.mark.serial  # changes the working folder; runs the command line in-process

ROOT = Path(__file__).resolve().parents[1]
HEADING = "### Grade from Python"
OUT = Path("results/leaderboard/rod-MP3/user/toy")  # the block's compare folder


def readme_block() -> str:
    """The first ```python block after the README's heading."""
    text = (ROOT / "README.md").read_text()
    assert HEADING in text, f"README.md has no section {HEADING!r}"
    section = text[text.index(HEADING) :]
    start = section.index("```python\n") + len("```python\n")
    return section[start : section.index("```", start)]


def write_with_meshio(path: Path, case, u: np.ndarray) -> None:
    """The series as meshio writes an XDMF time series: another writer than the API's."""
    import meshio

    with meshio.xdmf.TimeSeriesWriter(str(path)) as writer:
        writer.write_points_cells(case.nodes, [(case.cell_type, case.cells)])
        for t, values in zip(case.times, u, strict=True):
            writer.write_data(float(t), point_data={"displacement": values})


def numbers(folder: Path, label: str) -> tuple[dict, np.ndarray, dict]:
    """(the run's entry in summary.json, times, curves) of a compare folder."""
    import json

    summary = json.loads((folder / "summary.json").read_text())
    times, curves = read_curves(folder / "metrics.csv")
    return summary["runs"][label], times, curves[label]


def assert_same(graded: tb.Graded, folder: Path) -> None:
    """The API's numbers equal those the command wrote into `folder`, to round-off."""
    entry, times, curves = numbers(folder, graded.label)
    for key, value in graded.metrics.items():
        assert value == pytest.approx(entry[key], rel=1e-12, abs=1e-300), key
    np.testing.assert_allclose(graded.times, times, rtol=1e-15)
    for name in METRICS:
        np.testing.assert_allclose(graded.curves[name], curves[name], rtol=1e-12, atol=1e-300)
    assert graded.summary["runs"][graded.label]["wall_time_s"] == entry["wall_time_s"]


def test_the_readme_block_grades_as_compare_does(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    names: dict = {}
    exec(compile(readme_block(), "README.md (Grade from Python)", "exec"), names)
    case, u, graded = names["case"], names["u"], names["graded"]

    # the case as arrays: what the export's JSON holds
    assert case.nodes.shape == (len(case.nodes), 3) and case.cell_type == "hexahedron"
    assert list(case.node_sets) == ["clamped"] and case.truth["case"] == "rod"
    assert case.times[-1] == pytest.approx(10.0) and u.shape == (len(case.times), *case.nodes.shape)
    # the toy solver's E_n is known: 0.01 at every step after the first (u = 0 at t = 0)
    assert graded.metrics["relative_error_max"] == pytest.approx(0.01, rel=1e-12)
    assert np.allclose(graded.curves["relative_error"][1:], 0.01, rtol=1e-12)
    assert graded.metrics["interior_error_max"] > 0 and graded.reference_diverged_step is None
    assert graded.series == OUT.parent / "toy.xdmf" and (OUT / "summary.json").is_file()
    assert "E_i interior_error: max" in graded.lines["interior_error"]

    # the command line on the same arrays written by meshio: the same numbers
    write_with_meshio(tmp_path / "mine.xdmf", case, u)
    argv = ["mine.xdmf", "--label", "toy", "--wall-time", "0.5"]
    assert cli(["compare", "rod.reference.xdmf", *argv, "--out", "cli"]) == 0
    assert_same(graded, tmp_path / "cli")

    # the folder is a user's row of its case for the leaderboard, with nothing left out
    from tissuebench.workflows.leaderboard.rows import BOARDS, user_rows

    board = next(b for b in BOARDS if b.name == "rod-MP3")
    rows, skipped = user_rows(board, tmp_path / OUT.parent)
    assert skipped == [] and [r.label for r in rows] == ["toy"]
    assert Path(rows[0].series) == (tmp_path / graded.series).resolve()
    assert rows[0].wall_time_s == 0.5

    # its own mesh: the same nodes and values on tetrahedra (six per hexahedron about its 0-6
    # diagonal, conforming across the grid's faces); E_n is taken at the reference's nodes,
    # where the candidate is its nodal values again: 0.01 on any mesh with those nodes
    split = [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
    tets = case.cells[:, split].reshape(-1, 4)
    own = tb.grade("rod.reference.xdmf", case.nodes, tets, "tetra", case.times, u, out="tets")
    assert own.summary["candidate"]["mesh"]["cell_type"] == "tetrahedron"
    assert own.metrics["relative_error_max"] == pytest.approx(0.01, rel=1e-9)

    # the same arrays again: the series kept, compare skips the complete folder
    again = tb.grade(
        "rod.reference.xdmf", case.nodes, case.cells, case.cell_type, case.times, u, out=OUT,
        label="toy", wall_time=0.5,
    )  # fmt: skip
    assert "skipped" in again.lines and again.metrics == graded.metrics
    # other arrays over that series: refused in one line, the folder left as it was
    with pytest.raises(UserError, match="holds another series: force=True replaces it"):
        tb.grade(
            "rod.reference.xdmf", case.nodes, case.cells, case.cell_type, case.times, 1.02 * u,
            out=OUT, label="toy", wall_time=0.5,
        )  # fmt: skip
    assert numbers(OUT, "toy")[0] == numbers(tmp_path / "cli", "toy")[0]

    # against the truth, where it is cached here (computing it is `tissuebench truth rod`)
    from tissuebench.solvers.truth.store import is_cached

    if not is_cached("rod", comm=MPI.COMM_SELF):
        pytest.skip("the truth rod is not cached here: graded against the reference only")
    truth = tb.grade(
        "truth:rod", case.nodes, case.cells, case.cell_type, case.times, u, out="toy-truth",
        series="toy.xdmf", label="toy", wall_time=0.5,
    )  # fmt: skip
    assert truth.summary["truth"]["case"] == "rod"
    assert cli(["compare", "truth:rod", *argv, "--out", "cli-truth"]) == 0
    assert_same(truth, tmp_path / "cli-truth")
    capsys.readouterr()


def test_bad_arrays_are_refused_in_one_line(tmp_path):
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # m
    cells = np.array([[0, 1, 2, 3]])
    times = np.array([0.0, 0.1])  # s
    u = np.zeros((2, 4, 2))  # m
    cases = [
        (dict(displacements=np.zeros((2, 8))), "expected (steps, n, d)"),
        (dict(displacements=np.zeros((3, 4, 2))), "3 steps of field 'displacement', 2 times"),
        (dict(cells=np.array([[0, 1, 2, 7]])), "cells refer to points outside 0..3"),
        (dict(cell_type="pyramid"), "only first-order triangles, quadrilaterals"),
        (dict(times=np.array([0.1, 0.0])), "time stamps are not increasing"),
        (dict(label=" x"), "leading or trailing spaces"),
        (dict(wall_time=-1.0), "--wall-time must be a finite number"),
        (dict(series=tmp_path / "mine.vtu"), "the series is written as XDMF"),
        # the fourth red team: each was graded as something else, or ended in a traceback
        (dict(points=points.astype(str).astype(object)), "points: objects"),
        (dict(displacements=u + 0j), "displacements: complex numbers"),
        (dict(points=[[10**400, 0], [1, 0], [1, 1], [0, 1]]), "points: objects"),
        (dict(cells=cells + 0.5), "cells: a node index is not a whole number"),
        (dict(times=times[:, None]), "times of shape (2, 1): expected (steps,), s"),
    ]
    for change, said in cases:
        given = dict(
            points=points, cells=cells, cell_type="quadrilateral", times=times, displacements=u
        )
        given |= change
        options = {k: given.pop(k) for k in ("label", "wall_time", "series") if k in given}
        with pytest.raises(UserError, match=re.escape(said)) as raised:
            tb.grade("ref.xdmf", **given, out=tmp_path / "out", **options)
        assert "\n" not in str(raised.value), change
    assert not (tmp_path / "out").exists()  # nothing written for bad input
    notes = tmp_path / "notes"
    notes.mkdir()
    (notes / "todo.txt").write_text("mine")
    a_file = tmp_path / "afile"
    a_file.write_text("mine")
    for out, said in ((notes, "not a compare folder of ours"), (a_file, "not a folder")):
        given = dict(points=points, cells=cells, cell_type="quadrilateral", times=times)
        with pytest.raises(UserError, match=said):
            tb.grade("ref.xdmf", **given, displacements=u, out=out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile", "notes"]  # no series beside
    assert [p.name for p in notes.iterdir()] == ["todo.txt"]


def test_bad_export_options_are_refused_in_one_line(tmp_path):
    cases = [
        (dict(benchmark="liver"), "unknown benchmark 'liver'"),
        (dict(out=tmp_path / "rod.vtu"), "export_case writes a .json"),
        (dict(foo=1.0), "unknown option 'foo'"),
        (dict(needle_width=0.1), "rod takes no option 'needle_width' (its options: load_scale)"),
        (dict(material="MP9"), "unknown material 'MP9'"),
        (dict(dt=-1.0), "expected a positive number of seconds"),
    ]
    for change, said in cases:
        given = {"benchmark": "rod", "out": tmp_path / "rod.json"} | change
        with pytest.raises(UserError, match=re.escape(said)) as raised:
            tb.export_case(given.pop("benchmark"), given.pop("out"), **given)
        assert "\n" not in str(raised.value), change
    assert list(tmp_path.iterdir()) == []  # nothing written for bad input
