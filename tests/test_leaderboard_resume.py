"""A `leaderboard --rerun` stopped part way resumes from the cases it finished
(workflows/leaderboard/resume.py): on the toy plate's case and a second case posed as it (both
graded against the plate's truth), a rerun interrupted in its second case keeps the first, run
and graded; the rerun again takes that case as it was left, runs only the second, and writes
the first's rows as the interrupted run graded them. A record of other sources is not taken."""

import csv
import dataclasses
import json
import os

import pytest
from toy_benchmark import BOARD, NAME, registered

from tissuebench.workflows.cli import main
from tissuebench.workflows.io.output import OutputError, write_owned
from tissuebench.workflows.leaderboard import boards, build, resume
from tissuebench.workflows.leaderboard.record import FOLDER

pytestmark = [pytest.mark.slow, pytest.mark.serial]  # rank 0 writes the leaderboard's files

SECOND = dataclasses.replace(BOARD, name=f"{BOARD.name}-again")


@pytest.fixture
def plates(tmp_path):
    before = os.environ.get("TISSUEBENCH_CACHE")
    os.environ["TISSUEBENCH_CACHE"] = str(tmp_path / "cache")
    with registered():
        boards.register(SECOND)
        try:
            yield
        finally:
            boards.unregister(SECOND.name)
    if before is None:
        del os.environ["TISSUEBENCH_CACHE"]
    else:
        os.environ["TISSUEBENCH_CACHE"] = before


def rows_of(path, case):
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if r["case"] == case]


def test_an_interrupted_rerun_resumes_from_the_cases_it_finished(plates, tmp_path, monkeypatch):
    assert main(["truth", NAME, "--out", str(tmp_path / "truth")]) == 0
    out = tmp_path / "board"
    rerun = ["leaderboard", "--out", str(out), "--rerun", BOARD.name, SECOND.name]
    real = build.run_board
    ran = []

    def stopped_in_the_second(board, *args, **kwargs):
        ran.append(board.name)
        if board.name == SECOND.name:
            raise KeyboardInterrupt
        return real(board, *args, **kwargs)

    monkeypatch.setattr(build, "run_board", stopped_in_the_second)
    assert main(rerun) == 130
    assert ran == [BOARD.name, SECOND.name]
    kept = json.loads((out / FOLDER / resume.DONE).read_text())
    assert [c["board"]["name"] for c in kept["cases"]] == [BOARD.name]
    first = kept["cases"][0]
    # kept graded against the truth: every row has its truth columns
    assert first["rows"] and all(r["truth"] for r in first["rows"])
    assert not (out / "leaderboard.csv").exists()  # nothing written but what resumes

    ran.clear()

    def counted(board, *args, **kwargs):
        ran.append(board.name)
        return real(board, *args, **kwargs)

    monkeypatch.setattr(build, "run_board", counted)
    assert main(rerun) == 0
    assert ran == [SECOND.name]  # the first case taken, not run again
    assert not (out / FOLDER / resume.DONE).exists()  # all in the record now
    record = json.loads((out / "leaderboard.json").read_text())
    written = {c["board"]["name"]: c for c in record["cases"]}
    assert written[BOARD.name]["board"]["session"] == first["board"]["session"]
    assert written[BOARD.name]["rows"] == first["rows"]
    again = rows_of(out / "leaderboard.csv", SECOND.name)
    assert len(again) == len(first["rows"]) and {r["status"] for r in again} == {"ok"}
    # posed the same and run the same way, the two cases grade the same to round-off
    a = {
        r["label"]: float(r["truth_relative_error_max"])
        for r in rows_of(out / "leaderboard.csv", BOARD.name)
    }
    b = {r["label"]: float(r["truth_relative_error_max"]) for r in again}
    assert a.keys() == b.keys() and all(b[k] == pytest.approx(a[k], rel=1e-9) for k in a)


def test_a_record_of_other_sources_is_not_taken(plates, tmp_path, monkeypatch):
    out = tmp_path / "board"
    (out / FOLDER).mkdir(parents=True)
    finished = resume.Finished(out)
    finished.code = "0" * 64  # as another version of tissuebench would have written it
    finished.keep(dataclasses.replace(BOARD, session="then"), [], [])
    said = []
    assert resume.Finished(out, log=said.append).take(BOARD) is None
    assert len(said) == 1 and "other sources" in said[0] and BOARD.name in said[0]
    # the same file of today's sources is taken, but not for a case posed otherwise
    finished = resume.Finished(out)
    finished.keep(dataclasses.replace(BOARD, session="then"), [], [])
    taken = resume.Finished(out, log=said.append).take(BOARD)
    assert taken is not None and taken[0].session == "then"
    other = dataclasses.replace(BOARD, end_time=(BOARD.end_time or 0.2) / 2)
    assert resume.Finished(out, log=said.append).take(other) is None
    # one we wrote that does not read is not taken; one changed since we wrote it is refused
    path = out / FOLDER / resume.DONE
    write_owned(path, lambda tmp: tmp.write_text("{"))
    assert resume.Finished(out).take(BOARD) is None
    path.write_text(path.read_text() + " ")
    with pytest.raises(OutputError, match="changed since tissuebench wrote it"):
        resume.Finished(out)
