"""The leaderboard as a record (issue 26): `tissuebench leaderboard` renders from
OUT/leaderboard.json and grades only the users' compare folders; `--rerun CASE` re-times that
case alone; a user's folder is taken only under the case it was graded against. Two tiny cases
of ours (the rod at n = 1 and n = 2, 0.2 s, no outside simulator). The checks are against
things independent of the record: a user's run that is one of our recorded runs must get that
run's grades, its mesh must be the one its series holds, its Pareto flag must follow the
definition, and a rerun must re-time (new wall times) only the case it names."""

import argparse
import csv
import json
import os
import shutil

import pytest
from helpers import tissuebench

from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard.rows import Board

pytestmark = pytest.mark.serial  # each test drives the whole command on rank 0's files

TINY = dict(simulators=(), end_time=0.2)


def boards():
    return [
        Board("rod-a", "rod", "MP3", "linear", mesh_size=1, description="rod, n = 1", **TINY),
        Board("rod-b", "rod", "MP3", "linear", mesh_size=2, description="rod, n = 2", **TINY),
    ]


def run(out, monkeypatch, rerun=None):
    monkeypatch.setattr(leaderboard, "BOARDS", boards())
    args = argparse.Namespace(out=out, solver="direct", petsc="", force=False, rerun=rerun)
    return leaderboard.main(args)


def table(out):
    with open(out / "leaderboard.csv", newline="") as f:
        return list(csv.DictReader(f))


