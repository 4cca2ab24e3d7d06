"""Issue 25, item 5: the paper against the truth. The verdicts of claims 1, 2 and 5 (SPEC 7)
judged on hand-built numbers whose answer is known by construction, the section of README.md
rendered from the data alone, and a truth that is not cached named with the command that
computes it instead of numbers."""

from mpi4py import MPI  # noqa: F401 (loads libmpi before dolfinx)

import pytest

from tissuebench.workflows.study import truth as pt
from tissuebench.workflows.study import truth_section as report

pytestmark = pytest.mark.serial  # pure functions and text, on one process


def values(scale: float, metrics=pt.METRICS) -> dict:
    """{metric_reading: value}: every metric's time-mean `scale` and maximum 2 `scale`."""
    out = {}
    for m in metrics:
        out[f"{m}_mean"], out[f"{m}_max"] = scale, 2 * scale
    return out


def mp1_runs(explicit=1.0, implicit_lumped=2.0, explicit_lumped=3.0, quasi_static=10.0):
    """The MP1 runs against the MP1 truth, {algorithm: values}."""
    return {
        "implicit": values(0.5),
        "explicit": values(explicit),
        "implicit-lumped": values(implicit_lumped),
        "explicit-lumped": values(explicit_lumped),
        "quasi-static": values(quasi_static),
    }


def mp2_runs(quasi_static_mp2=1.0, smallest_mp1=20.0):
    """Every run against the MP2 truth, {label: values}: the MP1 runs from smallest_mp1 up."""
    runs = {"implicit-MP2": values(0.9 * quasi_static_mp2)}
    for k, a in enumerate(pt.ALGORITHMS):
        runs[f"{a}-MP1"] = values(smallest_mp1 * (1 + k))
    runs["quasi-static-MP2"] = values(quasi_static_mp2)
    return runs


# --- the verdicts ---------------------------------------------------------------------------


def test_claim_1_holds_in_the_papers_order_and_fails_when_explicit_is_not_the_closest():
    claim = pt.claim_order(mp1_runs())
    assert claim.holds is True and all(claim.checks.values())
    assert claim.parts == {"explicit the closest": 6, "quasi-static the worst": 6}
    # implicit-lumped below explicit (as against the truth): the ordering breaks
    swapped = pt.claim_order(mp1_runs(explicit=2.5))
    assert swapped.holds is False and not any(swapped.checks.values())
    assert swapped.parts == {"explicit the closest": 0, "quasi-static the worst": 6}
    # quasi-static not the worst: breaks too
    assert pt.claim_order(mp1_runs(quasi_static=2.9)).holds is False


def test_claim_2_is_the_ratio_to_the_sum_within_a_factor_2():
    assert pt.sum_ratio(1.0, 2.0, 3.0) == 1.0
    assert pt.claim_sum(mp1_runs(1.0, 2.0, 3.0)).holds is True  # exactly the sum
    assert pt.claim_sum(mp1_runs(1.0, 2.0, 5.9)).holds is True  # ratio 1.97
    assert pt.claim_sum(mp1_runs(1.0, 2.0, 6.1)).holds is False  # ratio 2.03
    assert pt.claim_sum(mp1_runs(1.0, 2.0, 1.6)).holds is True  # ratio 0.53
    low = pt.claim_sum(mp1_runs(1.0, 2.0, 1.4))  # ratio 0.47: the three do not add
    assert low.holds is False
    assert low.numbers["relative_error", "mean"]["ratio"] == pytest.approx(1.4 / 3.0)


def test_claim_5_needs_every_mp1_run_ten_times_quasi_static_mp2():
    claim = pt.claim_material(mp2_runs(1.0, 20.0))
    assert claim.holds is True
    assert claim.numbers["interior_error", "mean"]["smallest"] == "implicit-MP1"
    assert claim.numbers["interior_error", "mean"]["ratio"] == pytest.approx(20.0)
    near = pt.claim_material(mp2_runs(1.0, 2.3))  # material matters more, but not 'far'
    assert near.holds is False
    assert near.parts == {"quasi-static MP2 below every MP1 run": 6}
    worse = pt.claim_material(mp2_runs(1.0, 0.5))
    assert worse.holds is False and worse.parts["quasi-static MP2 below every MP1 run"] == 0


def test_missing_truths_leave_the_claims_unjudged():
    claims = pt.judge({})
    assert [(c.number, c.holds) for c in claims] == [(1, None), (2, None), (5, None)]
    mp1_only = pt.judge({"block-MP1-w0.2": {f"{a}-MP1": v for a, v in mp1_runs().items()}})
    assert [c.holds for c in mp1_only] == [True, True, None]


# --- the section, from data ----------------------------------------------------------------


def data(graded: dict, own: dict) -> pt.PaperTruth:
    missing = [name for _, _, _, name in pt.REFERENCES if name not in graded]
    return pt.assemble(graded, own, missing)


def test_the_section_shows_the_numbers_and_verdicts_of_its_data():
    rod = {"implicit": values(2.73e-4)}
    mp1 = {f"{a}-MP1": v for a, v in mp1_runs(explicit=2.5).items()}  # claim 1 fails
    mp2 = {**mp2_runs(1.0, 20.0), "implicit-MP1": values(20.0)}  # claim 5 holds
    graded = {"rod": rod, "block-MP1-w0.2": mp1, "block-MP2-w0.2": mp2}
    own = {"rod": 4.7e-6, "block-MP1-w0.2": 7e-5, "block-MP2-w0.2": 1.2e-4}
    text = "\n".join(report.truth_section(data(graded, own)))
    assert text.startswith("## The paper against the truth")
    assert "point needle" in text and "w = 0.2 m" in text
    # the rod reference's row: E_n mean, max, E_i mean, max, the truth's own error
    assert (
        "| rod, n = 3 | implicit | rod | 0.000273 | 0.000546 | 0.000273 | 0.000546 | 4.7e-06 |"
        in text
    )
    verdicts = [line for line in text.splitlines() if "Verdict against the truth" in line]
    assert len(verdicts) == 3
    assert "**does not hold**" in verdicts[0]  # claim 1, explicit not the closest
    assert "**holds**" in verdicts[1]  # claim 2: 3 / (2.5 + 2) = 0.67
    assert "**holds**" in verdicts[2]  # claim 5: 20 times
    assert "not cached" not in text


def test_a_missing_truth_gives_the_command_instead_of_numbers():
    rod = {"implicit": values(2.73e-4)}
    text = "\n".join(report.truth_section(data({"rod": rod}, {"rod": 4.7e-6})))
    for case in ("block-MP1-w0.2", "block-MP2-w0.2"):
        assert f"`tissuebench truth {case}`" in text
    assert "Verdict against the truth" not in text  # no claim judged without its truth
    row = next(line for line in text.splitlines() if line.startswith("| block MP1"))
    assert "not cached: `tissuebench truth block-MP1-w0.2`" in row
    assert row.endswith("` | | | | |")  # no number in the cells of E_n, E_i, own error
