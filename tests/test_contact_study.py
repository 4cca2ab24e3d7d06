"""The contact study (SPEC 12) end to end, quick: our algorithms on the contact block graded
against the contact truth (tissuebench contact --quick)."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tissuebench.workflows.contact.study import force_error, impulse_average
from tissuebench.workflows.io.tables import read_rows


def test_impulse_average_removes_the_step_to_step_alternation():
    """A smooth force plus an alternation (+a, -a, ...) about it: the two-step average gives
    the smooth force back where it is linear, and the force error is relative to the largest
    truth force."""
    t = np.arange(20) * 0.1
    smooth = np.column_stack([3 * t + 1, np.zeros_like(t)])
    chatter = smooth + np.column_stack([0.5 * (-1.0) ** np.arange(20), np.zeros_like(t)])
    averaged = impulse_average(chatter)
    assert np.allclose(averaged[1:-1], smooth[1:-1])
    assert force_error(smooth * 1.1, smooth) == pytest.approx(0.1)
    assert force_error(chatter, smooth) == pytest.approx(0.5 / 6.7)


@pytest.mark.serial
def test_quick_contact_study(tmp_path: Path):
    """`tissuebench contact --quick`: every run graded against the quick truth; against it, the
    finer grid is closer (E_i) and the stiffer penalty lets the tissue pass less far into the
    needle; the force errors are finite and quasi-static's E_i is the worst."""
    exe = Path(sys.executable).parent / "tissuebench"
    command = [str(exe), "contact", "--quick", "--cases", "contact-MP1", "--out", str(tmp_path)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "contact-quick"
    for name in ("contact.md", "contact.csv", "force-contact-MP1.png", "deformed-contact-MP1.png"):
        assert (folder / name).is_file(), name
    rows = read_rows(folder / "contact.csv")
    assert len(rows) == 7
    run = {(r["run"], int(r["N"]), float(r["kappa"])): r for r in rows}
    e_i = {key: float(r["interior_error_max"]) for key, r in run.items()}
    depth = {key: float(r["interpenetration_max"]) for key, r in run.items()}
    assert e_i[("implicit", 16, 10.0)] < e_i[("implicit", 8, 10.0)]
    assert depth[("implicit", 8, 100.0)] < depth[("implicit", 8, 10.0)]
    assert e_i[("quasi-static", 8, 10.0)] == max(e_i[(a, n, k)] for a, n, k in e_i if n == 8)
    assert all(np.isfinite(float(r["force_error"])) for r in rows)
    assert all(r["status"] == "ok" for r in rows)
    # SPEC 12's check of the truth's penalty, made at the half step (store.penalty_check): it
    # ran through, and the 10 k run lies nearer the truth's own half step than the two finest
    # levels lie to each other (the penalty is not what the truth's error is made of)
    from tissuebench.solvers.truth.store import load_cached

    truth = load_cached("contact-MP1", quick=True)
    assert truth is not None
    h = truth.hierarchy
    assert "penalty_failed" not in h
    assert h["penalty_step"] == pytest.approx(h["h"] / 2)
    assert max(h["penalty_difference"]) < max(h["level_differences"][-1]) / 5
