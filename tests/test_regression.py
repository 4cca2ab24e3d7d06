"""The paper's study as a regression test: one case of `tissuebench paper` rerun here gives the
time-means and maxima of the committed results/ summary (as scikit-fem's examples double as
tests), to 1e-9 relative or 1e-13 absolute (E_s is an area difference, of round-off size where
the shapes agree); in serial and under mpiexec -n 2."""

import json
from pathlib import Path

import pytest

from tissuebench.metrics import METRICS
from tissuebench.workflows.run.case import run_case
from tissuebench.workflows.study.cases import cases

pytestmark = pytest.mark.parallel  # the committed (serial) numbers on 2 ranks too

RESULTS = Path(__file__).parent.parent / "results"


@pytest.mark.parametrize("name", ["block-MP1"])
def test_paper_case_reproduces_the_committed_summary(tmp_path, name):
    committed = json.loads((RESULTS / name / "summary.json").read_text())
    case = next(c for c in cases() if c.name == name)
    summary = run_case(case, tmp_path / name, log=lambda *_: None)
    assert (tmp_path / name / "summary.json").read_text() == summary.dumps()  # the one writer
    assert summary.fingerprint == committed["fingerprint"]  # the same inputs and software
    assert summary.runs.keys() == committed["runs"].keys()
    for label, run in committed["runs"].items():
        assert summary.runs[label].status == run["status"]
        for metric in METRICS:
            for stat in ("max", "mean"):
                key = f"{metric}_{stat}"
                ours, theirs = summary.runs[label].reading(metric, stat), run[key]
                if theirs is None:
                    assert ours is None, (label, key)
                else:
                    assert ours == pytest.approx(theirs, rel=1e-9, abs=1e-13), (label, key)
