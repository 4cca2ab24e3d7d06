"""One cost on one board (issue 44): the SPEC 11 frontier's runs are rows of the leaderboard like
any other. Each costs its whole run (set-up and loop over the simulated time, as compare's
--wall-time and our study's rows count it), not its loop alone; the Pareto front against the
truth takes them (a run below and left of the front is on it, and the rows it beats leave
it); and every row on the page is in leaderboard.csv and leaderboard.json, rendering again
from the record without counting them twice.

End to end on test_trust_rows' case (the rod to 5 h, a synthetic truth, one row of ours in
the record), its frontier.csv committed in a clone made here with the numbers each test needs."""

import csv
import html
import json
import re
from pathlib import Path

import pytest
from test_trust_rows import case as case  # the fixture of its case (rod to 5 h, a truth)
from test_trust_rows import committed_frontier, frontier_rows, render, results

from tissuebench.workflows.leaderboard.frontier_rows import FRONTIER, frontier_row, join_frontier
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, mark_truth_pareto

pytestmark = pytest.mark.serial  # rank 0's files, the command run on them

E_I = "interior_error"


def ours(label: str, cost: float, error: float) -> Row:
    """A row of ours on the rod (10 simulated s) with E_i `error` against the truth."""
    truth = {f"{E_I}_mean": error, f"{E_I}_max": 2 * error}
    return Row("rod-MP3", label, "tissuebench", "ours", "reference", 336, "ok", None,
               dict.fromkeys(error_keys(), error), cost * 10, 10.0, "this session",
               truth=truth)  # fmt: skip


def run(scheme: str, loop_cost: float, setup_s: float, error: float) -> dict:
    """A frontier.csv row (text) of the rod: loop_cost s per simulated s over 10 s, setup_s s
    of set-up, E_i `error` (m^3) against the truth, no whole_s (an older file)."""
    text = {**frontier_rows()[0], "scheme": scheme, "cost": repr(loop_cost),
            "loop_s": repr(10 * loop_cost), "setup_s": repr(setup_s),
            "interior_error_mean": repr(error), "interior_error_max": repr(2 * error)}  # fmt: skip
    return frontier_row(text)


def test_a_frontier_run_costs_its_whole_run():
    """Loop 0.05 s per simulated s, set-up 3 s over 10 s: the row costs 0.35 s per simulated s,
    not 0.05; with whole_s given (a file of today) that one is taken."""
    board = Board("rod-MP3", "rod", "MP3", "linear", truth="rod")
    rows = join_frontier([board], {"rod-MP3": [ours("implicit", 0.01, 1e-5)]},
                         {"rod": [run("anp", 0.05, 3.0, 1e-5)]})["rod-MP3"]  # fmt: skip
    (row,) = [r for r in rows if r.source == FRONTIER]
    assert row.cost == pytest.approx(0.35) and row.wall_time_s == pytest.approx(3.5)
    assert "its time loop alone 0.05 s per simulated s" in row.description
    given = frontier_row({**frontier_rows()[0], "whole_s": "0.5"})  # loop 0.03 s, set-up 0.01
    assert given["whole_s"] == 0.5 and given["simulated"] == pytest.approx(10.0)
    with pytest.raises(ValueError, match="whole_s 0.01 is less than its loop's"):
        frontier_row({**frontier_rows()[0], "whole_s": "0.01"})


def test_a_frontier_run_below_and_left_of_the_front_is_on_it():
    """Ours: 0.01 s/s at 1e-4 and 0.1 s/s at 1e-5 (both on the front). A frontier run at
    0.005 s/s (whole) and 5e-6 beats both: it alone is on the front; a frontier run above and
    right of the front is not; the frontier's rows are joined to a truth's case only."""
    board = Board("rod-MP3", "rod", "MP3", "linear", truth="rod")
    mine = [ours("explicit", 0.01, 1e-4), ours("implicit", 0.1, 1e-5)]
    mark_truth_pareto(mine)
    assert all(r.truth_pareto["mean"] for r in mine)
    frontier = {"rod": [run("anp", 0.004, 0.01, 5e-6), run("standard", 1.0, 0.0, 1e-3)]}
    rows = join_frontier([board], {"rod-MP3": mine}, frontier)["rod-MP3"]
    front = {r.label: r.truth_pareto["mean"] for r in rows}
    assert front == {
        "explicit": False,
        "implicit": False,
        "anp implicit, hexahedron n=2": True,
        "standard implicit, hexahedron n=2": False,
    }
    other = Board("block-MP1", "block", "MP1", "linear", truth=None)
    assert join_frontier([other], {"block-MP1": mine}, frontier) == {"block-MP1": mine}


def page_labels(out: Path) -> list[str]:
    """The label of every point on the page."""
    text = (out / "leaderboard" / "index.html").read_text()
    return [
        html.unescape(x) for x in re.findall(r'class="pt f[^"]*"[^>]*data-label="([^"]*)"', text)
    ]


def csv_rows(out: Path) -> dict[str, dict]:
    with open(out / "leaderboard.csv", newline="") as f:
        return {r["label"]: r for r in csv.DictReader(f)}


def test_every_row_on_the_page_is_in_the_csv_and_the_record(case, tmp_path, monkeypatch):
    """`tissuebench leaderboard` with a committed frontier.csv of two runs: the page's points
    are the CSV's rows and the record's, the frontier's included, each costing its whole run;
    the front (in the CSV) holds the frontier run that beats our row; rendered again from the
    record, nothing is counted twice."""
    out = results(case, tmp_path)
    good = {
        **frontier_rows()[0],
        "scheme": "anp",
        "setup_s": "0.2",
        "loop_s": "0.03",
        "cost": "0.003",
        "interior_error_mean": "1e-6",
        "interior_error_max": "2e-6",
    }
    slow = {**good, "scheme": "standard", "cost": "0.3", "loop_s": "3.0",
            "interior_error_mean": "0.9"}  # fmt: skip
    committed_frontier(tmp_path, monkeypatch, [good, slow])  # the clone's, as committed
    written = []
    for _ in range(2):  # the second: from the record the first wrote
        assert render(out, case[2], monkeypatch, committed=True) == 0
        written.append([(out / n).read_bytes() for n in ("leaderboard.csv", "leaderboard.json")])
        shown = page_labels(out)
        table = csv_rows(out)
        record = json.loads((out / "leaderboard.json").read_text())
        recorded = [r["label"] for c in record["cases"] for r in c["rows"]]
        assert sorted(shown) == sorted(table) == sorted(recorded)
        assert len(shown) == 3  # ours and the two frontier runs
    assert written[0] == written[1]  # byte for byte: the frontier's rows not counted twice
    anp = table["anp implicit, hexahedron n=2"]
    # whole run: (0.2 + 0.03) s over 10 simulated s, not the loop's 0.003
    assert float(anp["wall_per_simulated_s"]) == pytest.approx(0.023)
    assert anp["source"] == FRONTIER and anp["truth_pareto_mean"] == "True"
    assert table["implicit"]["truth_pareto_mean"] == "False"  # beaten: 0.5 at 0.1/(5 h)
    assert table["standard implicit, hexahedron n=2"]["truth_pareto_mean"] == "False"
    costs = {label: float(r["wall_per_simulated_s"]) for label, r in table.items()}
    assert costs["standard implicit, hexahedron n=2"] == pytest.approx((0.2 + 3.0) / 10)
    # the page says the frontier's cost is the whole run's, as every row's
    text = (out / "leaderboard" / "index.html").read_text()
    assert "is the whole run's: set-up included" in text
