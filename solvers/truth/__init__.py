"""The truth (SPEC section 10): a reference that converges to the continuum problem without
locking (Q2 displacement, Taylor-Hood Q2-Q1 for nu >= 0.45 and neo-Hookean, the trapezoidal
rule with consistent mass), its cases on the benchmarks, and its own error from a hierarchy.

- solver.py: Problem, Truth (forms and solvers built once; static solve, time integration),
  TruthRun (the displacement history as owned dof values of the Q2 space, and the probe).
- cases.py: the SPEC 10 cases on the benchmarks' grids (the block's graded toward the needle).
- estimate.py: E_i between levels and time steps; estimate_error(): order and own error.
- fallbacks.py: the cases taken where a case does not converge (SPEC 10, 12), registered.
"""

from tissuebench.solvers.truth import fallbacks  # noqa: F401  (registers its cases)
from tissuebench.solvers.truth.cases import (
    CASES,
    benchmark_problem,
    case_truth,
)
from tissuebench.solvers.truth.estimate import ErrorEstimate, estimate_error, interior_difference
from tissuebench.solvers.truth.solver import Boundary, Problem, Truth, TruthRun

# The package's own cases (cases.py's and fallbacks.py's), taken once this package is loaded:
# before any case can be registered from elsewhere (register_case needs this package), so a
# case registered later (a test's toy plate) is known to its own process only.
PACKAGE_CASES = frozenset(CASES)

__all__ = [
    "CASES",
    "PACKAGE_CASES",
    "Boundary",
    "ErrorEstimate",
    "Problem",
    "Truth",
    "TruthRun",
    "benchmark_problem",
    "case_truth",
    "estimate_error",
    "interior_difference",
]
