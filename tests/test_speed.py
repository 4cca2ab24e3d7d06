"""Estimates that hold (core/speed.py): every truth estimate scales with the probe's time here
against the machine where the estimates were measured."""

import pytest

from tissuebench.core import speed
from tissuebench.solvers.truth import store


def test_estimates_scale_with_the_probe(monkeypatch: pytest.MonkeyPatch):
    """A probe twice the reference's time doubles every estimate; a probe at the reference's
    time gives the measured estimate itself; a far faster machine is taken as at most 4 times
    as fast."""
    monkeypatch.delenv("TISSUEBENCH_SLOWDOWN", raising=False)
    measured = store.EXPECTED_SECONDS["rod"]
    for wall, factor in ((2 * speed.REFERENCE_SECONDS, 2.0), (speed.REFERENCE_SECONDS, 1.0),
                         (speed.REFERENCE_SECONDS / 100, 0.25)):  # fmt: skip
        monkeypatch.setattr(speed, "probe", lambda wall=wall: (wall, wall))
        speed.slowdown.cache_clear()
        assert store.expected_seconds("rod") == pytest.approx(measured * factor)
    speed.slowdown.cache_clear()


def test_the_probe_is_short_and_counts_cpu():
    """The probe takes well under a second here and its wall time is at least its CPU time."""
    wall, cpu = speed.probe()
    assert 0 < cpu <= wall * 1.05 + 1e-3
    assert wall < 1.0


def test_the_slowdown_can_be_given(monkeypatch: pytest.MonkeyPatch):
    """TISSUEBENCH_SLOWDOWN replaces the probe; anything but a positive number is refused."""
    from tissuebench.core.errors import UserError

    for given, factor in (("3", 3.0), ("0.5", 0.5)):
        monkeypatch.setenv("TISSUEBENCH_SLOWDOWN", given)
        speed.slowdown.cache_clear()
        assert speed.scaled(10.0) == pytest.approx(10 * factor)
    for bad in ("fast", "0", "-1", "inf", "nan"):
        monkeypatch.setenv("TISSUEBENCH_SLOWDOWN", bad)
        speed.slowdown.cache_clear()
        with pytest.raises(UserError, match="TISSUEBENCH_SLOWDOWN"):
            speed.slowdown()
    speed.slowdown.cache_clear()
