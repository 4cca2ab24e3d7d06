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
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter, NullLocator

from tissuebench.metrics.table import METRICS, panels
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.models import LINEAR, split_label
from tissuebench.workflows.io.tables import spans_decades
from tissuebench.workflows.reports.style import (
    DIVERGED_FILL,
    HEAT_CMAP,
    MARKERS,
    STYLES,
    CaseView,
    model_style,
    plot_curve,
)
from tissuebench.workflows.summary import CaseSummary

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

DEFORMATION = "deformation.json"
SHAPE_MODELS = ("linear", "corotational", "neo-hookean")  # shapes.png: the implicit runs of these
SHAPE_ALGORITHM = "implicit"


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


# --- the grid of runs ----------------------------------------------------------------------


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


# --- deformation.json: the largest deflection, the smallest J ------------------------------


# the corners of the reference cells in VTK order: [0, 1]^2 and [0, 1]^3
VTK_CORNERS = {
    4: np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float),
    8: np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        dtype=float,
    ),
}


def gauss_points(d: int) -> np.ndarray:
    """The 2 x ... x 2 Gauss points on [0, 1]^d: the points at which the solver checks J
    (solvers/elastic.py, quadrature degree 2)."""
    g = 0.5 + np.array([-1.0, 1.0]) / (2 * np.sqrt(3.0))
    return np.stack(np.meshgrid(*([g] * d), indexing="ij"), axis=-1).reshape(-1, d)


