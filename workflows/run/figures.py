"""Figures of a case (rank 0 only): error curves as the paper's Figures 5-11, the rod's tip
with its crossings of the static deflection, and the deformed shape of the reference run (and of
its counterparts on other materials) over the undeformed outline: pictures rendered off-screen
by pyvista, composed with matplotlib (deformed.png) and PIL (reference.gif), the colour bar
beside the pictures, never over them."""

import io
from pathlib import Path
from typing import Any, cast

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter, NullFormatter

from tissuebench.core import interrupt
from tissuebench.meshes import BENCHMARKS
from tissuebench.metrics.series import Series
from tissuebench.metrics.table import METRICS, panels
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.tables import spans_decades
from tissuebench.workflows.run import model_figures
from tissuebench.workflows.run.style import CMAP, OUTLINE, STYLES, CaseView, plot_curve

# Plain log tick labels: matplotlib's mathtext parser takes seconds to load. One panel per
# metric of the table that is no variant, labelled as the table says.
LONG_RUN = 10.0  # s: deformed.png shows (0, 1, 2, 10) s within the run, and its end time


@interrupt.drawing
def case_figures(
    out: Path,
    case: CaseView,
    summary: CaseSummary,
    times: np.ndarray,
    curves: dict,
    tips: dict,
    series: dict | None = None,
) -> list[str]:
    """Write the case's figures into out; return their file names. A case with elastic models
    other than linear (SPEC section 8) has its own figures (workflows/run/model_figures.py).
    `series` ({label: Series}) holds the runs' displacement series that the caller has in
    memory (study, which has just computed them); a run not in it is read from its XDMF file
    in out. Drawn in a critical section (core/interrupt.py)."""
    if model_figures.is_model_case(case):
        return model_figures.case_figures(out, case, summary, times, curves, tips, series)
    files = [error_curves(out / "errors.png", case, summary, times, curves)]
    if tips:
        files.append(tip_history(out / "tip.png", case, summary, times, tips))
    reference = summary.runs[case.reference]
    if reference.status == "ok" or reference.diverged_step:  # a shape to draw
        files += deformed_shapes(out, case, summary, series=series)
    return files


def crossings(t: np.ndarray, y: np.ndarray, level: float) -> list[float]:
    """The times at which the sampled curve y(t) crosses `level` (y - level changes sign),
    each interpolated linearly between the two samples around it. A run of samples exactly at
    the level counts once, at its first sample, when the sign differs on its two sides;
    touching the level without crossing is not a crossing. Non-finite samples are skipped."""
    t = np.asarray(t, dtype=np.float64)
    d = np.asarray(y, dtype=np.float64) - level
    keep = np.flatnonzero(np.isfinite(d) & np.isfinite(t))
    t, d = t[keep], d[keep]
    signed = np.flatnonzero(d != 0)
    result = []
    for a, b in zip(signed[:-1], signed[1:], strict=False):
        if d[a] * d[b] > 0:
            continue
        if b == a + 1:
            result.append(float(t[a] + (t[b] - t[a]) * d[a] / (d[a] - d[b])))
        else:  # samples a+1 .. b-1 lie exactly on the level
            result.append(float(t[a + 1]))
    return result


def static_label(summary: CaseSummary, reference: str) -> str | None:
    """The quasi-static run on the reference's material, or None."""
    runs = summary.runs
    return next(
        (
            label
            for label, run in runs.items()
            if run.algorithm == "quasi-static" and run.material == runs[reference].material
        ),
        None,
    )


# --- error curves --------------------------------------------------------------------------


