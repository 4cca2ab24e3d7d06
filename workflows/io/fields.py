"""The point field a displacement series is read from: a name given, or the first of
DEFAULT_FIELDS that the file holds."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from tissuebench.metrics.series import InputError

# what a reader returns: (points (n, 3), cells (VTK node order), cell type, times (s), the
# (n, components) values at each time, the field's name), checked by metrics/series.series_of
FieldData = tuple[ArrayLike, ArrayLike, str, ArrayLike, np.ndarray | list[Any], str]

DEFAULT_FIELDS = ("displacement", "U", "DISP", "Displacement")


def field_names(field: str | None) -> tuple[str, ...]:
    """The names to look for: the one given, or DEFAULT_FIELDS in order."""
    return (field,) if field else DEFAULT_FIELDS


def missing_field(path: str | Path, names: Sequence[str], fields: Sequence[str]) -> InputError:
    """One line: none of `names` is among the file's `fields`."""
    nor = f" (nor {', '.join(names[1:])})" if len(names) > 1 else ""
    hint = (
        "; name the displacement field with --candidate-field or --reference-field (or --field)"
        if fields
        else ""
    )
    return InputError(
        f"{path}: no point field {names[0]!r}{nor}; fields: {', '.join(fields) or 'none'}{hint}"
    )
