"""What the documents of results/README.md share (study/report.py, claims.py, large_deformation.py,
divergence.py, truth_section.py): the summaries' readings, the claims' margins, the Verdict of a
claim, the metric table of a case, what the claims read in the runs' files (the tip's crossings, the
distance from the static solution) and the helpers of part 2 (what each run loses against the
reference, where a cell lies).

Every verdict says on which summary of the error curves it is judged. The summaries are those
of summary.json (SPEC section 6): the time-mean and the maximum over steps 1..N."""

import json
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tissuebench.meshes import get_entry
from tissuebench.metrics.table import METRICS as TABLE
from tissuebench.solvers.models import run_label, split_label
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.text import fmt
from tissuebench.workflows.run.figures import crossings, static_label

# the claims are read on the metrics of the table that are no variant (E_n, E_s, E_i)
METRICS = tuple(name for name, m in TABLE.items() if m.variant_of is None)
READINGS = {"mean": "time-mean", "max": "maximum"}
FAR = 10  # 'far less' taken as ten times less
ROUGHLY = 2  # 'roughly the sum' taken as within a factor 2
SETTLED = 1e-6  # 'the same static solution' taken as agreeing to 1e-6, relative
ABOUT = 0.05  # 'at about t = 4.2 s' taken as within 5 %
PAPER_CROSSING = 4.2  # s, SPEC section 7
LARGE_DEFORMATION = "large-deformation"  # the folder of part 2 (SPEC section 8) in the output
LOSS_READING = "interior_error"  # the loss of realism: the time-mean E_i (m) against the reference


@dataclass
class Verdict:
    """A claim judged on our numbers: one of SPEC section 7 or one that part 2 makes.

    `claim`: SPEC 7's number, or the claim in words; `holds`: the verdict on the reading it
    rests on (None: not judged); `checks`: each part of the judgement, {(metric, reading):
    bool} where the claim is judged per metric and summary, {name: bool} otherwise;
    `numbers`: the values it rests on, by name (E_n and E_s dimensionless, E_i in m^d, times
    in s, displacements in m)."""

    claim: int | str
    holds: bool | None
    checks: dict[Any, bool] = field(default_factory=dict)
    numbers: dict[str, Any] = field(default_factory=dict)


def metric_table(summary: CaseSummary) -> str:
    """A case's runs: status, and each metric of the table's max and time-mean, wall time (s)."""
    names = [n for n in TABLE if next(iter(summary.runs.values())).has_reading(n)]
    head = "| run | status | " + " | ".join(
        f"{TABLE[n].symbol} max | {TABLE[n].symbol} mean" for n in names
    )
    head += " | wall time (s) |"
    lines = [head, "|" + "---|" * (3 + 2 * len(names))]
    for label, run in summary.runs.items():
        status = (
            run.status
            if run.status == "ok"
            else f"diverged at step {run.diverged_step} (t = {run.diverged_time:.3g} s)"
        )
        cells = " | ".join(
            f"{fmt(run.reading(n, 'max'))} | {fmt(run.reading(n, 'mean'))}" for n in names
        )
        ref = " (reference)" if label == summary.reference else ""
        lines.append(f"| {label}{ref} | {status} | {cells} | {run.wall_time_s:.2f} |")
    return "\n".join(lines)


def value(
    summary: CaseSummary, label: str, metric: str = "relative_error", reading: str = "mean"
) -> float:
    """A run's summary of a metric, as summary.json holds it (`<metric>_mean`, `<metric>_max`),
    in the metric's unit; NaN where it holds none."""
    v = summary.runs[label].reading(metric, reading)
    return np.nan if v is None else v


def mean(summary: CaseSummary, label: str, metric: str = "relative_error") -> float:
    """A run's time-mean of a metric (the metric's unit)."""
    return value(summary, label, metric, "mean")


def verdict(ok: bool | None) -> str:
    """A verdict in bold."""
    return "**holds**" if ok else "**does not hold**"


def plain(ok: bool | None) -> str:
    """A verdict in plain text."""
    return "holds" if ok else "does not hold"


def first_steps(k: int) -> str:
    """'step 1' or 'steps 1..k'."""
    return "step 1" if k == 1 else f"steps 1..{k}"


