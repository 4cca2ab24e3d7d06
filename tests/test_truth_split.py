"""A linear truth's runs side by side (solvers/truth/split.py, in worker processes) give what
store.compute() gives running them one after another in one process, bit for bit: the quick
rod-MP2 (levels n = 1, 2, 4, graded; 30 steps of the truth's step h/4, its every 4th kept;
Taylor-Hood Q2-Q1, whose displacement part the workers hand over; the probe's and the static
tips) computed both ways. Only the wall times differ. (The quick rod, Q2 at h, took the same
path in 10 to 18 s more of make test: split.py has no branch that it takes and rod-MP2 not.)"""

from mpi4py import MPI

import numpy as np
import pytest

from tissuebench.solvers.truth.split import split_share, splittable, units_of
from tissuebench.solvers.truth.store import compute, compute_split

# one rank: the workers are processes of their own; about a minute in all
pytestmark = [pytest.mark.serial, pytest.mark.slow]

ARRAYS = ("times", "vertices", "cells", "boundary", "points", "weights", "u_vertices", "u_points")
TIMINGS = ("wall", "half_wall", "total_wall")


def without_timings(hierarchy: dict) -> dict:
    return {k: v for k, v in hierarchy.items() if k not in TIMINGS}


def test_split_is_compute_bit_for_bit():
    case = "rod-MP2"
    assert splittable(case)
    one = compute(case, quick=True, comm=MPI.COMM_SELF)
    lines: list[str] = []
    two = compute_split(case, quick=True, jobs=2, log=lines.append)
    assert one is not None and two is not None
    for name in ARRAYS:
        a, b = getattr(one, name), getattr(two, name)
        assert a.shape == b.shape and np.array_equal(a, b), name
    assert one.own_error == two.own_error
    assert without_timings(one.hierarchy) == without_timings(two.hierarchy)
    assert list(one.hierarchy) == list(two.hierarchy)  # the same record, in the same order
    assert len([line for line in lines if " s (" in line]) == 6  # each run said at its end


def test_what_splits():
    # the linear cases without contact split; a neo-Hookean, a contact or a floor case does not
    assert splittable("rod-MP2") and splittable("block-MP1-w0.2")
    assert not splittable("rod-nh-s1") and not splittable("contact-MP1")
    assert not splittable("rod-nhb-s2-uniform")
    assert units_of((2, 4, 8)) == [(2, 1), (4, 1), (8, 1), (2, 2), (2, 4), (8, 2)]
    # the finest at half the step is the longest run: on two workers it is one worker's work
    # alone (2 x 8^3 of 1656 = 8 + 64 + 512 + 16 + 32 + 1024 cells x steps), on one all of it
    assert split_share((2, 4, 8), "rod", 2) == pytest.approx(1024 / 1656)
    assert split_share((2, 4, 8), "rod", 1) == 1.0