def record_rows(out, case):
    doc = json.loads((out / "leaderboard.json").read_text())
    return next(c["rows"] for c in doc["cases"] if c["board"]["name"] == case)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A leaderboard of the two cases, rerun and timed (written once for the module)."""
    out = tmp_path_factory.mktemp("board") / "results"
    with pytest.MonkeyPatch.context() as mp:
        assert run(out, mp, rerun=[]) == 0
    return out


def copy(recorded, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(recorded, out)
    return out


def test_no_record_says_how_to_make_one(tmp_path, monkeypatch):
    from tissuebench.workflows.leaderboard import record

    monkeypatch.setattr(record, "clone_results", lambda: None)  # no clone's record either
    with pytest.raises(leaderboard.LeaderboardError) as err:
        run(tmp_path / "new", monkeypatch)
    assert "--rerun" in str(err.value) and "\n" not in str(err.value)
    assert "--results DIR" in str(err.value)
    with pytest.raises(leaderboard.LeaderboardError, match="no such case; name some of rod-a"):
        run(tmp_path / "new", monkeypatch, rerun=["rod-x"])


def test_the_record_renders_what_the_run_wrote(recorded, tmp_path, monkeypatch):
    """Rendering from the record alone writes the same md, csv and record, byte for byte; each
    Row and Board of the record reads back with every field."""
    out = copy(recorded, tmp_path)
    before = {n: (out / n).read_bytes() for n in leaderboard.OWNED}
    assert run(out, monkeypatch) == 0
    for name in leaderboard.OWNED:
        assert (out / name).read_bytes() == before[name], name
    b, rows, notes = leaderboard.read_record(out)
    assert [x.name for x in b] == ["rod-a", "rod-b"] and b[0].session
    again = leaderboard.record_of(b, rows, notes)
    assert json.dumps(again, indent=1) + "\n" == before["leaderboard.json"].decode()
    assert {r["label"] for r in table(out)} >= {"implicit", "explicit-lumped"}


def test_a_user_row_joins_without_a_rerun(recorded, tmp_path, monkeypatch):
    """Our implicit on the tetrahedron grid, graded by compare as a user's run: its row has the
    grades the run has in the record (graded there by the leaderboard itself), its mesh and
    dofs as the series holds them, its cost per dof, and a Pareto flag by the definition;
    every other row is as recorded (their Pareto flags aside)."""
    out = copy(recorded, tmp_path)
    folder = out / "leaderboard" / "rod-a"
    tets = folder / "ours-tetrahedron-grid" / "implicit.xdmf"
    compare(folder / "ours" / "implicit.xdmf", tets, folder / "user" / "mine",
            label="my-tets", wall_time=0.05)  # fmt: skip
    before = {(r["case"], r["label"]): r for r in table(out)}
    figures = {c: (out / "leaderboard" / f"{c}.png").read_bytes() for c in ("rod-a", "rod-b")}
    assert run(out, monkeypatch) == 0
    assert (out / "leaderboard" / "rod-a.png").read_bytes() != figures["rod-a"]  # redrawn
    assert (out / "leaderboard" / "rod-b.png").read_bytes() == figures["rod-b"]
    rows = table(out)
    mine = next(r for r in rows if r["label"] == "my-tets")
    ours = before[("rod-a", "implicit (tetrahedron grid)")]
    for key in ("interior_error_mean", "interior_error_max", "relative_error_max"):
        assert float(mine[key]) == pytest.approx(float(ours[key]), rel=1e-12), key
    # the rod at n = 1: 2 x 1 x 1 hexahedra, 3 x 2 x 2 nodes, six tetrahedra per hexahedron
    assert mine["mesh"] == "tetrahedra: 12 cells, 12 nodes" and mine["dofs"] == "36"
    cost = 0.05 / 0.2
    assert float(mine["us_per_dof_per_simulated_s"]) == pytest.approx(1e6 * cost / 36)
    done = [r for r in rows if r["case"] == "rod-a" and r["status"] == "ok"]
    done = [r for r in done if r["reference"] == "False"]
    points = [(float(r["wall_per_simulated_s"]), float(r["interior_error_mean"])) for r in done]
    c, e = cost, float(mine["interior_error_mean"])
    dominated = any(c2 <= c and e2 <= e and (c2, e2) != (c, e) for c2, e2 in points)
    assert (mine["pareto_mean"] == "True") == (not dominated)
    for r in rows:
        if r["label"] != "my-tets":
            old = before[(r["case"], r["label"])]
            same = [k for k in r if not k.startswith("pareto")]
            assert {k: r[k] for k in same} == {k: old[k] for k in same}, r["label"]
    text = (out / "leaderboard.md").read_text()
    assert "my-tets" in text and "tetrahedra: 12 cells, 12 nodes, 36" in text
    written = {n: (out / n).read_bytes() for n in leaderboard.OWNED}
    assert run(out, monkeypatch) == 0  # the user's row now in the record: read again, the same
    assert all((out / n).read_bytes() == written[n] for n in leaderboard.OWNED)


def test_rerun_of_one_case_keeps_the_others(recorded, tmp_path, monkeypatch):
    """--rerun rod-a re-times rod-a (new wall times) and keeps rod-b's recorded rows and its
    section of leaderboard.md byte for byte."""
    out = copy(recorded, tmp_path)
    section = (out / "leaderboard.md").read_text().split("## rod-b")[1]
    a, b = record_rows(out, "rod-a"), record_rows(out, "rod-b")
    assert run(out, monkeypatch, rerun=["rod-a"]) == 0
    assert json.dumps(record_rows(out, "rod-b")) == json.dumps(b)
    assert (out / "leaderboard.md").read_text().split("## rod-b")[1] == section
    again = record_rows(out, "rod-a")
    assert [r["label"] for r in again] == [r["label"] for r in a]
    assert any(x["wall_time_s"] != y["wall_time_s"] for x, y in zip(again, a, strict=True))


def test_a_user_folder_of_another_case_is_refused_in_one_line(
    recorded, tmp_path, monkeypatch, capsys
):
    """Under rod-a/user/: a block compare, a rod compare graded against rod-b's reference and
    one from a compare that recorded no fingerprint are each refused in one line that says what
    to do; the good folder beside them is written."""
    out = copy(recorded, tmp_path)
    users = out / "leaderboard" / "rod-a" / "user"
    a, b = out / "leaderboard" / "rod-a", out / "leaderboard" / "rod-b"
    compare(a / "ours" / "implicit.xdmf", a / "ours" / "explicit.xdmf", users / "good",
            label="good", wall_time=0.1)  # fmt: skip
    compare(b / "ours" / "implicit.xdmf", b / "ours" / "explicit.xdmf", users / "rod-b",
            label="rod-b-run", wall_time=0.1)  # fmt: skip
    block = tmp_path / "block"
    r = tissuebench("run", "block", "--mesh-size", "2", "--material", "MP1", "--end-time", "0.2",
                    "--algorithms", "implicit,explicit-lumped", "--out", block)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    compare(block / "implicit.xdmf", block / "explicit-lumped.xdmf", users / "block",
            label="block-run", wall_time=0.1)  # fmt: skip
    shutil.copytree(users / "good", users / "old")
    summary = json.loads((users / "old" / "summary.json").read_text())
    del summary["reference"]["fingerprint"]
    summary["runs"] = {"old-run": summary["runs"]["good"]}
    (users / "old" / "summary.json").write_text(json.dumps(summary))
    capsys.readouterr()
    assert run(out, monkeypatch) == 0
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 3, lines
    refused = {line.split("/user/")[1].split(":")[0]: line for line in lines}
    assert set(refused) == {"block", "old", "rod-b"}
    assert "graded against block MP1 linear" in refused["block"]
    assert (
        "12 nodes" in refused["rod-b"] and "compare against rod-a's reference" in refused["rod-b"]
    )
    assert "rerun tissuebench compare (with --force)" in refused["old"]
    labels = {r["label"] for r in table(out)}
    assert "good" in labels and not labels & {"block-run", "rod-b-run", "old-run"}
    text = (out / "leaderboard.md").read_text()
    assert all(f"user/{name}: left out" in text for name in refused)


def test_the_load_while_a_case_was_timed_is_recorded_and_said(recorded, tmp_path, monkeypatch):
    """The one-minute load average as a case's timing began and ended goes into the record and
    into the case's header; past the core count less a half, its times are said to be upper
    bounds (the timed run shared busy cores), and on a quiet machine they are not."""
    cores = os.cpu_count() or 1

    def section(out):
        return (out / "leaderboard.md").read_text().split("## rod-a")[1].split("## rod-b")[0]

    for loads, busy in (([cores + 1.0, 0.25], True), ([0.5, 0.75], False)):
        out = copy(recorded, tmp_path / str(busy))
        measured = iter(loads)
        monkeypatch.setattr(leaderboard, "load_average", lambda m=measured: next(m))
        assert run(out, monkeypatch, rerun=["rod-a"]) == 0
        board = next(
            c["board"]
            for c in json.loads((out / "leaderboard.json").read_text())["cases"]
            if c["board"]["name"] == "rod-a"
        )
        assert board["load"] == loads
        said = f"load average {loads[0]:.2f} as its timing began, {loads[1]:.2f} as it ended"
        assert said in section(out)
        assert ("upper bounds" in section(out)) is busy
