"""A user's row on its own mesh gets its full error budget (SPEC 10, issue 36): the leaderboard runs
our implicit on the mesh read from the user's series (workflows/leaderboard/user_mesh.py, posed by
meshes/regions.py) and grades it against the truth (discretisation) and the user's run against it
(algorithm). Where it cannot, the budget says why in one line.

The user here is our own implicit on the rod's tetrahedron grid (P1), graded by compare into
the case's user/ folder: then the algorithm part is 0 to round-off and the discretisation part
is the total (a physics fact: the same discrete model, the same mesh). The case is the linear
rod to T = 1 s (30 steps) against the quick rod truth (levels n = 1, 2, 4; about 5 s), computed
in a cache of the test's own; the leaderboard runs our algorithms on the hexahedra only (no
simplex rows, no outside simulator), as tests/test_recipe.py's tiny record does.
"""

import argparse
import json
import math

from mpi4py import MPI

import numpy as np
import pytest

from tissuebench.meshes import get_entry
from tissuebench.meshes.gmshio import MeshError
from tissuebench.meshes.posed import on_mesh, posing
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.compare.posing import geometry
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard import runs
from tissuebench.workflows.leaderboard.rows import Board
from tissuebench.workflows.leaderboard.user_mesh import implicit_on
from tissuebench.workflows.run.case import model_case, run_case

H, STEPS = 1 / 30, 30  # s: the case's time step and steps (T = 1 s, the quick truth's)
LABEL = "implicit-on-tetrahedra"
# a case of the test's own: the rows of ours of a committed case (rod-MP3) are rendered as
# committed (record.with_committed_rows), not as a test's record holds them
CASE = "rod-MP3-1s"
PARTS = ("total", "discretisation", "algorithm", "model")


def board() -> Board:
    """The linear rod to T = 1 s, ours only, against the (quick) rod truth."""
    return Board(
        CASE,
        "rod",
        "MP3",
        "linear",
        simulators=(),
        end_time=1.0,
        truth="rod",
        description="rod-MP3 to T = 1 s, ours on its hexahedra",
    )


def render(out, rerun=None) -> None:
    """`tissuebench leaderboard --out OUT [--rerun]` with the one case."""
    args = argparse.Namespace(out=out, solver="direct", petsc="", force=True, rerun=rerun)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(leaderboard, "BOARDS", [board()])
        patch.setattr(runs, "simplex_rows", lambda *args, **kwargs: [])
        assert leaderboard.main(args) == 0


@pytest.fixture(scope="module")
def board_with_user(tmp_path_factory):
    """The leaderboard folder with our runs and a user's row (our implicit on the tetrahedron
    grid, compared into OUT/leaderboard/rod-MP3/user/mine), rendered against the quick rod
    truth: (out, the record's user row), with the truth in place while the module runs."""
    from tissuebench.solvers.truth import store

    tmp = tmp_path_factory.mktemp("user-budget")
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("TISSUEBENCH_CACHE", str(tmp / "cache"))
        truth = store.truth_samples("rod", quick=True, comm=MPI.COMM_SELF)
        patch.setattr(
            store,
            "load_cached",
            lambda case, quick=False, comm=MPI.COMM_WORLD: truth if case == "rod" else None,
        )
        out = tmp / "results"
        render(out, rerun=[])  # our runs, the record
        case = model_case(
            "mine",
            "rod",
            "MP3",
            ["implicit"],
            ["linear"],
            "implicit",
            options={"cell": "tetrahedron"},
            end_time=1.0,
        )
        run_case(case, tmp / "tetrahedra", MPI.COMM_SELF, log=lambda line: None)
        compare(
            out / "leaderboard" / CASE / "ours" / "implicit.xdmf",
            tmp / "tetrahedra" / "implicit.xdmf",
            out / "leaderboard" / CASE / "user" / "mine",
            comm=MPI.COMM_SELF,
            label=LABEL,
            wall_time=1.0,
        )
        render(out)  # from the record, with the user's row
        yield out, user_row(out)


def user_row(out) -> dict:
    """The user's row as the record leaderboard.json holds it."""
    record = json.loads((out / "leaderboard.json").read_text())
    rows = [r for c in record["cases"] for r in c["rows"] if r["label"] == LABEL]
    assert len(rows) == 1, f"{len(rows)} rows of {LABEL} in the record"
    return rows[0]


@pytest.mark.serial
def test_a_user_row_on_p1_tetrahedra_shows_all_four_budget_parts(board_with_user):
    out, row = board_with_user
    assert row["source"] == "user" and row["mesh"].startswith("tetrahedra")
    b = row["budget"]
    for part in PARTS:
        assert isinstance(b.get(part), float) and math.isfinite(b[part]), (part, b)
    assert "run here on its mesh" in b["discretisation_how"]
    # the user's run is our implicit on that very mesh: nothing is lost to the algorithm, and
    # the whole loss against the truth is the mesh's (the discretisation part)
    assert 0 < b["total"] < 1e-2  # m^3
    assert b["algorithm"] <= 1e-9 * b["total"]
    assert b["discretisation"] == pytest.approx(b["total"], rel=1e-9)
    assert b["model"] == 0.0 and b["model_how"].startswith("none")
    # the page's budget chart has the user's row, whose tooltip shows the four numbers
    import html
    import re

    text = (out / "leaderboard" / "index.html").read_text()
    tips = [
        json.loads(html.unescape(t))
        for t in re.findall(r'class="brow f"[^>]*data-tip="([^"]*)"', text)
    ]
    lines = next(t for t in tips if t[0] == LABEL)
    assert "run here" in " ".join(lines)
    for part, line in zip(PARTS, lines[1:], strict=True):
        assert re.match(rf"{part}: \d", line), line


