"""The runs of a case with elastic models (SPEC section 8) as a grid, algorithm by model, as
the figures of model_figures.py lay them out (grid, realism_table), and the runs that the
shapes and tip-path figures draw (SHAPE_ALGORITHM with each of SHAPE_MODELS)."""

from __future__ import annotations

from typing import Any

import numpy as np

from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.workflows.io.summary import CaseSummary

SHAPE_MODELS = ("linear", "corotational", "neo-hookean")  # shapes.png: the implicit runs of these
SHAPE_ALGORITHM = "implicit"


def grid(summary: CaseSummary) -> tuple[list[str], list[str], dict]:
    """(algorithms, models, {(algorithm, model): label}) of a summary's runs, in the order of
    the registries (ALGORITHMS, MODELS), only those present."""
    runs = summary.runs
    cells = {(run.algorithm, run.model): label for label, run in runs.items()}
    algorithms = [a for a in ALGORITHMS if any(k[0] == a for k in cells)]
    algorithms += [a for a in dict.fromkeys(k[0] for k in cells) if a not in algorithms]
    models = [m for m in MODELS if any(k[1] == m for k in cells)]
    models += [m for m in dict.fromkeys(k[1] for k in cells) if m not in models]
    return algorithms, models, cells


def realism_table(
    summary: CaseSummary, metric: str = "interior_error"
) -> tuple[list[str], list[str], list[list]]:
    """(algorithms, models, cells): cells[i][j] is None (no such run), "reference", or a dict
    with the run's label, status, time-mean of `metric` (NaN if none) and divergence time."""
    algorithms, models, labels = grid(summary)
    table = []
    for a in algorithms:
        row: list[dict[str, Any] | str | None] = []
        for m in models:
            label = labels.get((a, m))
            if label is None:
                row.append(None)
                continue
            if label == summary.reference:
                row.append("reference")
                continue
            run = summary.runs[label]
            mean = run.readings.get(f"{metric}_mean")
            row.append(
                {
                    "label": label,
                    "status": run.status,
                    "mean": np.nan if mean is None else float(mean),
                    "diverged_time": run.diverged_time,
                    "reason": run.reason,
                }
            )
        table.append(row)
    return algorithms, models, table
