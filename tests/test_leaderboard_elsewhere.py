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
