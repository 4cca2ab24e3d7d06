"""The accuracy metrics of SPEC section 6 (E_n, E_s, E_i) on arrays and meshes, and the grading
of one displacement series against another (files are read in workflows/io/)."""

from tissuebench.metrics.table import METRICS, NAMES, Metric, Metrics
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.compare import Grading, grade_series, summarize

__all__ = [
    "METRICS",
    "NAMES",
    "Metric",
    "InputError",
    "Metrics",
    "Series",
    "Grading",
    "grade_series",
    "summarize",
]
