"""Numbers as the reports write them (results/README.md, truth.md): one format for all."""

import math


def fmt(x: float | None, digits: int = 3) -> str:
    """A number to `digits` significant digits, or n/a for None, NaN and infinity."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:.{digits}g}"
