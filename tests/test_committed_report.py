"""The committed results/README.md is what tissuebench writes from the committed results: the
verdicts of SPEC 7's claims, judged again here from the committed summaries and CSV files,
and the SPEC 11 answer, written again from the committed frontier.csv, stand in it word for
word (issue 36: a newcomer's `make paper` gives the report we publish; the runs themselves
are checked to reproduce in test_regression.py)."""

from pathlib import Path

import pytest

from tissuebench.workflows.commands.paper import cases
from tissuebench.workflows.frontier import read_rows
from tissuebench.workflows.reports.claims import claims
from tissuebench.workflows.reports.frontier import answer
from tissuebench.workflows.summary import read_case_summary

RESULTS = Path(__file__).resolve().parents[1] / "results"
pytestmark = pytest.mark.serial  # reads the repository's files only


def test_the_claims_verdicts_are_what_the_committed_runs_give():
    summaries = {c.name: read_case_summary(RESULTS / c.name) for c in cases()}
    assert all(s is not None for s in summaries.values())
    report = (RESULTS / "README.md").read_text()
    judged = claims(RESULTS, summaries)
    assert "holds" in judged or "does not hold" in judged
    assert judged in report


def test_the_spec_11_answer_is_what_the_committed_frontier_gives():
    rows = read_rows(RESULTS / "frontier" / "frontier.csv")
    assert len({r["case"] for r in rows}) == 4
    report = (RESULTS / "README.md").read_text()
    assert "\n".join(answer(rows)) in report
