"""The accuracy metrics of SPEC section 6 (E_n, E_s, E_i) and `compare` for any two simulations."""

from tissuebench.metrics.errors import METRICS, NAMES, Metric, Metrics
from tissuebench.metrics.series import InputError, Series, read_series
from tissuebench.metrics.compare import Grading, grade, summarize

__all__ = [
    "METRICS",
    "NAMES",
    "Metric",
    "InputError",
    "Metrics",
    "Series",
    "Grading",
    "grade",
    "read_series",
    "summarize",
]
