"""The leaderboard from a user's own folder (issue 44, item 1): `tissuebench leaderboard --out
results` in a folder outside the clone renders the clone's committed record (found from the
installed package's source tree) or the one `--results DIR` names, into OUT, and never writes
into the record's folder. tests/test_recipe.py runs the README's recipe that way end to end;
here the choice of record, its one-line refusal, and a render from a copy of the committed
results/ with nothing to grade (seconds: every figure of the same rows is copied)."""

import argparse
import csv
import hashlib
from pathlib import Path

import pytest
from helpers import tissuebench
from test_recipe import committed_results

from tissuebench.workflows.leaderboard import build, record
from tissuebench.workflows.leaderboard.force_figure import force_drawing_code
from tissuebench.workflows.leaderboard.record import RECORD, LeaderboardError, record_folder

ROOT = Path(__file__).resolve().parents[1]
COMMITTED = ROOT / "results" / RECORD


def as_drawn_now(png: Path) -> bool:
    """Whether a committed figure is as today's code draws it (its stamp: the case figures'
    drawing code, or the force figures')."""
    return build.as_drawn_now(png, force_drawing_code() if png.stem.endswith("-force") else None)


def digest(folder: Path) -> dict[str, str]:
    """{path relative to folder: SHA-256} of every file under folder."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


@pytest.mark.serial  # files in tmp_path, which the ranks of mpiexec share
def test_the_record_is_outs_the_clones_or_the_one_named(tmp_path, monkeypatch):
    out = tmp_path / "mywork" / "results"
    if COMMITTED.is_file():  # an editable install from this clone: its results/ is found
        assert record.clone_results() == ROOT / "results"
        assert record_folder(out) == ROOT / "results"
    monkeypatch.setattr(record, "clone_results", lambda: None)  # an installed copy
    assert record_folder(out) == out  # none: the caller says so
    (out).mkdir(parents=True)
    (out / RECORD).write_text("{}")
    assert record_folder(out) == out  # the user's own record first
    named = tmp_path / "copy"
    with pytest.raises(LeaderboardError, match=r"^--results .*copy: no leaderboard record"):
        record_folder(out, named)
    named.mkdir()
    (named / RECORD).write_text("{}")
    assert record_folder(out, named) == named  # named: it wins


@pytest.mark.serial
def test_results_without_a_record_is_refused_in_one_line(tmp_path):
    done = tissuebench(
        "leaderboard", "--out", tmp_path / "out", "--results", tmp_path / "none", cwd=tmp_path
    )
    assert done.returncode == 2, done.stderr
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and f"--results {tmp_path / 'none'}: no leaderboard record" in err[0]
    assert not (tmp_path / "out" / "leaderboard.md").exists()


@pytest.mark.serial
def test_a_render_from_a_copy_of_the_committed_results_leaves_it_unchanged(
    tmp_path, capsys, monkeypatch
):
    if not COMMITTED.is_file() or not (ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout with its committed leaderboard record")
    copy = tmp_path / "copy"
    committed_results(copy)
    before = digest(copy)
    out = tmp_path / "mywork" / "results"
    drawn = []  # the figures drawn anew: none where the rows are the record's and the
    # committed figure is as drawn by today's code (a case with the frontier's rows too)
    fresh = {p.name for p in (copy / "leaderboard").glob("*.png") if not as_drawn_now(p)}
    monkeypatch.setattr(build, "plot_case", lambda path, board, rows: drawn.append(board.name))
    monkeypatch.setattr(build, "plot_force", lambda path, board, rows: drawn.append(board.name))
    args = argparse.Namespace(
        out=out, results=copy, solver="direct", petsc="", force=False, rerun=None
    )
    assert build.main(args) == 0
    assert digest(copy) == before  # only read
    said = capsys.readouterr().out
    assert f"rendering the record {copy / RECORD} (only read)" in said
    assert f"from the record {copy / RECORD}" in said
    mine = (out / "leaderboard.md").read_text().splitlines()
    theirs = (copy / "leaderboard.md").read_text().splitlines()
    heads = [line for line in theirs if line.startswith("## ")]
    assert heads and heads == [line for line in mine if line.startswith("## ")]
    # issue 44, item 5: rod-MP2's explicit-lumped diverged, and its budget and row say so
    with open(out / "leaderboard.csv", newline="") as f:
        table = {(r["case"], r["label"]): r for r in csv.DictReader(f)}
    lumped = table.get(("rod-MP2", "explicit-lumped"))
    if lumped is not None and lumped["status"] == "diverged":
        assert lumped["errors_over"] == "the steps before it diverged"
        html = (out / "leaderboard" / "index.html").read_text()
        assert "explicit-lumped (diverged)</text>" in html  # its line in rod-MP2's budget
    # the same rows: each figure as drawn by today's code is the record's, copied
    assert sorted(drawn) == sorted({n.removesuffix(".png").removesuffix("-force") for n in fresh})
    for png in sorted((copy / "leaderboard").glob("*.png")):
        if build.as_drawn_now(png):
            assert (out / "leaderboard" / png.name).read_bytes() == png.read_bytes(), png.name


def forged_copy(tmp_path: Path) -> tuple[Path, dict]:
    """A copy of the committed results/ whose record has rod-MP3's first row of ours made
    perfect (every error 1e-15) and its first simulator row's wall time 1e-9 s; the rows as
    committed, by label."""
    import json

    copy = tmp_path / "copy"
    committed_results(copy)
    doc = json.loads((copy / RECORD).read_text())
    case = next(c for c in doc["cases"] if c["board"]["name"] == "rod-MP3")
    committed = {r["label"]: dict(r) for r in case["rows"]}
    ours = next(r for r in case["rows"] if r["source"] == "tissuebench")
    ours["errors"] = dict.fromkeys(ours["errors"], 1e-15)
    ours["truth"] = {k: (1e-15 if v is not None else v) for k, v in ours["truth"].items()}
    theirs = next(r for r in case["rows"] if r["source"] not in ("tissuebench", "user"))
    theirs["wall_time_s"] = 1e-9
    (copy / RECORD).write_text(json.dumps(doc))
    return copy, {"ours": committed[ours["label"]], "theirs": committed[theirs["label"]]}


@pytest.mark.serial  # files in tmp_path, which the ranks of mpiexec share
def test_rows_of_ours_edited_in_a_record_are_rendered_as_committed(tmp_path, capsys, monkeypatch):
    """Issue 60, item 1: a record read from a folder anyone can write (OUT's own, or one named
    with --results) does not bring its grades of ours or the simulators to the page: they are
    the record's as the clone's git holds it, and the case is said in one line."""
    if not COMMITTED.is_file() or not (ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout with its committed leaderboard record")
    copy, committed = forged_copy(tmp_path)
    drawn = []

    def draw(path, board, rows):  # a figure drawn anew: which, and a file in its place
        drawn.append(board.name)
        path.write_bytes(b"a figure")

    monkeypatch.setattr(build, "plot_case", draw)
    monkeypatch.setattr(build, "plot_force", draw)
    out = tmp_path / "results"
    args = argparse.Namespace(
        out=out, results=copy, solver="direct", petsc="", force=False, rerun=None
    )
    assert build.main(args) == 0
    said = capsys.readouterr().out
    assert "rod-MP3: the record's rows of ours and the simulators are not as committed" in said
    assert said.count("not as committed") == 1  # the other cases are as committed
    assert "rod-MP3" in drawn  # its figure: drawn anew, not the forged record's copied
    (case,) = [
        c
        for c in build.json.loads((out / RECORD).read_text())["cases"]
        if c["board"]["name"] == "rod-MP3"
    ]
    rendered = {r["label"]: r for r in case["rows"]}
    for row in committed.values():
        got = rendered[row["label"]]
        assert got["errors"] == row["errors"] and got["truth"] == row["truth"]
        assert got["wall_time_s"] == row["wall_time_s"]
    with open(out / "leaderboard.csv", newline="") as f:
        values = [v for r in csv.DictReader(f) for v in r.values()]
    assert values and not [v for v in values if v in ("1e-15", "1e-09")]  # the forged values


@pytest.mark.serial  # files in tmp_path
def test_without_a_committed_record_the_rows_are_said_to_be_shown_as_read(tmp_path, capsys):
    """An installed copy without its clone (no git): nothing to hold the record against; the
    record is taken as read, and that is said in one line."""
    from tissuebench.workflows.leaderboard.record import committed_record, with_committed_rows

    if not COMMITTED.is_file():
        pytest.skip("needs the committed leaderboard record")
    copy, _ = forged_copy(tmp_path)
    committed, why = committed_record(tmp_path)  # not a git repository
    assert committed is None and "git show HEAD:results/leaderboard.json" in why
    said: list[str] = []
    read = record.read_record(copy)
    assert read is not None
    held, changed = with_committed_rows(read, committed, why, said.append)
    assert held is read and changed == []
    assert len(said) == 1 and "shown as read, not held against a committed record" in said[0]
