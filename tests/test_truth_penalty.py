"""SPEC 12's limit of a contact truth's penalty (solvers/truth/store.py): where the finest
level with k and 10 k differ by more than a tenth of the truth's own error, that difference
over 0.9 is counted in the own error (the error of k if it falls as 1/k), and the target is
judged on the sum."""

from types import SimpleNamespace

import numpy as np
import pytest

from tissuebench.solvers.truth import store


def samples(penalty_difference: list[float] | None, space: float, time: float):
    """A truth of one quadrature point of weight 1 (2D) displaced 1 m: its size is 1 m^2."""
    h = {"penalty_step": 1 / 60, "penalty_difference": penalty_difference}
    if penalty_difference is None:
        h = {}
    return SimpleNamespace(
        hierarchy=h,
        own_error={"space": space, "time": time, "interior_error_max": space + time},
        weights=np.ones(1),
        gdim=2,
        u_points=[np.array([[1.0, 0.0]])],
        inputs={},  # not a meridian truth's (store.is_axisymmetric reads them)
    )


def test_the_penalty_part_is_counted_and_judged():
    target = store.TARGET_FRACTION  # of a size of 1 m^2
    s = samples([0.0, 0.45 * target], 0.3 * target, 0.3 * target)
    store.judge(s)  # type: ignore[arg-type]
    assert s.own_error["penalty"] == pytest.approx(0.5 * target)
    assert s.own_error["interior_error_max"] == pytest.approx(1.1 * target)
    assert not s.own_error["meets_target"]
    store.judge(s)  # type: ignore[arg-type]  # judged at every read: the same again
    assert s.own_error["interior_error_max"] == pytest.approx(1.1 * target)
    smaller = samples([0.09 * target], 0.3 * target, 0.3 * target)
    store.judge(smaller)  # type: ignore[arg-type]
    assert smaller.own_error["interior_error_max"] == pytest.approx(0.7 * target)
    assert smaller.own_error["meets_target"]


def test_no_penalty_part_without_the_half_step_check():
    """A truth without contact, or whose 10 k run was made at h (before), keeps space + time."""
    s = samples(None, 1e-6, 2e-6)
    store.judge(s)  # type: ignore[arg-type]
    assert "penalty" not in s.own_error
    assert s.own_error["interior_error_max"] == pytest.approx(3e-6)
    assert store.penalty_part({"penalty_difference": [1.0]}) is None
