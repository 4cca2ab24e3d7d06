"""The accuracy metrics of SPEC section 6 (E_n, E_s, E_i) on arrays and meshes, and the grading
of one displacement series against another (files are read in workflows/io/)."""

from mpi4py import MPI  # noqa: F401 (loads libmpi before PETSc and DOLFINx do)

from tissuebench.metrics.compare import Grading, grade_series, summarize
from tissuebench.metrics.series import InputError, Series
from tissuebench.metrics.table import METRICS, NAMES, Metric, Metrics

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
