"""How fast this machine does tissuebench's kind of work now, against the machine its time
estimates were measured on: a probe of about 0.1 s (a sparse LU factorisation and solve, one
thread, as the truth's steps are) timed at first use, so that every "about N s" scales with the
machine's speed and its load at the time (issue: estimates that hold under load).

The probe's CPU time on the machine of the estimates (a quiet 2-core machine, one core for the
probe) is REFERENCE_SECONDS; its wall time here, best of three, over that is `slowdown()`. On a
machine loaded to twice its cores the probe shares its core and takes about twice as long, as
the truth's computation will."""

from __future__ import annotations

import os
import time
from functools import cache

import numpy as np

from tissuebench.core.errors import UserError

REFERENCE_SECONDS = 0.04  # s: probe()'s CPU time (best of 15) on the machine of the estimates
GRID = 120  # the probe's 2D Laplacian: GRID^2 unknowns


def probe() -> tuple[float, float]:
    """(wall, CPU) seconds of one probe, best of three: factorise the 5-point Laplacian of a
    GRID x GRID grid (SuperLU, one thread) and solve with it."""
    import scipy.sparse as sp  # here: 0.1 s of every command's start otherwise
    import scipy.sparse.linalg as spla

    one = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(GRID, GRID))
    eye = sp.identity(GRID)
    matrix = (sp.kron(one, eye) + sp.kron(eye, one)).tocsc()
    rhs = np.ones(GRID * GRID)
    best = (float("inf"), float("inf"))
    for _ in range(3):
        wall, cpu = time.perf_counter(), time.process_time()
        spla.splu(matrix).solve(rhs)
        best = min(best, (time.perf_counter() - wall, time.process_time() - cpu))
    return best


@cache
def slowdown() -> float:
    """This machine's time for the probe now over REFERENCE_SECONDS (1: as fast as where the
    estimates were measured; 2: half as fast, or loaded so that a core is shared), at least
    0.25; measured once a process. The environment variable TISSUEBENCH_SLOWDOWN, a positive
    number, replaces the measurement (the tests set 1, so that the estimates they read are the
    measured ones)."""
    given = os.environ.get("TISSUEBENCH_SLOWDOWN")
    if given:
        try:
            factor = float(given)
        except ValueError:
            factor = float("nan")
        if not factor > 0 or factor == float("inf"):
            raise UserError(f"TISSUEBENCH_SLOWDOWN={given!r}: give a positive number")
        return factor
    wall, _ = probe()
    return max(wall / REFERENCE_SECONDS, 0.25)


def scaled(seconds: float) -> float:
    """An estimate measured on the reference machine (s), for this machine now (s)."""
    return seconds * slowdown()
