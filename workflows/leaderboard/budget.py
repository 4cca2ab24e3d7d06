"""The error budget of a leaderboard case as a figure (SPEC 10): for each run graded against
the truth, its total error (against the truth) beside the parts it splits into: the
discretisation (our implicit on the run's mesh against the truth), the algorithm (the run
against our implicit on its mesh) and the model; time-mean E_i, in m^3 (3D) or m^2 (2D), on
a log axis. A part that is zero, or could not be measured, is said in words instead of a bar.
A run that did not finish (diverged, failed) is marked so wherever its budget is shown
(marked): its numbers are over the steps before it stopped. Rank 0 only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, TypeGuard

from matplotlib.figure import Figure  # no pyplot: no global backend state

PARTS = ("total", "discretisation", "algorithm", "model")
DECADES = 4  # the axis spans this many decades below the largest part
COLOURS = {
    "total": "#333333",
    "discretisation": "#1f77b4",
    "algorithm": "#ff7f0e",
    "model": "#2ca02c",
}
LABELS = {
    "total": "total: against the truth",
    "discretisation": "discretisation: our implicit on its mesh",
    "algorithm": "algorithm: against our implicit on its mesh",
    "model": "model",
}


class BudgetRow(Protocol):
    """What the figure reads of a leaderboard row (workflows/leaderboard/rows.py's Row)."""

    label: str
    status: str
    budget: dict


STOPPED = {  # what a run's errors cover when it did not finish its steps, by its status
    "diverged": "the steps before it diverged",
    "failed": "the steps before it failed",
    "reference diverged": "the steps before the reference diverged",
}


def covers(status: str) -> str:
    """What a row's errors and budget (time means and maxima over its steps) cover: "every
    step" for a run that finished (status ok); a diverged or failed run's are over the steps
    before it stopped, and are no measure of the run as a whole."""
    if status == "ok":
        return "every step"
    return STOPPED.get(status, f"what was graded ({status})")


def marked(label: str, status: str, short: bool = False) -> str:
    """A row's label where its errors or budget are shown: as it is for a run that finished,
    else with its status and, unless short, what its numbers cover ("explicit-lumped
    (diverged: over the steps before it diverged)")."""
    if status == "ok":
        return label
    return f"{label} ({status})" if short else f"{label} ({status}: over {covers(status)})"


def measured(value: float | None) -> TypeGuard[float]:
    """A part that was measured and can be drawn on a log axis (0 is drawn at the axis)."""
    return value is not None and math.isfinite(value) and value >= 0


def budget_rows(rows: Sequence[BudgetRow]) -> list[BudgetRow]:
    """The rows that have a budget with a measured total, the largest total first (drawn at
    the top of the figure last: smallest at the bottom)."""
    kept = [r for r in rows if r.budget and measured(r.budget.get("total"))]
    return sorted(kept, key=lambda r: r.budget["total"])


def plot_budget(path: Path, title: str, rows: list[BudgetRow], unit: str) -> bool:
    """Draw the budget of `rows` to path (PNG); False (nothing written) when no row has one.
    `unit` is E_i's ("m^3" or "m^2")."""
    kept = budget_rows(rows)
    if not kept:
        return False
    values = [r.budget[p] for r in kept for p in PARTS if measured(r.budget.get(p))]
    positive = [v for v in values if v > 0]
    # the axis spans DECADES below the largest part: a part below that (round-off, where a
    # run is our implicit by another code) is said in words, not drawn down to 1e-16
    floor = max(min(positive) / 3, max(positive) * 10.0**-DECADES) if positive else 1e-12
    height = 0.8 / len(PARTS)
    fig = Figure(figsize=(9, 1.0 + 0.42 * len(kept) * len(PARTS) / 2), layout="constrained")
    ax = fig.add_subplot()
    drawn: set[str] = set()
    for i, r in enumerate(kept):
        for k, part in enumerate(PARTS):
            y = i + (k - (len(PARTS) - 1) / 2) * height
            value = r.budget.get(part)
            if measured(value) and value > floor:
                ax.barh(y, value - floor, left=floor, height=height * 0.9, color=COLOURS[part],
                        label=LABELS[part] if part not in drawn else None)  # fmt: skip
                drawn.add(part)
            else:
                said = "not measured"
                if measured(value):
                    said = "0" if value == 0 else f"{value:.1g} (below the axis)"
                ax.text(floor, y, f"  {part}: {said}", va="center", fontsize=6, color=COLOURS[part])
    ax.set_xscale("log")
    ax.set_ylim(-0.5, len(kept) - 0.5)
    ax.set_yticks(range(len(kept)), [marked(r.label, r.status, True) for r in kept], fontsize=7)
    ax.set_xlabel(f"time-mean E_i ({unit})")
    ax.grid(True, axis="x", which="both", alpha=0.25)
    ax.legend(loc="lower right", fontsize=7)
    ax.set_title(title, fontsize=9, wrap=True)
    fig.savefig(path, dpi=110)
    return True