def error_figure(case: CaseView, summary: CaseSummary, times: np.ndarray, curves: dict) -> Figure:
    """One panel per metric against time, one line per run but the reference (colour, dash pattern,
    width and staggered markers differ from run to run). A diverged run's curve ends at its
    last finite step; a dotted vertical line in its colour (gid "diverged:<label>") marks the
    time at which it diverged, the time its legend entry gives."""
    shown = [(group[0], METRICS[group[0]].label) for group in panels()]
    fig = Figure(figsize=(8, 3.2 * len(shown)), layout="constrained")
    axes = fig.subplots(len(shown), 1, sharex=True, squeeze=False)[:, 0]
    labels = [label for label in curves if label != case.reference]
    every = max(1, (len(times) - 1) // 8)
    for ax, (name, title) in zip(axes, shown, strict=True):
        values = []
        for k, label in enumerate(labels):
            run = summary.runs[label]
            y = curves[label][name]
            text = label
            if run.status == "diverged":
                text += (
                    f": diverged at step {run.diverged_step}, "
                    f"t = {run.diverged_time:.3g} s (dotted line)"
                )
                ax.axvline(
                    run.diverged_time,
                    color=f"C{k % 10}",
                    ls=":",
                    lw=1.6,
                    gid=f"diverged:{label}",
                )
            plot_curve(ax, times, y, k, len(labels), every, label=text)
            values.append(y[1:])
        if values and spans_decades(np.concatenate(values)):
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(LogFormatter())
            ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_ylabel(title)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time t (s)")
    ref = summary.runs[case.reference]
    fig.suptitle(
        f"{case.name}: errors against {case.reference} ({ref.material}), "
        f"h = {summary.h:.4g} s, {summary.num_dofs} dofs",
        fontsize=11,
    )
    handles, names = axes[0].get_legend_handles_labels()
    if handles:  # below the panels: clear of the curves and of the title
        fig.legend(
            handles,
            names,
            loc="outside lower center",
            ncols=2 if len(names) > 3 else len(names),
            fontsize=8,
            handlelength=4.5,
        )
    return fig


def error_curves(
    path: Path, case: CaseView, summary: CaseSummary, times: np.ndarray, curves: dict
) -> str:
    error_figure(case, summary, times, curves).savefig(path, dpi=110)
    return path.name


# --- the rod's tip -------------------------------------------------------------------------


def tip_figure(case: CaseView, summary: CaseSummary, times: np.ndarray, tips: dict) -> Figure:
    """The vertical displacement of the probe point against time, one line per run: the
    reference wide and pale underneath, the others narrower and dashed on top of it. Where a
    quasi-static run on the reference's material exists, its last value is the static
    deflection; a second panel then shows each run's distance from it, u_y minus the static
    deflection, on a symmetric log scale (linear within a band about 0), where the oscillation
    about the static shape stays visible as it decays. The reference's crossings of the static
    deflection (interpolated linearly between steps) are marked in both panels by dotted
    vertical lines (gid "crossing"), with their times."""
    from matplotlib.ticker import FuncFormatter, SymmetricalLogLocator

    ref = case.reference
    static = static_label(summary, ref)
    level = None if static is None else float(tips[static][-1, 1])
    fig = Figure(figsize=(9, 5 if level is None else 8), layout="constrained")
    axes = np.atleast_1d(  # numpy's stubs take no Axes, which atleast_1d takes
        cast(
            Any,
            fig.subplots(
                1 if level is None else 2,
                1,
                sharex=True,
                height_ratios=None if level is None else [3, 2],
            ),
        )
    )
    others = [label for label in tips if label not in (ref, static)]
    shifts = [0.0] if level is None else [0.0, level]
    for ax, shift in zip(axes, shifts, strict=True):
        ax.plot(
            times[: len(tips[ref])],
            tips[ref][:, 1] - shift,
            "-",
            color="C0",
            lw=6,
            alpha=0.45,
            zorder=1,
            label=f"{ref} (reference: wide, pale)",
        )
        for k, label in enumerate(others, start=1):
            dash, width = STYLES[1 + (k - 1) % (len(STYLES) - 1)]
            ax.plot(
                times[: len(tips[label])],
                tips[label][:, 1] - shift,
                dash,
                color=f"C{k}",
                lw=min(width, 1.8),
                zorder=2 + k,
                label=label,
            )
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("tip displacement u_y (m)")
    axes[0].set_title(
        f"{case.name}: vertical displacement of the {BENCHMARKS[case.benchmark].probe_label}"
    )
    if level is not None:
        tip = tips[ref]
        axes[0].plot(
            times[: len(tips[static])],
            tips[static][:, 1],
            "--",
            color="k",
            lw=1.1,
            zorder=10,
            label=f"{static}: the static deflection {level:.4g} m from step 1 on",
        )
        axes[1].axhline(0.0, color="k", ls="--", lw=1.1, zorder=10)
        cross = crossings(times[: len(tip)], tip[:, 1], level)
        d = tip[1:, 1] - level
        peaks = [
            np.abs(d[(times[1 : len(tip)] > a) & (times[1 : len(tip)] < b)]).max(initial=0.0)
            for a, b in zip([0.0, *cross], [*cross, times[len(tip) - 1] + 1], strict=True)
        ]
        peaks = [x for x in peaks if x > 0]
        linthresh = max(min(peaks, default=1.0) / 10, 1e-15)
        axes[1].set_yscale("symlog", linthresh=linthresh, linscale=0.6)
        decades = np.log10(max(peaks, default=1.0) / linthresh)
        axes[1].yaxis.set_major_locator(
            SymmetricalLogLocator(linthresh=linthresh, base=10 ** max(1, round(decades / 4)))
        )
        axes[1].yaxis.set_major_formatter(
            FuncFormatter(
                lambda v, _: "0" if v == 0 else ("" if abs(v) < 1.5 * linthresh else f"{v:.0e}")
            )
        )
        axes[1].yaxis.set_minor_formatter(NullFormatter())
        axes[1].set_ylabel("u_y - static deflection (m)\nsymmetric log scale")
        for j, tc in enumerate(cross):
            for ax, y in zip(axes, (level, 0.0), strict=True):
                ax.axvline(
                    tc,
                    color="0.25",
                    ls=":",
                    lw=1.2,
                    zorder=0,
                    gid="crossing",
                    label=f"{ref} crosses the static deflection (interpolated)"
                    if j == 0 and ax is axes[0]
                    else None,
                )
                ax.plot([tc], [y], "o", color="k", mfc="white", ms=6, zorder=11)
            right = tc > 0.9 * times[-1]
            axes[0].annotate(
                f"{tc:.2f} s",
                (tc, level),
                xytext=(-4 if right else 4, 10 if j % 2 == 0 else -16),
                textcoords="offset points",
                fontsize=8,
                ha="right" if right else "left",
            )
    axes[-1].set_xlabel("time t (s)")
    axes[0].legend(fontsize=8, loc="upper right", handlelength=4)
    return fig


def tip_history(
    path: Path, case: CaseView, summary: CaseSummary, times: np.ndarray, tips: dict
) -> str:
    tip_figure(case, summary, times, tips).savefig(path, dpi=110)
    return path.name


# --- deformed shapes -----------------------------------------------------------------------


def shape_rows(case: CaseView, summary: CaseSummary) -> list[str]:
    """The runs whose deformed shape is drawn: the reference, and the runs of the same
    algorithm on other materials (the MP1 counterpart of implicit-MP2), sorted by material."""
    runs = summary.runs
    ref = runs[case.reference]
    rows = [case.reference] + [
        label
        for label, run in runs.items()
        if label != case.reference
        and run.algorithm == ref.algorithm
        and run.material != ref.material
        and run.status == "ok"
    ]
    return sorted(rows, key=lambda label: (runs[label].material, label))


def shown_steps(
    times: np.ndarray, shown: tuple[float, ...] = (0.0, 1.0, 2.0, LONG_RUN)
) -> list[int]:
    """Steps nearest the times `shown` within the run, and the last step if it is not among them."""
    wanted = [t for t in shown if t <= times[-1] + 1e-12] + [times[-1]]
    return list(dict.fromkeys(int(np.argmin(np.abs(times - t))) for t in wanted))


def _pad3(a):
    out = np.zeros((len(a), 3))
    out[:, : a.shape[1]] = a
    return out


class ShapeRenderer:
    """Off-screen pictures of one mesh deformed by a displacement: faces coloured by |u| on the
    fixed scale clim, no lighting (the colours are the colour map's), cell edges, and the
    undeformed outline behind. The camera is fixed for every picture: the block seen from +z,
    the rod from the side it bends to (its long side face, a little from above and from its
    free end); parallel projection."""

    def __init__(self, series, clim, bounds, size):
        import pyvista as pv
        from vtkmodules.vtkCommonCore import vtkLogger

        vtkLogger.SetStderrVerbosity(
            vtkLogger.VERBOSITY_OFF
        )  # no display here: off-screen is intended
        self.dim = series.dim
        self.x0 = _pad3(series.points)
        cell_type = {
            "triangle": pv.CellType.TRIANGLE,
            "quadrilateral": pv.CellType.QUAD,
            "tetrahedron": pv.CellType.TETRA,
            "hexahedron": pv.CellType.HEXAHEDRON,
        }[series.cell_type]
        undeformed = pv.UnstructuredGrid({cell_type: series.cells}, self.x0.copy())
        outline = undeformed.extract_surface(algorithm="dataset_surface").extract_feature_edges(
            feature_angle=30,
            boundary_edges=True,
            feature_edges=self.dim == 3,
            manifold_edges=False,
            non_manifold_edges=False,
        )
        self.grid = undeformed.copy()
        self.grid.point_data["|u| (m)"] = np.zeros(len(self.x0))
        p = pv.Plotter(off_screen=True, window_size=size, border=False)
        p.set_background("white")
        p.add_mesh(outline, color=OUTLINE, line_width=3)
        p.add_mesh(
            self.grid,
            scalars="|u| (m)",
            cmap=CMAP,
            clim=clim,
            show_edges=True,
            edge_color="#333333",
            line_width=0.6 if self.dim == 2 else 1.2,
            lighting=False,
            show_scalar_bar=False,
        )
        p.enable_parallel_projection()
        if self.dim == 2:
            p.view_xy()
        else:
            direction = np.array([0.45, 0.35, 1.0])
            p.camera.focal_point = [0.0, 0.0, 0.0]
            p.camera.position = direction / np.linalg.norm(direction)
            p.camera.up = (0.0, 1.0, 0.0)
        p.reset_camera(bounds=bounds)
        # Behind: moved away from the camera along the view direction by twice the size of
        # the scene. In parallel projection that leaves its picture where it was, and every
        # part of the deformed shape lies in front of it.
        view = np.asarray(p.camera.GetDirectionOfProjection())
        outline.points = (
            outline.points + 2.0 * float(np.ptp(np.reshape(bounds, (3, 2)), axis=1).max()) * view
        )
        outline.Modified()
        p.reset_camera_clipping_range()
        self.plotter = p

    def image(self, u: np.ndarray) -> np.ndarray:
        u = _pad3(u)
        self.grid.points = self.x0 + u
        self.grid.point_data["|u| (m)"] = np.linalg.norm(u, axis=1)
        self.plotter.render()
        return np.asarray(self.plotter.screenshot(return_img=True))

    def resize(self, size: tuple[int, int]) -> None:
        """Pictures of `size` pixels from now on, framed as before (the aspect ratio is kept)."""
        self.plotter.window_size = size

    def close(self) -> None:
        self.plotter.close()


def crop(images: list[np.ndarray], pad: int = 6) -> list[np.ndarray]:
    """The images cut to the union of their non-white pixels (the same box for all, so that
    every picture keeps the same scale)."""
    mask = np.zeros(images[0].shape[:2], dtype=bool)
    for img in images:
        mask |= np.any(img[..., :3] < 250, axis=-1)
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if len(rows) == 0:
        return images
    r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, mask.shape[0])
    c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, mask.shape[1])
    return [img[r0:r1, c0:c1] for img in images]


