"""The accuracy metrics of SPEC section 6 (E_n, E_s, E_i) and `compare` for any two simulations."""

from tissuebench.metrics.errors import NAMES, Metrics
from tissuebench.metrics.series import InputError, Series, read_series
from tissuebench.metrics.compare import compare, summarize

__all__ = ["NAMES", "InputError", "Metrics", "Series", "compare", "read_series", "summarize"]
