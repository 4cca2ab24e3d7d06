"""The large rod's crease (SPEC 10, "The large rod creases"), reported from its cached truth:
each level's smallest J = det F against time (the truth records it at every step of h), and a
picture of the finest grid's folded cells.

A cell's J is taken at its eight corners from the displacement at the grid's vertices (the
trilinear interpolant of the truth's Q2 field there: exact at the corners for a trilinear
field, a lower resolution than the truth's own quadrature points, where its smallest J is
measured), F = dx dX^-1 from the three cell edges that meet at the corner.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tissuebench.solvers.truth.samples import TruthSamples

CLAMP_VIEW = 0.2  # m: the picture shows the cells whose centre is nearer the clamp than this
FOLDED = 0.1  # J below this at any corner: a folded cell (SPEC 10: "J falls below 0.1")
# the corners of a VTK hexahedron (the truth's cell order) and, for each, its three edge
# neighbours in the order of the reference axes x, y, z (the rod's grid cells are boxes)
HEX_EDGES = (
    (0, 1, 3, 4),
    (1, 0, 2, 5),
    (2, 3, 1, 6),
    (3, 2, 0, 7),
    (4, 5, 7, 0),
    (5, 4, 6, 1),
    (6, 7, 5, 2),
    (7, 6, 4, 3),
)


def corner_jacobians(vertices: np.ndarray, cells: np.ndarray, u: np.ndarray) -> np.ndarray:
    """J = det F at the 8 corners of every hexahedron (cells (c, 8), VTK order) of the
    reference vertices (m) displaced by u (m): (c, 8). F = dx dX^-1 along the corner's edges."""
    x = vertices + u
    out = np.empty(cells.shape, dtype=float)
    for k, (a, *edges) in enumerate(HEX_EDGES):
        dX = np.stack([vertices[cells[:, e]] - vertices[cells[:, a]] for e in edges], axis=-1)
        dx = np.stack([x[cells[:, e]] - x[cells[:, a]] for e in edges], axis=-1)
        out[:, k] = np.linalg.det(dx) / np.linalg.det(dX)
    return out


def fold_time(samples: TruthSamples) -> int:
    """The step (index into samples.times) at which the finest level's smallest J is least."""
    return int(np.argmin(samples.hierarchy["min_jacobian"][-1]))


