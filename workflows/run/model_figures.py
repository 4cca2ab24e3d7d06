"""Figures of a case with elastic models (SPEC section 8; rank 0 only), in place of the
paper's figures, which one line per run would crowd with twenty runs:

- errors.png: one row of panels per model, one column per metric (E_n, E_s, E_i), one line per
  algorithm in the same colour, dash pattern and marker in every row;
- realism.png: the loss of realism, a heat map of the time-mean E_i of every algorithm (rows)
  with every model (columns) against the reference, on a log colour scale; a run that diverged
  is a hatched grey cell with its divergence time;
- shapes.png: the deformed outlines of the implicit runs with the linear, corotational and
  neo-Hookean models at the reference's largest deflection, over the undeformed outline, and
  the same enlarged where they differ most (the block: the domain's boundary polygon; the rod:
  its side view, the outline of the mesh projected on the x-y plane);
- tip_path.png (a benchmark with a probe point, the rod): the tip's path in the x-y plane and
  its u_y against time, for the implicit run of every model, with each model's static tip
  (its quasi-static run at the end time);
- deformation.json: the numbers these figures and the report take from the runs' XDMF
  series, which are not committed: the step of the reference's largest deflection, and for
  every run its smallest J = det F over the steps it kept, at the Gauss points at which the
  solver checks for inverted elements (2 per direction), with the step and the cell's centre,
  and the same at its last kept step.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, cast

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter, NullLocator

from tissuebench.metrics.table import METRICS, panels
from tissuebench.solvers.models import LINEAR, split_label
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.tables import spans_decades
from tissuebench.workflows.run.deformation import (  # noqa: F401 (read here before)
    VTK_CORNERS,
    deformation_data,
    jacobians,
)
from tissuebench.workflows.run.model_runs import grid, realism_table
from tissuebench.workflows.run.model_shapes import (  # noqa: F401 (read here before)
    boundary_nodes,
    draw_outline,
    shapes_figure,
    silhouette,
)
from tissuebench.workflows.run.style import (
    DIVERGED_FILL,
    HEAT_CMAP,
    MARKERS,
    STYLES,
    CaseView,
    plot_curve,
)
from tissuebench.workflows.run.tip_path import tip_path_figure

DEFORMATION = "deformation.json"


def is_model_case(case: CaseView) -> bool:
    """True if some run of the case has an elastic model other than linear."""
    return any(run.model != LINEAR for run in case.runs)


def case_figures(
    out: Path,
    case: CaseView,
    summary: CaseSummary,
    times: np.ndarray,
    curves: dict,
    tips: dict,
    series: dict | None = None,
) -> list[str]:
    """Write the figures of a case with models into out; return their file names. `series`
    ({label: Series}): the runs' series in memory; the others are read from out."""
    cache = dict(series or {})
    deformation = deformation_data(out, summary, cache)
    (out / DEFORMATION).write_text(json.dumps(deformation, indent=2) + "\n")
    files = [
        save(out / "errors.png", error_figure(case.name, summary, times, curves)),
        save(out / "realism.png", realism_figure(case.name, summary)),
    ]
    shapes = shapes_figure(out, case.name, summary, deformation, cache)
    if shapes is not None:
        files.append(save(out / "shapes.png", shapes))
    if tips:
        files.append(save(out / "tip_path.png", tip_path_figure(case, summary, times, tips)))
    return [*files, DEFORMATION]


def save(path: Path, fig: Figure, dpi: int = 110) -> str:
    fig.savefig(path, dpi=dpi)
    return path.name


# --- errors.png ----------------------------------------------------------------------------