@pytest.mark.serial
def test_a_rendering_from_the_record_keeps_the_budget_without_running_again(board_with_user):
    out, before = board_with_user

    def refused(*args, **kwargs):
        raise AssertionError("our implicit ran again on the user's mesh")

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr("tissuebench.workflows.leaderboard.user_mesh.implicit_on", refused)
        render(out)
    assert user_row(out)["budget"] == before["budget"]


@pytest.mark.serial
def test_our_implicit_on_our_own_series_mesh_is_our_run_on_it(board_with_user):
    """Q1 hexahedra read in VTK order, made a DOLFINx mesh and posed by the regions: our
    implicit on it is the run that wrote the series (the cell ordering and the clamped nodes
    are right)."""
    out, _ = board_with_user
    series = read_series(out / "leaderboard" / CASE / "ours" / "implicit.xdmf")
    assert series.cell_type == "hexahedron"
    ours = implicit_on(series, "rod", "MP3", "linear", {}, H, STEPS)
    assert np.array_equal(ours.points, series.points) and np.array_equal(ours.cells, series.cells)
    scale = max(np.abs(u).max() for u in series.displacements)
    for mine, theirs in zip(ours.displacements, series.displacements, strict=True):
        assert np.abs(mine - theirs).max() <= 1e-10 * scale


def test_the_regions_are_the_exports_and_a_mesh_without_the_needle_is_refused():
    """Each benchmark's regions state the export's predicates; a block mesh with no node at the
    needle (1, 0.5) cannot pose it, said in one line."""
    import dolfinx.mesh

    for name, options in (("rod", {}), ("block", {}), ("block", {"needle_width": 0.2})):
        assert get_entry(name).posing is not None
        _, posed = posing(name, **options)
        assert {r.name: r.predicate for r in posed.regions} == geometry(name, options)["regions"]
    mesh = dolfinx.mesh.create_unit_square(
        MPI.COMM_WORLD, 3, 3, dolfinx.mesh.CellType.quadrilateral
    )
    with pytest.raises(MeshError) as err:
        on_mesh("block", mesh)
    assert "needle" in str(err.value) and "\n" not in str(err.value)
    bench = on_mesh("block", mesh, needle_width=0.4)  # 0.5 +- 0.2 holds y = 1/3 and 2/3
    assert [c.name for c in bench.constraints] == ["needle", "left", "bottom", "top"]
    found = MPI.COMM_WORLD.allreduce(
        int(np.sum(bench.constraints[0].entities < mesh.topology.index_map(0).size_local))
    )
    assert found == 2


@pytest.mark.serial
def test_our_implicit_on_our_quadrilaterals_is_our_run_on_them(tmp_path):
    """The same in 2D: the block's 4 x 4 quadrilaterals (the needle pushing), 5 steps."""
    case = model_case(
        "block-4",
        "block",
        "MP1",
        ["implicit"],
        ["linear"],
        "implicit",
        mesh_size=4,
        end_time=5 * H,
    )
    run_case(case, tmp_path / "block", MPI.COMM_SELF, log=lambda line: None)
    series = read_series(tmp_path / "block" / "implicit.xdmf")
    assert series.cell_type == "quadrilateral"
    ours = implicit_on(series, "block", "MP1", "linear", {}, H, 5)
    scale = max(np.abs(u).max() for u in series.displacements)
    assert scale > 0.01  # m: the needle moved 0.08 m/s for 5 h
    for mine, theirs in zip(ours.displacements, series.displacements, strict=True):
        assert np.abs(mine - theirs).max() <= 1e-10 * scale


@pytest.mark.serial
def test_where_our_implicit_cannot_run_the_budget_says_why_in_one_line(tmp_path):
    """A user's block on 3 x 3 quadrilaterals has no node at the point needle (1, 0.5): no part
    beyond the total, and one line that names the region."""
    from tissuebench.workflows.io.xdmf import write_series
    from tissuebench.workflows.leaderboard.rows import Row, error_keys
    from tissuebench.workflows.leaderboard.user_mesh import budget_on_mesh

    x = np.linspace(0.0, 1.0, 4)
    points = np.array([(a, b, 0.0) for b in x for a in x])
    cells = np.array(
        [
            (4 * j + i, 4 * j + i + 1, 4 * j + i + 5, 4 * j + i + 4)
            for j in range(3)
            for i in range(3)
        ]
    )
    path = tmp_path / "three.xdmf"
    zeros = np.zeros((STEPS + 1, len(points), 3))
    write_series(
        path, ((points, cells, "quadrilateral"), {"displacement": zeros}), np.arange(STEPS + 1) * H
    )
    board = Board("block-MP1", "block", "MP1", "linear", end_time=1.0, truth="block-MP1-w0.2")
    row = Row(
        "block-MP1",
        "three",
        "user",
        "",
        "quadrilaterals: 9 cells, 16 nodes",
        32,
        "ok",
        None,
        dict.fromkeys(error_keys()),
        1.0,
        1.0,
        "reported by the user",
        series=str(path),
    )
    parts = budget_on_mesh(board, row, truth=None)
    assert [parts[p] for p in PARTS[1:]] == [None, None, None]
    why = parts["discretisation_how"]
    assert "needle" in why and "x = 1 and y = 0.5" in why and "\n" not in why, why
