"""shapes.png of a case with elastic models (model_figures.py): the deformed outlines of the
implicit runs with the linear, corotational and neo-Hookean models at the reference's largest
deflection, over the undeformed outline, and the same enlarged where they differ most."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from tissuebench.solvers.models import split_label
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.run.model_runs import SHAPE_ALGORITHM, SHAPE_MODELS, grid
from tissuebench.workflows.run.style import model_style

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry


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
