"""The look shared by the figures of part 1 (figures.py) and part 2 (model_figures.py): one
line style and marker per run, one colour and dash per elastic model, the colour maps."""

from typing import Any, Protocol

import numpy as np
from matplotlib.axes import Axes


class CaseView(Protocol):
    """A case as the figures see it (workflows/run/case.py's Case has these): its name, benchmark,
    reference run label and runs (each with its elastic `model`)."""

    name: str
    benchmark: str
    reference: str
    runs: list


# One line style per run, widest first: a run drawn later lies on top of the earlier ones with
# a narrower, differently dashed line, so curves that coincide all stay visible.
STYLES = [
    ("-", 3.4),
    ("--", 2.5),
    ("-.", 1.9),
    (":", 2.2),
    ("-", 1.1),
    ("--", 1.1),
    ("-.", 1.1),
    (":", 1.1),
]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*"]
CMAP = "viridis"
OUTLINE = "#737373"  # the undeformed outline, drawn behind the deformed shape
# one colour and dash per model (shapes.png, tip_path.png); the neo-Hookean reference in black
MODEL_STYLE = {
    "linear": ("C0", "-"),
    "svk": ("C3", "-."),
    "neo-hookean": ("C2", "-"),
    "neo-hookean-barrier": ("C2", ":"),
    "corotational": ("C1", "--"),
}
HEAT_CMAP = "magma_r"  # light: close to the reference; dark: far from it
DIVERGED_FILL = "#d9d9d9"


def model_style(model: str, k: int = 0) -> tuple[str, str]:
    """(colour, dash) of an elastic model's lines; an unknown model takes colour k past the four."""
    return MODEL_STYLE.get(model, (f"C{4 + k}", ":"))


def plot_curve(
    ax: Axes,
    times: np.ndarray,
    y: np.ndarray,
    k: int,
    n: int,
    every: int,
    label: str | None = None,
    small: bool = False,
) -> str:
    """Curve k of n from step 1 on (times in s): its colour, dash pattern, width and markers
    differ from curve to curve, the markers (one per `every` steps) staggered so that they do
    not cover each other. Returns the colour."""
    color, (dash, width) = f"C{k % 10}", STYLES[k % len(STYLES)]
    ax.plot(
        times[1:],
        y[1:],
        dash,
        color=color,
        lw=width,
        label=label,
        zorder=2 + k,
        marker=MARKERS[k % len(MARKERS)],
        ms=4 if small else 5,
        mfc="white",
        mew=1.0 if small else 1.2,
        markevery=(k * every // max(1, n), every),
    )
    return color


LABEL_STEP = 9  # points: how far a label moves down (then up) from one that it would cover


def place_labels(fig, ax, labels: list[tuple[str, tuple[float, float]]]) -> None:
    """Annotate each point (text, (x, y)) beside it, right of it or else left of it, moving a
    label that would cover a label placed before it, a plotted point or the axes' edge down or
    up by LABEL_STEP points until it is clear (at most 6 tries each way and side; then it stays
    where it covers least, joined to its point by a thin line). The axes' layout is settled
    first."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed: list[Any] = list(_marker_boxes(ax))  # what a label must not cover
    for text, xy in labels:
        offsets = [4 + k * LABEL_STEP * sign for k in range(7) for sign in (-1, 1)][1:]
        best = None
        for dy in offsets:
            for side in (1, -1):
                note = ax.annotate(
                    text,
                    xy,
                    textcoords="offset points",
                    xytext=(4 * side, dy),
                    ha="left" if side > 0 else "right",
                    fontsize=7,
                )
                box = note.get_window_extent(renderer)
                cover = sum(_overlap(box, b) for b in placed)
                cover += box.width * box.height - _overlap(box, frame)  # outside the axes
                if best is None or cover < best[0]:
                    if best is not None:
                        best[1].remove()
                    best = (cover, note, box, dy)
                else:
                    note.remove()
                if cover == 0:
                    break
            if best is not None and best[0] == 0:
                break
        assert best is not None  # offsets is not empty
        cover, note, box, dy = best
        if abs(dy) > LABEL_STEP:  # moved away from its point: drawn again, a line joining them
            xytext, ha = note.xyann, note.get_ha()
            note.remove()
            ax.annotate(
                text,
                xy,
                textcoords="offset points",
                xytext=xytext,
                ha=ha,
                fontsize=7,
                arrowprops={"arrowstyle": "-", "color": "0.6", "lw": 0.5, "shrinkA": 0},
            )
        placed.append(best[2])


def _overlap(a, b) -> float:
    """The area (display units squared) two boxes share."""
    return max(0.0, min(a.x1, b.x1) - max(a.x0, b.x0)) * max(0.0, min(a.y1, b.y1) - max(a.y0, b.y0))


def _marker_boxes(ax, half: float = 4.0) -> list:
    """Boxes (display units, 2 half wide) about every point plotted in ax as a marker."""
    from matplotlib.transforms import Bbox

    points = []
    for collection in ax.collections:
        offsets = collection.get_offsets()
        if len(offsets):
            points.append(collection.get_offset_transform().transform(offsets))
    for line in ax.lines:
        if line.get_marker() not in (None, "None", "", " "):
            xy = line.get_xydata()
            if len(xy):
                points.append(line.get_transform().transform(xy))
    return [
        Bbox([[x - half, y - half], [x + half, y + half]])
        for block in points
        for x, y in block
        if np.isfinite(x) and np.isfinite(y)
    ]
