"""tip_path.png of a case with elastic models on a benchmark with a probe point, the rod
(model_figures.py): the tip's path in the x-y plane and its u_y against time, for the implicit
run of every model, with each model's static tip (its quasi-static run at the end time)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from tissuebench.solvers.models import LINEAR
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.run.model_runs import SHAPE_ALGORITHM, grid
from tissuebench.workflows.run.style import CaseView, model_style


def static_tips(summary: CaseSummary) -> dict[str, list[float]]:
    """{model: final tip displacement of its quasi-static run (m)} for the runs that reached the
    end time."""
    result = {}
    for label, run in summary.runs.items():
        if run.algorithm == "quasi-static" and run.status == "ok":
            tip = run.tip_displacement_final
            if tip is not None:
                result[run.model] = tip
    return result


def tip_path_figure(case: CaseView, summary: CaseSummary, times: np.ndarray, tips: dict) -> Figure:
    """Left: the tip's position in the x-y plane over the run for the implicit run of each model
    (a cross where a run diverged), each model's static tip (its quasi-static run at the end
    time) as a star; right: its u_y against time, with the static u_y of each model dashed."""
    from tissuebench.meshes import BENCHMARKS

    entry = BENCHMARKS[case.benchmark]
    probe = np.asarray(entry.probe, dtype=float)
    _, models, labels = grid(summary)
    static = static_tips(summary)
    fig = Figure(figsize=(12, 5.4), layout="constrained")
    path_ax, time_ax = fig.subplots(1, 2, width_ratios=[1, 1.3])
    path_ax.plot(
        [probe[0]], [probe[1]], "o", color="0.4", mfc="white", ms=8, label="undeformed tip"
    )
    for k, m in enumerate(models):
        label = labels.get((SHAPE_ALGORITHM, m))
        if label is None or label not in tips:
            continue
        color, dash = model_style(m, k)
        wide = label == summary.reference
        tip = np.asarray(tips[label], dtype=float)
        style = dict(color=color, ls=dash, lw=4.5 if wide else 1.6, alpha=0.4 if wide else 1.0)
        name = label + (" (reference: wide, pale)" if wide else "")
        run = summary.runs[label]
        if run.status == "diverged":
            name += f", diverged at t = {run.diverged_time:.3g} s (cross)"
        path_ax.plot(probe[0] + tip[:, 0], probe[1] + tip[:, 1], **style, label=name)
        time_ax.plot(times[: len(tip)], tip[:, 1], **style, label=name)
        if run.status == "diverged" and len(tip):  # none kept if step 0 diverged
            for ax, xy in (
                (path_ax, probe[:2] + tip[-1, :2]),
                (time_ax, (times[len(tip) - 1], tip[-1, 1])),
            ):
                ax.plot([xy[0]], [xy[1]], "x", color=color, ms=10, mew=2.2, zorder=20)
        if m in static:
            s = np.asarray(static[m])
            path_ax.plot(
                [probe[0] + s[0]],
                [probe[1] + s[1]],
                "*",
                color=color,
                ms=14,
                mec="white",
                zorder=15,
                label=f"quasi-static{'' if m == LINEAR else '+' + m} at "
                f"t = {summary.end_time:.3g} s "
                f"(static tip u = ({s[0]:.4g}, {s[1]:.4g}) m)",
            )
            time_ax.axhline(s[1], color=color, ls=(0, (2, 2)), lw=1.0, zorder=0)
    path_ax.set_xlabel("x (m)")
    path_ax.set_ylabel("y (m)")
    path_ax.set_title(
        f"path of the {entry.probe_label} in the x-y plane\n(axes not to the same scale)",
        fontsize=10,
    )
    path_ax.grid(True, alpha=0.3)
    time_ax.set_xlabel("time t (s)")
    time_ax.set_ylabel("tip displacement u_y (m)")
    time_ax.set_title("u_y against time; thin dashed: each model's static u_y", fontsize=10)
    time_ax.grid(True, alpha=0.3)
    handles, names = path_ax.get_legend_handles_labels()
    fig.legend(handles, names, loc="outside lower center", ncols=2, fontsize=8.5)
    fig.suptitle(
        f"{case.name}: the rod's tip with every model (implicit runs), load scale "
        f"{summary.option('load_scale', 1):g}",
        fontsize=11,
    )
    return fig