def error_figure(case_name: str, summary: CaseSummary, times: np.ndarray, curves: dict) -> Figure:
    """One row of panels per model, one column per metric that is no variant; in each panel
    one line per algorithm (the reference left out), drawn alike in every row. A diverged run's
    curve ends at its last finite step, with a cross there and a dotted vertical line in its
    colour at the divergence time (gid "diverged:<label>"); the row's title lists them."""
    algorithms, models, labels = grid(summary)
    ref = summary.reference
    shown = [group[0] for group in panels()]
    fig = Figure(figsize=(4.1 * len(shown) + 0.4, 2.45 * len(models) + 1.5), layout="constrained")
    rows = np.atleast_1d(cast(Any, fig.subfigures(len(models), 1)))  # numpy's stubs: no SubFigure
    every = max(1, (len(times) - 1) // 8)
    axes = np.empty((len(models), len(shown)), dtype=object)
    for r, (row, model) in enumerate(zip(rows, models, strict=True)):
        axes[r] = np.atleast_1d(row.subplots(1, len(shown), sharex=True))
        diverged = []
        for k, a in enumerate(algorithms):
            label = labels.get((a, model))
            if label is None or label == ref:
                continue
            run = summary.runs[label]
            if run.status == "diverged":
                diverged.append(f"{a} at t = {run.diverged_time:.3g} s")
            for ax, name in zip(axes[r], shown, strict=True):
                y = np.asarray(curves[label][name], dtype=float)
                color = plot_curve(ax, times, y, k, len(algorithms), every, small=True)
                if run.status == "diverged":
                    ax.axvline(
                        run.diverged_time,
                        color=color,
                        ls=":",
                        lw=1.4,
                        gid=f"diverged:{label}",
                    )
                    finite = np.flatnonzero(np.isfinite(y[1:]))
                    if len(finite):
                        last = finite[-1] + 1
                        ax.plot([times[last]], [y[last]], "x", color=color, ms=8, mew=2, zorder=20)
        title = f"model {model}" + (
            " (the reference's model)" if model == split_label(ref)[1] else ""
        )
        if diverged:
            title += "; diverged (cross, dotted line): " + ", ".join(diverged)
        row.suptitle(title, fontsize=9.5, ha="left", x=0.01)
    for c, name in enumerate(shown):
        column = axes[:, c]
        values = np.concatenate(
            [
                np.asarray(curves[label][name], dtype=float)[1:]
                for (a, m), label in labels.items()
                if label != ref
            ]
            or [np.zeros(0)]
        )
        finite = values[np.isfinite(values)]
        log = spans_decades(finite)
        for r, ax in enumerate(column):
            if log:
                ax.set_yscale("log")
                ax.yaxis.set_major_formatter(LogFormatter())
                ax.yaxis.set_minor_locator(NullLocator())  # twelve panels: minor ticks cost seconds
            if len(finite):
                positive = finite[finite > 0]
                lo = positive.min() / 1.5 if log and len(positive) else 0.0
                ax.set_ylim(lo, finite.max() * (1.5 if log else 1.05) or 1.0)
            ax.grid(True, alpha=0.3)
            ax.set_xlim(0, times[-1])
            if r == 0:
                ax.set_title(METRICS[name].label, fontsize=10)
            if r == len(models) - 1:
                ax.set_xlabel("time t (s)")
    fig.suptitle(
        f"{case_name}: errors against {ref}, one row per model, one line per algorithm "
        f"(h = {summary.h:.4g} s, {summary.num_dofs} dofs)",
        fontsize=11,
    )
    handles = [
        axes[0, 0].plot(
            [],
            [],
            STYLES[k % len(STYLES)][0],
            color=f"C{k % 10}",
            lw=STYLES[k % len(STYLES)][1],
            marker=MARKERS[k % len(MARKERS)],
            ms=4,
            mfc="white",
            label=a,
        )[0]
        for k, a in enumerate(algorithms)
    ]
    fig.legend(
        handles,
        algorithms,
        loc="outside lower center",
        ncols=len(algorithms),
        fontsize=9,
        handlelength=4.5,
    )
    return fig


# --- realism.png ---------------------------------------------------------------------------


def realism_figure(case_name: str, summary: CaseSummary, metric: str = "interior_error") -> Figure:
    """Rows: algorithms; columns: models; each cell the run's time-mean of `metric` against the
    reference over steps 1..N on a log colour scale, its value written in it. A diverged run is
    a hatched grey cell (gid "diverged:<label>") with its divergence time and its time-mean over
    the steps it kept; the reference's own cell says so."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Rectangle

    algorithms, models, table = realism_table(summary, metric)
    values = np.array(
        [
            [c["mean"] if isinstance(c, dict) and c["status"] == "ok" else np.nan for c in row]
            for row in table
        ]
    )
    positive = values[np.isfinite(values) & (values > 0)]
    lo, hi = (positive.min(), positive.max()) if len(positive) else (1e-6, 1e-3)
    if hi <= lo * 1.01:
        lo, hi = lo / 2, hi * 2
    norm = LogNorm(lo, hi)
    cmap = __import__("matplotlib").colormaps[HEAT_CMAP]
    fig = Figure(
        figsize=(2.05 * len(models) + 2.6, 0.95 * len(algorithms) + 1.6), layout="constrained"
    )
    ax = fig.subplots()
    ax.set_xlim(-0.5, len(models) - 0.5)
    ax.set_ylim(len(algorithms) - 0.5, -0.5)
    symbol = METRICS[metric].symbol
    for i, row in enumerate(table):
        for j, cell in enumerate(row):
            box: dict[str, Any] = dict(xy=(j - 0.5, i - 0.5), width=1, height=1)
            if cell is None:
                ax.add_patch(Rectangle(**box, facecolor="white", edgecolor="0.6"))
                ax.text(j, i, "not run", ha="center", va="center", fontsize=8, color="0.4")
            elif cell == "reference":
                ax.add_patch(Rectangle(**box, facecolor="white", edgecolor="0.6"))
                ax.text(
                    j, i, "reference\n(0 by definition)", ha="center", va="center", fontsize=8.5
                )
            elif cell["status"] != "ok":
                ax.add_patch(
                    Rectangle(
                        **box,
                        facecolor=DIVERGED_FILL,
                        edgecolor="0.45",
                        hatch="///",
                        gid=f"diverged:{cell['label']}",
                    )
                )
                partial = (
                    f"\n({symbol} mean to then {cell['mean']:.2g})"
                    if np.isfinite(cell["mean"])
                    else ""
                )
                ax.text(
                    j,
                    i,
                    f"diverged at\nt = {cell['diverged_time']:.3g} s{partial}",
                    ha="center",
                    va="center",
                    fontsize=8,
                    bbox=dict(
                        boxstyle="round,pad=0.15", facecolor="white", edgecolor="none", alpha=0.85
                    ),
                )
            else:
                v = cell["mean"]
                rgba = cmap(norm(v)) if np.isfinite(v) and v > 0 else (1, 1, 1, 1)
                ax.add_patch(Rectangle(**box, facecolor=rgba, edgecolor="white", lw=1.5))
                light = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2] > 0.55
                ax.text(
                    j,
                    i,
                    f"{v:.2e}" if np.isfinite(v) else "n/a",
                    ha="center",
                    va="center",
                    fontsize=10,
                    color="black" if light else "white",
                )
    ax.set_xticks(range(len(models)), models)
    ax.set_yticks(range(len(algorithms)), algorithms)
    ax.xaxis.tick_top()
    ax.xaxis.set_label_position("top")
    ax.set_xlabel("elastic model")
    ax.set_ylabel("algorithm")
    ax.tick_params(length=0)
    for spine in ax.spines.values():
        spine.set_visible(False)
    fig.colorbar(
        ScalarMappable(norm, cmap=cmap),
        ax=ax,
        label=f"time-mean {symbol} (m), log scale",
        shrink=0.9,
    )
    fig.suptitle(
        f"{case_name}: loss of realism, time-mean interior error {symbol} against "
        f"{summary.reference}\nover steps 1..{summary.steps} (t to {summary.end_time:.3g} "
        "s)",
        fontsize=10.5,
    )
    return fig
