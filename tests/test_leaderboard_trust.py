"""The leaderboard keeps what it promises (issue 35, item 5), on a record written here (no run,
no truth): a user's compare folder whose summary.json was edited after compare (every error
set to 1e-9, or its fingerprint made to name the truth) is left out with one line that says
so; every output is written as one set, so a signal after staging leaves the old set whole
(and no temporary), and one during the renames is raised once the new set is whole; and a
record whose rows are not of their type or range (a wall time "fast", errors null, dofs
"many", 100,000 nested brackets) is refused in one line before anything is replaced."""

import argparse
import json
import signal
from pathlib import Path

from mpi4py import MPI

import pytest
from test_newcomer_leaderboard import compare_summary

from tissuebench.core import interrupt
from tissuebench.workflows.io import output
from tissuebench.workflows.io.manifest import seal
from tissuebench.workflows.io.output import write_owned
from tissuebench.workflows.leaderboard import build, record
from tissuebench.workflows.leaderboard import rows as ranking
from tissuebench.workflows.leaderboard.rows import BOARDS, Board, Row, error_keys

pytestmark = pytest.mark.serial  # rank 0's files and signals

ROD = next(b for b in BOARDS if b.name == "rod-MP3")
SMALL = Board("rod-small", "rod", "MP3", "linear", simulators=(), description="a small case")


def user_folder(where: Path, label: str = "mine") -> Path:
    """A compare folder as compare writes it for rod-MP3 (summary.json and its manifest), its
    candidate series a file in it (recorded with its hashes; not read as a series here)."""
    where.mkdir(parents=True)
    series = where / "mine.xdmf"
    series.write_text(f"<Xdmf/> {label}\n")
    (where / "summary.json").write_text(json.dumps(compare_summary(ROD, label, series)))
    seal(where)
    return where


def test_an_edited_summary_is_left_out_with_a_line_that_says_so(tmp_path):
    users = tmp_path / "leaderboard" / ROD.name / "user"
    user_folder(users / "honest", "honest")
    for name, change in (
        ("better", lambda s: s["runs"]["better"].update(dict.fromkeys(error_keys(), 1e-9))),
        ("truth", lambda s: s["reference"]["fingerprint"].update(source="truth", truth="rod")),
    ):
        folder = user_folder(users / name, name)
        summary = json.loads((folder / "summary.json").read_text())
        change(summary)
        (folder / "summary.json").write_text(json.dumps(summary))  # after compare: no manifest
    rows, skipped = ranking.user_rows(ROD, users, BOARDS)
    assert [r.label for r in rows] == ["honest"]
    assert len(skipped) == 2, skipped
    for line in skipped:
        assert "left out" in line and "summary.json was changed since tissuebench wrote it" in line
        assert "grade the run again with tissuebench compare" in line
    # a folder without compare's manifest is left out too; a file added beside it is harmless
    (users / "honest" / "notes.txt").write_text("mine")
    bare = users / "bare"
    bare.mkdir()
    (bare / "summary.json").write_text(json.dumps(compare_summary(ROD, "bare")))
    rows, skipped = ranking.user_rows(ROD, users, BOARDS)
    assert [r.label for r in rows] == ["honest"]
    assert any("bare: left out: it has no manifest of compare's" in line for line in skipped)


# --- the record, the set of outputs ------------------------------------------------------------


def row(label: str, cost: float, error: float, **kw) -> Row:
    errors = dict.fromkeys(error_keys(), error)
    return Row(SMALL.name, label, "tissuebench", "d", "reference", 336, "ok", None, errors,
               cost * 0.2, 0.2, "this session", **kw)  # fmt: skip


def recorded(out: Path, monkeypatch) -> dict[str, bytes]:
    """OUT with a record of SMALL (written as ours) rendered once: its files' bytes."""
    rows = [row("implicit", 1.0, 0.0, reference=True), row("explicit", 0.5, 1e-4)]
    doc = record.record_of([SMALL], {SMALL.name: rows}, {SMALL.name: []})
    write_owned(out / record.RECORD, lambda tmp: tmp.write_text(json.dumps(doc)))
    monkeypatch.setattr(build, "BOARDS", [SMALL])
    assert run(out) == 0
    return snapshot(out)


def run(out: Path) -> int:
    return build.main(argparse.Namespace(out=out, solver="direct", petsc="", force=False))


def snapshot(out: Path) -> dict[str, bytes]:
    files = [out / n for n in record.OWNED] + sorted((out / "leaderboard").glob("*"))
    return {str(p.relative_to(out)): p.read_bytes() for p in files if p.is_file()}


def temporaries(out: Path) -> list[Path]:
    return [p for p in out.rglob("*") if ".tmp" in p.name or "lock" in p.name]


