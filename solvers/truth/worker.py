"""A worker of a split truth (solvers/truth/split.py): `python -m tissuebench.solvers.truth.worker
CASE N M QUICK OUT` computes one unit, level N at the step h / (M k), on one rank, and writes it
to OUT (.npz). It imports the store, which the split itself does not."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core import interrupt
from tissuebench.solvers.truth.split import Unit
from tissuebench.solvers.truth.store import inputs, level_truth


def run_unit(case: str, quick: bool, unit: Unit, out: Path) -> None:
    """Compute one unit on COMM_SELF and write it to `out` (.npz). A worker's work."""
    given = inputs(case, quick)
    steps, k = given["steps"], given["step_divisor"]
    n, m = unit
    truth, bench = level_truth(case, n, MPI.COMM_SELF)
    run = truth.run(bench.dt / (m * k), m * k * steps, keep=m * k)
    arrays: dict[str, np.ndarray] = {
        "u": np.asarray(run.u),
        "times": np.asarray(run.times),
        "dofs": np.asarray(run.dofs),
        "wall": np.asarray(run.wall),
    }
    if run.tip is not None:
        arrays["tip"] = np.asarray(run.tip)
        if m == 1:  # as compute(): the static tip right after the level's run, on its Truth
            try:
                arrays["static"] = np.asarray(truth.tip(truth.static(steps * bench.dt)))
            except RuntimeError as err:
                arrays["static"] = np.full(3, np.nan)
                arrays["static_error"] = np.asarray(str(err))
    partial = out.with_name(out.name + ".partial.npz")
    np.savez(partial, allow_pickle=False, **arrays)
    os.replace(partial, out)


if __name__ == "__main__":  # a unit's worker: CASE N M QUICK OUT (the package's cases)
    name, n_, m_, quick_, out_ = sys.argv[1:6]
    # 0 when done; 130 or 143 with one line on a signal, never 0 (core/interrupt.py)
    interrupt.run_worker(
        lambda: run_unit(name, quick_ == "1", (int(n_), int(m_)), Path(out_)), "truth worker"
    )
