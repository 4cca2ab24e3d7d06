"""Figures of a case (rank 0 only): error curves as the paper's Figures 5-11, the rod's tip,
and the reference run's deformed shape (pyvista, off-screen) as pictures and a GIF."""

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import LogFormatter, NullFormatter

from tissuebench.workflows.files import spans_decades

# Unicode subscripts, and plain log tick labels: matplotlib's mathtext parser takes seconds to load
PANELS = [("relative_error", "relative error E\u2099"), ("surface_error", "surface error E\u209b"),
          ("interior_error", "interior error E\u1d62")]


def case_figures(out, case, summary, times, curves, tips):
    """Write the case's figures into out; return their file names."""
    files = [error_curves(out / "errors.png", case, summary, times, curves)]
    if tips:
        files.append(tip_history(out / "tip.png", case, summary, times, tips))
    files += deformed_shapes(out, case, summary)
    return files


def error_curves(path, case, summary, times, curves):
    """Three panels against time, one line per run but the reference; a diverged run ends
    with a cross where it stopped."""
    fig = Figure(figsize=(8, 9), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    labels = [label for label in curves if label != case.reference]
    colors = {label: f"C{k}" for k, label in enumerate(labels)}
    for ax, (name, title) in zip(axes, PANELS):
        values = []
        for label in labels:
            run = summary["runs"][label]
            y = curves[label][name]
            text = label
            if run["status"] == "diverged":
                text += f" (diverged, t = {run['diverged_time']:.3g} s)"
                last = run["diverged_step"] - 1
                if last >= 1 and np.isfinite(y[last]):
                    ax.plot(times[last], y[last], "x", color=colors[label], ms=10, mew=2)
            ax.plot(times[1:], y[1:], color=colors[label], label=text, lw=1.5)
            values.append(y[1:])
        if values and spans_decades(np.concatenate(values)):
            ax.set_yscale("log")
            ax.yaxis.set_major_formatter(LogFormatter())
            ax.yaxis.set_minor_formatter(NullFormatter())
        ax.set_ylabel(title)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("time t (s)")
    ref = summary["runs"][case.reference]
    axes[0].set_title(f"{case.name}: errors against {case.reference} ({ref['material']}), "
                      f"h = {summary['h']:.4g} s, {summary['num_dofs']} dofs")
    fig.savefig(path, dpi=110)
    return path.name


def tip_history(path, case, summary, times, tips):
    """The vertical displacement of the probe point against time, one line per run."""
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.subplots()
    for label, tip in tips.items():
        style = "--" if summary["runs"][label]["algorithm"] == "quasi-static" else "-"
        ax.plot(times[: len(tip)], tip[:, 1], style, label=label, lw=1.5)
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("tip displacement u_y (m)")
    ax.set_title(f"{case.name}: vertical displacement of the tip (0.5, 0.25, 0.125) m")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    return path.name


def grid(series, step):
    """A pyvista grid of the series' mesh, deformed by the displacement at `step`."""
    import pyvista as pv

    cell_type = pv.CellType.QUAD if series.cell_type == "quadrilateral" else pv.CellType.HEXAHEDRON
    points = np.zeros((len(series.points), 3))
    points[:, : series.dim] = series.points
    u = np.zeros_like(points)
    u[:, : series.dim] = series.displacements[step]
    g = pv.UnstructuredGrid({cell_type: series.cells}, points + u)
    g.point_data["|u| (m)"] = np.linalg.norm(u, axis=1)
    return g


def _plotter(series, shape=(1, 1), size=(900, 700)):
    import pyvista as pv
    from vtkmodules.vtkCommonCore import vtkLogger

    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)  # no display here: off-screen is intended
    pv.global_theme.font.color = "black"
    p = pv.Plotter(off_screen=True, shape=shape, window_size=size, border=False)
    p.set_background("white")
    return p


def _show(p, series, step, clim, title, bar=True):
    _show_grid(p, grid(series, step), series, clim, title, bar)


def _show_grid(p, g, series, clim, title, bar=True):
    p.add_mesh(g, scalars="|u| (m)", cmap="viridis", clim=clim, show_edges=True, show_scalar_bar=bar,
               scalar_bar_args={"title": "|u| (m)", "n_labels": 3, "fmt": "%.3f", "vertical": True,
                                "position_x": 0.78, "position_y": 0.15, "height": 0.7, "width": 0.08})
    if title:
        p.add_text(title, font_size=10, color="black")
    if series.dim == 2:
        p.view_xy()
    else:
        p.view_isometric()
        p.camera.azimuth = -30
    p.reset_camera()


def deformed_shapes(out, case, summary, times_shown=(0.0, 1.0, 2.0, 10.0), frames=30):
    """deformed.png (the reference at a few times) and reference.gif (its animation), read
    back from the reference's XDMF output."""
    from tissuebench.metrics.series import read_series

    series = read_series(out / f"{case.reference}.xdmf")
    times = series.times
    clim = [0.0, max(float(np.linalg.norm(u, axis=1).max()) for u in series.displacements) or 1.0]
    steps = [int(np.argmin(np.abs(times - t))) for t in times_shown if t <= times[-1] + 1e-12]
    p = _plotter(series, shape=(1, len(steps)), size=(380 * len(steps), 420))
    for k, step in enumerate(steps):
        p.subplot(0, k)
        _show(p, series, step, clim, f"{case.reference}, t = {times[step]:.3g} s", bar=k == len(steps) - 1)
    p.screenshot(str(out / "deformed.png"))
    p.close()

    p = _plotter(series, size=(400, 330))
    p.open_gif(str(out / "reference.gif"), fps=10)
    g = grid(series, 0)
    _show_grid(p, g, series, clim, "")
    text = p.add_text("", font_size=10, color="black")
    x0 = np.zeros((len(series.points), 3))
    x0[:, : series.dim] = series.points
    for step in np.unique(np.linspace(0, len(times) - 1, frames).round().astype(int)):
        u = np.zeros_like(x0)
        u[:, : series.dim] = series.displacements[step]
        g.points = x0 + u
        g.point_data["|u| (m)"] = np.linalg.norm(u, axis=1)
        text.set_text("upper_left", f"{case.name} {case.reference}, t = {times[step]:.2f} s")
        p.write_frame()
    p.close()
    return ["deformed.png", "reference.gif"]