def shape_grid(
    case: CaseView,
    summary: CaseSummary,
    series: Series,
    steps: list[int],
    images: list,
    clim: tuple[float, float],
    row_labels: list[str],
) -> Figure:
    """deformed.png's figure: one row per run, one column per time, one colour bar beside."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    nrows, ncols = len(images), len(steps)
    h, w = images[0][0].shape[:2]
    panel = 2.9
    fig = Figure(figsize=(ncols * panel + 1.3, nrows * panel * h / w + 0.9), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False)
    times = series.times
    for r in range(nrows):
        for c, step in enumerate(steps):
            ax = axes[r, c]
            ax.imshow(images[r][c], interpolation="antialiased")
            ax.set_xticks([])
            ax.set_yticks([])
            for spine in ax.spines.values():
                spine.set_visible(False)
            if r == 0:
                ax.set_title(f"t = {times[step]:.3g} s", fontsize=10)
            if c == 0:
                ax.set_ylabel(row_labels[r], fontsize=10)
    fig.colorbar(
        ScalarMappable(Normalize(*clim), cmap=CMAP),
        ax=axes,
        label="|u| (m)",
        shrink=0.9,
        aspect=25 * nrows,
    )
    what = " and ".join(row_labels)
    fig.suptitle(
        f"{case.name}: deformed shape of {what}, one colour scale; grey: undeformed outline",
        fontsize=10,
    )
    return fig


def colour_bar(clim: tuple[float, float], height: int, dpi: int = 100) -> np.ndarray:
    """A vertical colour bar of |u| with its ticks and label, as an RGB picture `height` pixels
    tall."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    fig = Figure(figsize=(1.0, height / dpi), dpi=dpi)
    ax = fig.add_axes((0.08, 0.05, 0.17, 0.9))
    fig.colorbar(ScalarMappable(Normalize(*clim), cmap=CMAP), cax=ax, label="|u| (m)")
    return _rgba(fig, dpi)