def shape_gradients(corners: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Gradients of the Q1 shape functions of the reference corners at the points xi:
    (points, corners, d)."""
    # N_a(xi) = prod_k (c_ak xi_k + (1 - c_ak)(1 - xi_k)); dN_a/dxi_j drops factor j for 2 c_aj - 1
    factors = corners[None] * xi[:, None] + (1 - corners[None]) * (1 - xi[:, None])
    d = corners.shape[1]
    grads = np.empty(factors.shape)
    for j in range(d):
        others = np.prod(np.delete(factors, j, axis=2), axis=2)
        grads[..., j] = (2 * corners[None, :, j] - 1) * others
    return grads


def jacobians(points: np.ndarray, cells: np.ndarray, displacements: np.ndarray) -> np.ndarray:
    """J = det F at the Gauss points of every cell, (steps, cells, points), for displacements
    (steps, nodes, d) on a Q1 mesh with cells in VTK order: the ratio of the deformed to the
    undeformed determinant of the map from the reference cell."""
    X = np.asarray(points, dtype=float)
    u = np.asarray(displacements, dtype=float)
    d = X.shape[1]
    grads = shape_gradients(VTK_CORNERS[cells.shape[1]], gauss_points(d))

    def determinants(x):  # x: (..., nodes, d) -> (..., cells, points)
        # A[..., c, q, i, j] = sum_n x[cells[c, n], i] dN_n/dxi_j (q): one matrix product
        A = np.moveaxis(np.tensordot(x[..., cells, :], grads, axes=([-2], [1])), -3, -2)
        if d == 2:
            return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]
        return np.einsum("...i,...i->...", np.cross(A[..., 0], A[..., 1]), A[..., 2])

    return determinants(X + u) / determinants(X)[None]


def deformation_data(folder: Path, summary: CaseSummary, cache: dict | None = None) -> dict:
    """deformation.json's content from the runs' series: those in `cache` ({label: Series}),
    the others read from their XDMF files in folder into it, for the figures that follow."""
    from tissuebench.metrics.series import InputError
    from tissuebench.workflows.io.series import read_series

    cache = {} if cache is None else cache
    ref = summary.reference
    result: dict[str, Any] = {"largest_deflection": None, "smallest_J": {}}
    for label, run in summary.runs.items():
        try:
            series = cache[label] if label in cache else read_series(folder / f"{label}.xdmf")
        except InputError:  # a run that diverged at step 0 keeps no step
            continue
        cache[label] = series
        u = np.asarray(series.displacements)
        if label == ref:
            norms = np.linalg.norm(u, axis=2).max(axis=1)
            k = int(np.argmax(norms))
            node = int(np.argmax(np.linalg.norm(u[k], axis=1)))
            result["largest_deflection"] = {
                "label": label,
                "step": k,
                "time": float(series.times[k]),
                "u_max": float(norms[k]),
                "node": [float(x) for x in series.points[node]],
            }
        J = jacobians(series.points, series.cells, u).min(axis=2)  # (steps, cells)
        per_step = J.min(axis=1)
        k = int(np.argmin(per_step))

        def centre(step):
            cell = series.cells[int(np.argmin(J[step]))]
            return [float(x) for x in series.points[cell].mean(axis=0)]

        result["smallest_J"][label] = {
            "J": float(per_step[k]),
            "step": k,
            "time": float(series.times[k]),
            "cell_centre": centre(k),
            "last_step": len(u) - 1,
            "J_last_step": float(per_step[-1]),
            "cell_centre_last_step": centre(-1),
        }
    return result


# --- shapes.png ----------------------------------------------------------------------------


def silhouette(points: np.ndarray, cells: np.ndarray, u: np.ndarray) -> BaseGeometry:
    """The deformed domain seen along z as a shapely geometry: in 2D the union of the deformed
    quadrilaterals (the polygon through the deformed boundary nodes, as SPEC section 6 takes
    it), in 3D the union of the convex hulls of each deformed hexahedron's corners projected on
    the x-y plane (the side view)."""
    from shapely import make_valid, union_all
    from shapely.geometry import MultiPoint, Polygon

    x = np.asarray(points, dtype=float) + np.asarray(u, dtype=float)
    if cells.shape[1] == 4:
        pieces = [make_valid(Polygon(x[c])) for c in cells]
    else:
        pieces = [MultiPoint(x[c, :2]).convex_hull for c in cells]
    return union_all(pieces)


def draw_outline(ax: Axes, geometry: BaseGeometry, **style) -> None:
    """Draw every exterior and interior ring of a (multi)polygon; the first ring carries the
    label."""
    polygons = getattr(geometry, "geoms", [geometry])
    first = True
    for polygon in polygons:
        if polygon.geom_type != "Polygon" or polygon.is_empty:
            continue
        for ring in [polygon.exterior, *polygon.interiors]:
            xy = np.asarray(ring.coords)
            unlabelled = cast(dict[str, Any], {} if first else {"label": None})
            ax.plot(xy[:, 0], xy[:, 1], **{**style, **unlabelled})  # later rings: no label
            first = False


def boundary_nodes(cells: np.ndarray) -> np.ndarray:
    """The nodes on the boundary of a Q1 mesh: those of the edges (quadrilaterals) or faces
    (hexahedra) that belong to one cell only."""
    from tissuebench.metrics.series import HEX_FACES, QUAD_EDGES

    facets = cells[:, QUAD_EDGES if cells.shape[1] == 4 else HEX_FACES]
    facets = facets.reshape(-1, facets.shape[-1])
    keys, counts = np.unique(np.sort(facets, axis=1), axis=0, return_counts=True)
    return np.unique(keys[counts == 1])


def shapes_figure(
    folder: Path, case_name: str, summary: CaseSummary, deformation: dict, cache: dict | None = None
) -> Figure | None:
    """shapes.png: the implicit runs of SHAPE_MODELS (those present) at the step of the
    reference's largest deflection; left the whole body, right the square about the boundary
    nodes where the drawn shapes are farthest apart (left out when that square is more than
    half the body's size). None if no shape can be drawn."""
    from matplotlib.patches import Rectangle

    from tissuebench.metrics.series import InputError
    from tissuebench.workflows.io.series import read_series

    cache = {} if cache is None else cache
    largest = deformation.get("largest_deflection")
    _, models, labels = grid(summary)
    shown = [m for m in SHAPE_MODELS if (SHAPE_ALGORITHM, m) in labels]
    if largest is None or not shown:
        return None
    step = largest["step"]
    series = {}
    for m in shown:
        label = labels[SHAPE_ALGORITHM, m]
        if label not in cache:
            try:
                cache[label] = read_series(folder / f"{label}.xdmf")
            except InputError:  # diverged at step 0: nothing to draw
                continue
        series[m] = cache[label]
    if not series:
        return None
    first = next(iter(series.values()))
    points, cells = first.points, first.cells
    dim = points.shape[1]
    ref_model = split_label(summary.reference)[1]
    undeformed = silhouette(points, cells, np.zeros_like(points))
    shapes, absent = {}, {}
    for m, s in series.items():
        if step < len(s.displacements):
            shapes[m] = s.displacements[step]
        else:
            absent[m] = summary.runs[labels[SHAPE_ALGORITHM, m]].diverged_time
    # the window: the square about the boundary nodes where the drawn shapes are farthest apart
    # (at least 60 % of the largest distance), padded
    edge = boundary_nodes(cells)
    keys = list(shapes)
    spread = np.zeros(len(edge))
    for i, a in enumerate(keys):
        for b in keys[i + 1 :]:
            spread = np.maximum(spread, np.linalg.norm((shapes[a] - shapes[b])[edge, :2], axis=1))
    far = edge[spread >= 0.6 * spread.max()] if len(keys) > 1 else edge[:1]
    x = np.concatenate([points[far, :2] + shapes[m][far, :2] for m in keys])
    lo, hi = x.min(axis=0), x.max(axis=0)
    centre = (lo + hi) / 2
    extent = float(np.ptp(points, axis=0).max())
    half = max(0.6 * float((hi - lo).max()), 0.08 * extent)
    apart = float(spread.max())

    zoom = 2 * half <= 0.5 * extent  # a larger square would show little more than the whole
    fig = Figure(figsize=(12, 5.8) if zoom else (7.5, 6.2), layout="constrained")
    axes = np.atleast_1d(cast(Any, fig.subplots(1, 2 if zoom else 1)))  # numpy's stubs: no Axes
    order = sorted(keys, key=lambda m: m != ref_model)  # the wide reference first, underneath
    for ax in axes:
        draw_outline(ax, undeformed, color="k", ls=":", lw=1.0, label="undeformed")
        for m in order:
            color, dash = model_style(m)
            wide = m == ref_model
            draw_outline(
                ax,
                silhouette(points, cells, shapes[m]),
                color=color,
                ls=dash,
                lw=5 if wide else 1.7,
                alpha=0.4 if wide else 1.0,
                zorder=2 if wide else 3,
                label=f"{labels[SHAPE_ALGORITHM, m]}"
                + (" (reference: wide, pale)" if wide else ""),
            )
        ax.set_aspect("equal")
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
    view = "boundary outline" if dim == 2 else "side view: the mesh projected on x-y"
    if zoom:
        axes[1].set_xlim(centre[0] - half, centre[0] + half)
        axes[1].set_ylim(centre[1] - half, centre[1] + half)
        axes[0].add_patch(
            Rectangle(
                (centre[0] - half, centre[1] - half),
                2 * half,
                2 * half,
                fill=False,
                ec="0.2",
                lw=1.0,
                label="the square enlarged on the right",
            )
        )
        axes[0].set_title(f"whole body, {view}", fontsize=10)
        axes[1].set_title(
            f"enlarged ({2 * half:.2g} m square): the outlines are up to {1000 * apart:.3g} mm "
            "apart",
            fontsize=10,
        )
    else:
        axes[0].set_title(
            f"{view}; the outlines are up to {1000 * apart:.3g} mm apart", fontsize=10
        )
    handles, names = axes[0].get_legend_handles_labels()
    for m, t in absent.items():
        names.append(f"{labels[SHAPE_ALGORITHM, m]}: diverged at t = {t:.3g} s, not drawn")
        handles.append(axes[0].plot([], [], color=model_style(m)[0], ls=model_style(m)[1])[0])
    fig.legend(handles, names, loc="outside lower center", ncols=3 if zoom else 2, fontsize=9)
    fig.suptitle(
        f"{case_name}: deformed shape at the reference's largest deflection,"
        + (" " if zoom else "\n")
        + f"t = {largest['time']:.3g} s (largest nodal |u| {largest['u_max']:.3g} m)",
        fontsize=11,
    )
    return fig


# --- tip_path.png --------------------------------------------------------------------------


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
