"""FloorTruth (solvers/truth/floor.py): where the truth's Newton asks for a residual below its
round-off floor, a step is taken once its residual has fallen by FLOOR_RTOL, and is the step
the truth's Newton takes to its own tolerance; a step that has not fallen so far still raises;
a case that converges is the same, bit for bit; only the floor cases' keys change."""

import numpy as np
import pytest

from tissuebench.solvers.truth import case_truth, store
from tissuebench.solvers.truth.floor import FLOOR_CASES, FLOOR_RTOL, FloorTruth
from tissuebench.solvers.truth.solver import Truth


def unreachable(cls, max_it: int):
    """cls whose Newton asks for a residual 1e-16 of its first (below round-off: as at the
    large rod's t = 8.2 s) and stops after max_it iterations."""

    class Tight(cls):
        def _newton_solver(self, full):
            problem = super()._newton_solver(full)
            problem.solver.setTolerances(rtol=1e-16, atol=0.0, max_it=max_it)
            return problem

    return Tight


def test_a_step_at_the_floor_is_the_converged_step():
    truth, bench = case_truth("rod-nhb-s3", 1)
    converged = truth.run(bench.dt, 4)
    with pytest.raises(RuntimeError, match="Newton did not converge"):
        unreachable(Truth, 12)(truth.problem).run(bench.dt, 4)
    floor = unreachable(FloorTruth, 12)(truth.problem)
    run = floor.run(bench.dt, 4)
    steps = [t / bench.dt for t, _ in floor.floor_steps]  # those whose Newton stopped
    assert steps and np.allclose(steps, np.round(steps)) and set(np.round(steps)) <= {1, 2, 3, 4}
    assert all(0 < ratio <= FLOOR_RTOL for _, ratio in floor.floor_steps)
    assert np.allclose(run.u, converged.u, rtol=0, atol=1e-12)  # Newton's 1e-10 (of ~1e-2 m)


def test_a_step_short_of_the_floor_still_raises():
    truth, bench = case_truth("rod-nhb-s3", 1)
    floor = unreachable(FloorTruth, 1)(truth.problem)  # one iteration: far from 1e-9
    with pytest.raises(RuntimeError, match="Newton did not converge"):
        floor.run(bench.dt, 2)
    assert floor.floor_steps == []


def test_a_converging_case_is_the_same_bit_for_bit():
    truth, bench = case_truth("rod-nhb-s3", 1)
    floor = FloorTruth(truth.problem)
    assert np.array_equal(floor.run(bench.dt, 4).u, truth.run(bench.dt, 4).u)
    assert floor.floor_steps == []


def test_only_the_floor_cases_keys_hold_it():
    assert FLOOR_CASES and all(c.endswith("-uniform") for c in FLOOR_CASES)
    for case in ("rod", "rod-nhb-s3", "rod-nhb-s1.5", *FLOOR_CASES):
        given = store.inputs(case)
        assert ("newton_floor" in given) == (case in FLOOR_CASES), case


def test_truth_md_says_which_steps_were_taken_at_the_floor():
    from tissuebench.workflows.truth.report import floor_words

    assert floor_words(1e-9, []).endswith("it took none.")
    said = floor_words(1e-9, [["8", 8.2, 1.05e-10], ["8 half", 8.2, 3e-10]])
    assert (
        "it took 2 (n = 8 at t = 8.2 s, n = 8 half at t = 8.2 s), the largest ratio 3e-10." in said
    )