def animation(
    path: Path,
    frames: list,
    titles: list[str],
    labels: list[str],
    clim: tuple[float, float],
    width: int = 280,
    fps: int = 10,
) -> None:
    """A GIF: each frame's pictures side by side (scaled to `width` pixels), a label above each,
    the frame's title above all and the colour bar beside them, clear of the pictures. Composed
    with PIL: the colour bar is drawn once."""
    from matplotlib import font_manager
    from PIL import Image, ImageDraw, ImageFont

    h0, w0 = frames[0][0].shape[:2]
    size = (width, max(1, round(h0 * width / w0)))
    font = ImageFont.truetype(font_manager.findfont("DejaVu Sans"), 13)
    small = ImageFont.truetype(font_manager.findfont("DejaVu Sans"), 11)
    bar = Image.fromarray(colour_bar(clim, size[1]))
    top, gap, margin = 44, 12, 8
    canvas = (margin + len(labels) * (size[0] + gap) + bar.width, top + size[1] + margin)
    template = Image.new("RGB", canvas, "white")
    template.paste(bar, (margin + len(labels) * (size[0] + gap), top))
    draw = ImageDraw.Draw(template)
    for k, label in enumerate(labels):
        draw.text(
            (margin + k * (size[0] + gap) + size[0] // 2, top - 4),
            label,
            fill="black",
            font=small,
            anchor="md",
        )
    pictures = []
    for pics, title in zip(frames, titles, strict=True):
        frame = template.copy()
        for k, pic in enumerate(pics):
            picture = Image.fromarray(pic)
            if picture.size != size:
                picture = picture.resize(size, Image.Resampling.LANCZOS)
            frame.paste(picture, (margin + k * (size[0] + gap), top))
        ImageDraw.Draw(frame).text((canvas[0] // 2, 6), title, fill="black", font=font, anchor="ma")
        pictures.append(frame)
    # one palette for every frame (no flicker), from the first, middle and last frames and the
    # whole colour map (so that colours the sampled frames lack keep their own entries)
    from matplotlib import colormaps

    frames_rgb = [np.asarray(pictures[k]) for k in (0, len(pictures) // 2, -1)]
    ramp = (255 * colormaps[CMAP](np.linspace(0, 1, canvas[0]))[:, :3]).astype(np.uint8)
    sample = Image.fromarray(
        np.vstack([*frames_rgb, np.repeat(ramp[None], canvas[1] // 2, axis=0)])
    )
    palette = sample.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    pictures = [frame.quantize(palette=palette, dither=Image.Dither.NONE) for frame in pictures]
    buffer = io.BytesIO()
    pictures[0].save(
        buffer,
        format="GIF",
        save_all=True,
        append_images=pictures[1:],
        duration=1000 // fps,
        loop=0,
    )
    path.write_bytes(buffer.getvalue())


def _rgba(fig, dpi):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def deformed_shapes(
    out: Path, case: CaseView, summary: CaseSummary, frames: int = 30, series: dict | None = None
) -> list[str]:
    """deformed.png (the reference, and its counterparts on other materials, at a few times)
    and reference.gif (their animation), from the runs' series in `series` ({label: Series})
    or else read from their XDMF output."""
    from PIL import Image

    from tissuebench.workflows.io.series import read_series

    runs = summary.runs
    labels = shape_rows(case, summary)
    given = series or {}
    series = [
        given[label] if label in given else read_series(out / f"{label}.xdmf") for label in labels
    ]
    row_labels = [
        f"{label} ({runs[label].material}{', reference' if label == case.reference else ''})"
        for label in labels
    ]
    times = series[0].times
    norms = [max(float(np.linalg.norm(u, axis=1).max()) for u in s.displacements) for s in series]
    clim = (0.0, max(norms) or 1.0)
    x0 = _pad3(series[0].points)
    lo, hi = x0.min(axis=0), x0.max(axis=0)
    for s in series:
        for u in s.displacements:
            x = x0 + _pad3(u)
            lo, hi = np.minimum(lo, x.min(axis=0)), np.maximum(hi, x.max(axis=0))
    bounds = [lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]]
    size = (520, 440) if series[0].dim == 3 else (460, 460)
    renderer = ShapeRenderer(series[0], clim, bounds, size)
    try:
        steps = shown_steps(times)
        still = [[renderer.image(s.displacements[step]) for step in steps] for s in series]
        renderer.resize(
            (round(0.7 * size[0]), round(0.7 * size[1]))
        )  # the GIF's smaller pictures render faster
        gif_steps = np.unique(np.linspace(0, len(times) - 1, frames).round().astype(int))
        moving = [[renderer.image(s.displacements[step]) for s in series] for step in gif_steps]
    finally:
        renderer.close()

    flat = crop([img for row in still for img in row])
    still = [flat[r * len(steps) : (r + 1) * len(steps)] for r in range(len(series))]
    flat = crop([img for row in moving for img in row])
    moving = [flat[k * len(series) : (k + 1) * len(series)] for k in range(len(gif_steps))]
    # RGB, no alpha channel: a smaller file, the same picture
    picture = _rgba(shape_grid(case, summary, series[0], steps, still, clim, row_labels), 110)
    Image.fromarray(picture).save(out / "deformed.png")  # optimize=True: 7 times as long, 5 % less

    labels = [f"{label} ({runs[label].material})" for label in labels]
    animation(
        out / "reference.gif",
        moving,
        [f"{case.name}, t = {times[k]:.2f} s" for k in gif_steps],
        labels,
        clim,
    )
    return ["deformed.png", "reference.gif"]