def test_a_signal_after_staging_leaves_the_old_set_whole(tmp_path, monkeypatch):
    out = tmp_path / "results"
    before = recorded(out, monkeypatch)
    assert "leaderboard/index.html" in before and "leaderboard/rod-small.png" in before
    # a new row: every file changes; a SIGINT once all of them are staged, before any rename
    doc = json.loads((out / record.RECORD).read_text())
    doc["cases"][0]["rows"].append(json.loads(json.dumps(doc["cases"][0]["rows"][1])))
    doc["cases"][0]["rows"][-1]["label"] = "explicit-again"
    write_owned(out / record.RECORD, lambda tmp: tmp.write_text(json.dumps(doc)))
    before = snapshot(out)
    monkeypatch.setattr(build, "STAGED_HOOK", lambda: signal.raise_signal(signal.SIGINT))
    # Python's own SIGINT handler, which a job started in the background (SIGINT ignored)
    # does not get
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            run(out)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert snapshot(out) == before  # the old set, whole
    assert temporaries(out) == []
    assert set(interrupt.unwritten()) >= {str(out / "leaderboard.md"), str(out / record.RECORD)}


def test_a_signal_during_the_renames_is_raised_once_the_new_set_is_whole(tmp_path, monkeypatch):
    out = tmp_path / "results"
    recorded(out, monkeypatch)
    doc = json.loads((out / record.RECORD).read_text())
    doc["cases"][0]["rows"][1]["wall_time_s"] = 0.05  # every output changes
    write_owned(out / record.RECORD, lambda tmp: tmp.write_text(json.dumps(doc)))
    replace, calls = output.os.replace, []

    def replaced(src, dst):  # a SIGTERM at the first rename into place
        if not Path(dst).name.startswith(output.PREFIX):  # not a file staged (io/tables.py)
            calls.append(dst)
            if len(calls) == 1:
                signal.raise_signal(signal.SIGTERM)
        return replace(src, dst)

    restore = interrupt.install(MPI.COMM_SELF)
    try:
        monkeypatch.setattr(output.os, "replace", replaced)
        with pytest.raises(interrupt.Terminated):
            run(out)
    finally:
        monkeypatch.undo()
        restore()
    assert len(calls) >= 4  # md, csv, json, index.html (and the figure) all moved into place
    assert interrupt.unwritten() == []  # said truthfully: all written
    written = json.loads((out / record.RECORD).read_text())
    assert written["cases"][0]["rows"][1]["wall_time_s"] == 0.05
    assert "0.25" in (out / "leaderboard.csv").read_text()  # 0.05 s over 0.2 s
    assert temporaries(out) == []
    for name in ("leaderboard.md", "leaderboard.csv", record.RECORD):  # listed as ours
        output.check_owned(out / name)


@pytest.mark.parametrize(
    "field, value, said",
    [
        ("wall_time_s", "fast", "wall_time_s 'fast' is not a number >= 0"),
        ("errors", None, "errors None is not an object of numbers"),
        ("dofs", "many", "dofs 'many' is not a whole number >= 0"),
        ("end_time", -1.0, "end_time -1.0 is not a number > 0"),
        ("pareto", {"mean": "yes"}, "pareto"),
        ("label", ["a"], "label ['a'] is not text"),
    ],
)
def test_a_malformed_record_row_is_refused_before_anything_is_replaced(
    tmp_path, monkeypatch, field, value, said
):
    out = tmp_path / "results"
    recorded(out, monkeypatch)
    doc = json.loads((out / record.RECORD).read_text())
    doc["cases"][0]["rows"][1][field] = value
    write_owned(out / record.RECORD, lambda tmp: tmp.write_text(json.dumps(doc)))
    before = snapshot(out)
    with pytest.raises(record.LeaderboardError) as caught:
        run(out)
    line = str(caught.value)
    assert "\n" not in line and said in line, line
    assert "case rod-small, row 2" in line and "--rerun` writes a new one" in line
    assert snapshot(out) == before


def test_a_deeply_nested_record_is_one_line(tmp_path, monkeypatch):
    out = tmp_path / "results"
    recorded(out, monkeypatch)
    write_owned(out / record.RECORD, lambda tmp: tmp.write_text("[" * 100_000 + "]" * 100_000))
    before = snapshot(out)
    with pytest.raises(record.LeaderboardError, match="nested too deep") as caught:
        run(out)
    assert "\n" not in str(caught.value)
    assert snapshot(out) == before


def test_each_graded_user_row_is_recorded_as_it_ends_and_resumed_from(tmp_path, capsys):
    """users.Progress: one line per graded row, the rows so far in graded-users.json (ours,
    in the folder's manifest), read back by a later run; an edited file is not."""
    from tissuebench.workflows.leaderboard import users

    out = tmp_path / "results"
    progress = users.Progress(out, total=2)
    first = row("mine", 1.0, 1e-4)
    first.source = "user"
    progress(SMALL, first, 1.25)
    said = capsys.readouterr().out
    assert "graded user row 1 (of 2 user rows): mine (rod-small) in 1.2 s" in said
    again = users.Progress(out, total=2).resumed()
    assert list(again.values())[0].label == "mine" and users.user_key(first) in again
    path = out / "leaderboard" / users.GRADED
    path.write_text(path.read_text().replace("0.0001", "1e-09"))  # edited: not taken
    assert users.Progress(out, total=2).resumed() == {}
    progress.done()
    assert not path.exists()