def plot_jacobians(path: Path, samples: TruthSamples) -> None:
    """Each level's smallest J against time (and the finest level's half step), with the
    place of its least on the finest level: the crease, where the finer levels fold and the
    coarser ones level off."""
    from matplotlib.figure import Figure

    h = samples.hierarchy
    times = np.asarray(samples.times)
    fig = Figure(figsize=(7.0, 4.2))
    ax = fig.add_subplot()
    for n, values in zip(h["levels"], h["min_jacobian"], strict=True):
        ax.plot(times[: len(values)], values, label=f"level n = {n}")
    if "half_min_jacobian" in h:
        half = h["half_min_jacobian"]
        ax.plot(times[: len(half)], half, "k:", label=f"n = {h['levels'][-1]}, half step")
    t, *where = h["min_jacobian_at"][-1]
    least = min(h["min_jacobian"][-1])
    ax.plot([t], [least], "rv")
    place = ", ".join(f"{c:.3f}" for c in where)
    ax.annotate(
        f"least {least:.3g} at t = {t:.3g} s,\nX = ({place}) m",
        (t, least),
        xytext=(0.35, 0.55),
        textcoords="axes fraction",
        arrowprops={"arrowstyle": "->", "color": "0.4"},
    )
    ax.axhline(FOLDED, color="0.6", lw=0.8, ls="--")
    ax.text(0.1, FOLDED, f" J = {FOLDED:g}", va="bottom", color="0.4", fontsize=8)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("smallest J = det F (quadrature points)")
    ax.set_ylim(0, 1.05)
    ax.set_title(f"{samples.case}: the smallest J of each level against time")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def plot_folded(path: Path, samples: TruthSamples) -> tuple[float, int, float]:
    """The finest grid deformed at the step where its smallest J is least, each cell coloured
    by its smallest corner J, the folded cells (J < FOLDED) opaque and the rest faint; a
    pyvista picture seen from below the clamp. Returns (t in s, folded cells, the least corner
    J)."""
    import pyvista as pv

    pv.OFF_SCREEN = True
    i = fold_time(samples)
    cells = np.asarray(samples.cells)
    vertices = np.asarray(samples.vertices)
    u = np.asarray(samples.u_vertices[i])
    corner = corner_jacobians(vertices, cells, u).min(axis=1)
    cell_array = np.hstack([np.full((len(cells), 1), 8), cells]).ravel()
    grid = pv.UnstructuredGrid(
        cell_array, np.full(len(cells), pv.CellType.HEXAHEDRON, dtype=np.uint8), vertices + u
    )
    grid.cell_data["smallest corner J"] = corner
    inside = vertices[cells].mean(axis=1)[:, 0] < CLAMP_VIEW
    near = grid.extract_cells([int(c) for c in np.flatnonzero(inside)])
    folded = int((corner < FOLDED).sum())
    plotter = pv.Plotter(off_screen=True, window_size=[1000, 640])
    plotter.add_mesh(
        near,
        scalars="smallest corner J",
        cmap="inferno",
        clim=(float(min(corner.min(), 0.0)), 1.0),
        show_edges=True,
        scalar_bar_args={"title": "corner J", "vertical": True},
    )
    plotter.add_text(
        f"{samples.case}, finest level (n = {samples.hierarchy['levels'][-1]}), "
        f"t = {samples.times[i]:.3g} s: the part x < {CLAMP_VIEW:g} m of the deformed rod;\n"
        f"{folded} cells with a corner J < {FOLDED:g} (dark), on the compressed lower edges",
        font_size=10,
    )
    # pyvista's stubs type these as unbound wrappers: the calls are pyvista's own examples
    plotter.view_vector((0.5, -0.6, 1.0), viewup=(0.0, 1.0, 0.0))  # type: ignore[arg-type]
    plotter.reset_camera()  # type: ignore[call-arg]
    plotter.camera.zoom(1.25)
    plotter.screenshot(str(path))
    plotter.close()
    return float(samples.times[i]), folded, float(corner.min())


def creased(h: dict) -> bool:
    """Whether a hierarchy folds (SPEC 10): its smallest J falls with every refinement, to
    below FOLDED on the finest level, while the levels move apart."""
    smallest = [min(j) for j in h.get("min_jacobian", [])]
    diffs = [max(d) for d in h.get("level_differences", [])]
    falls = len(smallest) > 1 and all(b < a for a, b in zip(smallest, smallest[1:]))  # noqa: B905
    grows = len(diffs) > 1 and diffs[-1] >= diffs[-2]
    return falls and grows and smallest[-1] < FOLDED


def crease_figures(samples: TruthSamples, folder: Path) -> dict | None:
    """For a hexahedral truth that folds (creased): folder/CASE-J.png (plot_jacobians) and
    folder/CASE-folded.png (plot_folded); returns their names, the fold's time (s), its
    folded cells and least corner J; None (nothing drawn) for any other truth."""
    if samples.cell_type != "hexahedron" or not creased(samples.hierarchy):
        return None
    folder.mkdir(parents=True, exist_ok=True)
    jacobians, picture = folder / f"{samples.case}-J.png", folder / f"{samples.case}-folded.png"
    plot_jacobians(jacobians, samples)
    t, folded, least = plot_folded(picture, samples)
    return {
        "J": f"{folder.name}/{jacobians.name}",
        "folded": f"{folder.name}/{picture.name}",
        "t": t,
        "cells": folded,
        "least_corner_J": least,
    }