def peak_from(curve: np.ndarray, start: int) -> tuple[float, int | None]:
    """(max, step) of a curve over steps start..N, ignoring NaN."""
    tail = curve[start:]
    if not np.isfinite(tail).any():
        return np.nan, None
    k = int(np.nanargmax(tail))
    return float(tail[k]), start + k


# --- the runs' files ------------------------------------------------------------------------


def settled(folder: Path, summary: CaseSummary, steps: list[int] | None = None) -> dict:
    """{label: {step: ||u - u_qs|| / ||u_qs||}}: each run of the case against its quasi-static
    run at the given steps (default: the last), Euclidean norms of all nodal displacement
    components, from the runs' XDMF output. Runs that diverged are left out."""
    from tissuebench.workflows.io.series import read_series

    static = static_label(summary, summary.reference)
    steps = [summary.steps] if steps is None else steps
    us = read_series(folder / f"{static}.xdmf").displacements
    result = {}
    for label, run in summary.runs.items():
        if label == static or run.status != "ok":
            continue
        u = read_series(folder / f"{label}.xdmf").displacements
        result[label] = {
            k: float(np.linalg.norm(u[k] - us[k]) / np.linalg.norm(us[k])) for k in steps
        }
    return result


def tip_crossings(tips: dict, summary: CaseSummary) -> tuple[float, list[float]]:
    """(static tip deflection in m, the reference tip's crossings of it in s, interpolated)."""
    ref = summary.reference
    static = static_label(summary, ref)
    level = float(tips[static][1][-1])
    t, y = tips[ref]
    return level, crossings(t, y, level)


def excursions(
    t: np.ndarray, y: np.ndarray, level: float, times: list[float]
) -> list[tuple[float, float]]:
    """The extreme of y - level between consecutive crossing times (and after the last):
    [(time, y - level)]."""
    edges = [0.0, *times, t[-1] + 1]
    result = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        inside = np.flatnonzero((t > a) & (t < b))
        if len(inside) and a > 0:
            k = inside[np.argmax(np.abs(y[inside] - level))]
            result.append((float(t[k]), float(y[k] - level)))
    return result


# --- part 2's helpers ------------------------------------------------------------------------


def read_deformation(folder: Path) -> dict | None:
    """A case's deformation.json (workflows/run/model_figures.py), or None."""
    try:
        return json.loads((Path(folder) / "deformation.json").read_text())
    except (OSError, ValueError):
        return None


def loss_runs(summary: CaseSummary) -> dict[str, str]:
    """{what is lost: run label} against the reference (ALGORITHM+MODEL): each run differs from
    the reference in one respect (or two, for lumped explicit stepping)."""
    algorithm, model = split_label(summary.reference)
    return {
        "linearisation": run_label(algorithm, "linear"),
        "svk": run_label(algorithm, "svk"),
        "corotational": run_label(algorithm, "corotational"),
        "lumping": run_label("implicit-lumped", model),
        "explicit stepping": run_label("explicit", model),
        "lumped explicit stepping": run_label("explicit-lumped", model),
        "inertia (quasi-static)": run_label("quasi-static", model),
    }


def loss(summary: CaseSummary, label: str) -> tuple[float, str | None, float | None]:
    """(time-mean E_i in m, status, divergence time in s) of a run; (nan, None, None) if it is
    absent."""
    run = summary.runs.get(label)
    if run is None:
        return np.nan, None, None
    v = run.readings.get(f"{LOSS_READING}_mean")
    return (np.nan if v is None else float(v)), run.status, run.diverged_time


def ratio_text(r: float) -> str:
    """A ratio to two significant digits, written out in full above 10."""
    return f"{float(f'{r:.2g}'):.0f}" if r >= 10 else f"{r:.2g}"


def cases_text(names: Iterable[str]) -> str:
    """'a, b and c'."""
    names = list(names)
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def place(summary: CaseSummary, centre: Sequence[float]) -> str:
    """Where a cell centre (m) lies, in words, from the benchmark's geometry (SPEC sections 4,
    5)."""
    x = centre
    text = "(" + ", ".join(f"{c:.3g}" for c in x) + ") m"
    text += get_entry(summary.benchmark).place(x, summary.mesh_size, summary.option)
    return text
