"""The contact study's report (SPEC 12): results/contact/contact.md and contact.csv, the needle
force against time beside the truth's, and the deformed block at t = 2 s with the needle and the
contact pressure along the edge."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tissuebench.meshes import get_entry
from tissuebench.meshes.tools import Tool
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.fallbacks import fallbacks_of
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.contact.study import ALGORITHMS, BENCHMARK, TruthForce, label_of
from tissuebench.workflows.io.tables import read_rows

COLUMNS = (
    "case",
    "run",
    "N",
    "kappa",
    "status",
    "substeps",
    "interior_error_max",
    "interior_error_mean",
    "force_error",
    "interpenetration_max",
    "cost",
)


def fmt(x: object) -> str:
    """A number in a table: three digits, or a dash for None and NaN."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "—"
    return f"{x:.3g}" if isinstance(x, float) else str(x)


def penalty_words(truth: TruthSamples) -> str:
    """SPEC 12's limit of the truth's penalty in words: the finest level with k against 10 k
    (E_i max of their difference beside the truth's own error), or why it was not made."""
    info = truth.hierarchy
    if "penalty_failed" in info:
        return (
            f"The penalty's limit is unchecked: the finest level with 10 k did not run through "
            f"({info['penalty_failed']})."
        )
    if "penalty_difference" not in info:
        return ""
    diff = max(info["penalty_difference"])
    own = truth.own_error["interior_error_max"]
    holds = "meets" if diff < own / 10 else "does not meet"
    where = "at the half step " if "penalty_step" in info else ""
    counted = (
        ", so the difference over 0.9 is counted in the own error as its penalty's part"
        if "penalty" in truth.own_error and diff >= own / 10
        else ""
    )
    return (
        f"The finest level {where}with 10 k differs from it by E_i max {fmt(diff)} m^2: SPEC "
        f"12's limit (under a tenth of the own error, {fmt(own / 10)}) {holds} it{counted}."
    )


def markdown(
    rows: list[dict],
    truths: dict[str, tuple[TruthSamples, TruthForce]],
    missing: list[str],
    unconverged: Sequence[str] = (),
) -> str:
    """contact.md: per contact case, the truth's own errors, then every run's row."""
    lines = [
        "# The needle as contact: what our algorithms lose",
        "",
        "Written by `tissuebench contact --out results`. The block of the paper (1 m square, "
        "fixed left, bottom and top edges, plane strain) pushed by a rigid, frictionless needle "
        f"with a rounded tip (radius R = {needle(BENCHMARK).radius:g} m; 0.16 s m deep at t = 2 s "
        "for a load scale s, held there to t = 10 s). Our algorithms impose the contact by a "
        "penalty k = kappa E / h_e; the truth is Taylor-Hood Q2-Q1 on graded grids with a 100 "
        "times stiffer penalty, checked against 10 times that (see truth.md). Every run is graded "
        "against the truth: E_i (m^2, max and "
        "time-mean), the needle force's error (the largest |F - F_truth| over the largest "
        "|F_truth|), the largest interpenetration of the deformed edge into the needle (m), "
        "and the cost (the run's wall time, set-up included, per simulated second, on this "
        "machine). The truth's force is averaged over two steps (its stiff contact makes the "
        "trapezoidal rule's force alternate from step to step about its mean).",
        "",
    ]
    for case, (truth, force) in truths.items():
        own = truth.own_error
        largest = float(np.linalg.norm(force.force, axis=1).max())
        lines += [
            f"## {case}",
            "",
            f"Truth: own E_i max {fmt(own['interior_error_max'])} m^2 (space "
            f"{fmt(own['space'])}, time {fmt(own['time'])}"
            + (f", the penalty's part {fmt(own['penalty'])}" if "penalty" in own else "")
            + f"); its needle force's own error "
            f"{fmt(force.own_error)} (against the next coarser level {fmt(force.parts['space'])}, "
            f"the half step {fmt(force.parts.get('time'))}, ten times the penalty "
            f"{fmt(force.parts.get('penalty'))}; a dash: not measured); largest force "
            f"{fmt(largest)} N/m. " + penalty_words(truth),
            "",
            "| run | N | kappa | status | sub-steps | E_i max (m^2) | E_i mean (m^2) "
            "| force error | interpenetration (m) | cost (s/s) |",
            "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|",
        ]
        for r in rows:
            if r["case"].startswith(f"{case}-N"):
                lines.append(
                    f"| {r['run']} | {r['N']} | {fmt(float(r['kappa']))} | {r['status']} | "
                    f"{r['substeps']} | {fmt(r['interior_error_max'])} | "
                    f"{fmt(r['interior_error_mean'])} | {fmt(r['force_error'])} | "
                    f"{fmt(r['interpenetration_max'])} | {fmt(r['cost'])} |"
                )
        lines += [
            "",
            f"![needle force, {case}](force-{case}.png)",
            "",
            f"![deformed at t = 2 s, {case}](deformed-{case}.png)",
            "",
        ]
    for case in missing:
        fallback = "".join(
            f" When last computed its levels did not converge: SPEC 12 takes it at s = "
            f"{scale:g}, {c}, above."
            for c, scale in fallbacks_of(case)
        )
        lines += [
            f"## {case}",
            "",
            f"Its truth is not computed: `tissuebench truth {case}`.{fallback}",
            "",
        ]
    for case in unconverged:
        lines += [
            f"## {case}",
            "",
            "Its truth's levels do not converge (truth.md: the E_i between levels grows with "
            "refinement), so nothing is graded against it."
            + "".join(
                f" SPEC 12 takes it at s = {scale:g}: {c}." for c, scale in fallbacks_of(case)
            ),
            "",
        ]
    return "\n".join(lines)


def plot_force(
    path: Path, case: str, folder: Path, force: TruthForce, model: str, h: float
) -> None:
    """The needle force F_x (N/m) against time of the five algorithms (N = 20, kappa = 10)
    and the truth's, with its own error as a band."""
    from matplotlib.figure import Figure

    rows = read_rows(folder / "contact.csv")
    fig = Figure(figsize=(9, 4.8), layout="constrained")
    ax = fig.subplots()
    t = np.arange(len(force.force)) * h
    band = force.own_error * np.linalg.norm(force.force, axis=1).max()
    ax.fill_between(t, force.force[:, 0] - band, force.force[:, 0] + band, color="0.8", lw=0)
    ax.plot(t, force.force[:, 0], "k-", lw=2.0, label="truth (band: its own error)")
    for k, algorithm in enumerate(ALGORITHMS):
        label = label_of(algorithm, model)
        mine = [(float(r["time"]), float(r["force_x"])) for r in rows if r["algorithm"] == label]
        if mine:
            x, y = np.array(mine).T
            ax.plot(x, y, lw=1.0, color=f"C{k}", label=label)
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("needle force F_x (N/m)")
    grid = folder.name.split("-N")[-1].replace("-kappa", ", kappa = ")
    ax.set_title(f"{case}: the force on the rigid needle, N = {grid}, against the truth")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    fig.savefig(path, format="png", dpi=110)


def needle(benchmark: str, scale: float = 1.0) -> Tool:
    """The tool of a contact benchmark at load scale `scale` (meshes/tools/)."""
    make = get_entry(benchmark).tool
    assert make is not None  # a contact case
    return make(load_scale=scale)


def edge_pressure(folder: Path, label: str, t: float, scale: float) -> tuple[np.ndarray, ...]:
    """(deformed x and y of points along the right edge, m, 20 on each of its deformed
    segments; the penalty's pressure k <-g_n> there, Pa) of our run `label` in its case
    folder at time t (s): the pressure the run's penalty applies, not only at the nodes."""
    from tissuebench.solvers.materials import get_material
    from tissuebench.workflows.io.series import read_series
    from tissuebench.workflows.io.summary import read_case_summary

    summary = read_case_summary(folder)
    assert summary is not None  # a case folder of ours
    series = read_series(folder / f"{label}.xdmf", "displacement")
    i = int(np.argmin(np.abs(series.times - t)))
    right = np.isclose(series.points[:, 0], 1.0)
    nodes = series.points[right] + series.displacements[i][right]
    nodes = nodes[np.argsort(series.points[right, 1])]
    s = np.linspace(0.0, 1.0, 20, endpoint=False)[None, :, None]
    x = ((1 - s) * nodes[:-1, None] + s * nodes[1:, None]).reshape(-1, 2)
    x = np.vstack([x, nodes[-1:]])
    E = get_material(summary.runs[label].material).E
    k = float(summary.options["kappa"]) * E * summary.mesh_size  # kappa E / h_e, h_e = 1/N m
    tool = needle(summary.benchmark, scale)
    p = k * np.maximum(-tool.signed_distance(x, tool.centre(float(series.times[i]))), 0.0)
    return x[:, 0], x[:, 1], p


def plot_deformed(
    path: Path,
    case: str,
    truth: TruthSamples,
    scale: float,
    runs: list[tuple[Path, str]],
    t: float = 2.0,
) -> None:
    """The truth's deformed block at time t (s; its cells' edges) with the needle and the
    deformed right edge of our runs (case folder, label); and those runs' contact pressure
    p = k <-g_n> (Pa) along the edge."""
    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure
    from matplotlib.patches import Polygon

    i = int(np.argmin(np.abs(truth.times - t)))
    x = truth.vertices + truth.u_vertices[i]
    tool = needle(CASES[case][0], scale)
    c = tool.centre(float(truth.times[i]))
    fig = Figure(figsize=(12, 5), layout="constrained")
    body, pressure = fig.subplots(1, 2, width_ratios=(1.1, 1))
    cells = truth.cells
    edges = np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [2, 3]], cells[:, [3, 0]]])
    body.add_collection(LineCollection(x[edges], colors="0.55", linewidths=0.3))
    body.add_patch(Polygon(tool.outline(c), closed=True, color="C3", alpha=0.35, lw=0))
    for k, (folder, label) in enumerate(runs):
        ex, ey, p = edge_pressure(folder, label, float(truth.times[i]), scale)
        name = f"{label}, N = {folder.name.split('-N')[-1].replace('-kappa', ', kappa = ')}"
        body.plot(ex, ey, "-", lw=1.2, color=f"C{k}", label=name)
        pressure.plot(ey, p, "-", lw=1.2, color=f"C{k}", label=name)
    body.set_xlim(0.5, 1.2)
    body.set_ylim(0.15, 0.85)
    body.set_aspect("equal")
    body.set_title(f"{case} at t = {truth.times[i]:g} s: the truth (grey cells), the needle (red)")
    body.set_xlabel("x (m)")
    body.set_ylabel("y (m)")
    body.legend(fontsize=8, loc="lower left", title="our deformed edge")
    pressure.set_xlabel("deformed y along the right edge (m)")
    pressure.set_ylabel("contact pressure p = k <-g_n> (Pa)")
    pressure.set_title("our runs' contact pressure along the edge")
    pressure.grid(True, alpha=0.3)
    pressure.legend(fontsize=8)
    fig.savefig(path, format="png", dpi=110)


def paper_section(folder: Path) -> list[str]:
    """The paper report's section on the needle as contact (results/README.md), from the Hertz
    check's record and the contact study's table in `folder`, where they are."""
    import json

    lines = ["## The needle as contact (SPEC 12)", ""]
    hertz = folder / "hertz.json"
    if hertz.is_file():
        r = json.loads(hertz.read_text())
        lines += [
            f"The Hertz check ([contact/hertz.json](contact/hertz.json), `tissuebench hertz`): "
            f"the rigid needle pushed {1e3 * r['depth']:g} mm statically into the linear "
            f"{r['material']} block, solved as the truth is, carries P = {r['P']:.4g} N/m; its "
            f"largest pressure is {100 * r['p0_error']:+.2f} % from Hertz's line contact and its "
            f"contact half-width {100 * r['a_error']:+.2f} % (SPEC 12 asks 1 % and 2 %).",
            "",
        ]
    lines += [
        "The outside simulators with their own contact, graded against the same truths at "
        "N = 10, 20 and 40, are on the leaderboard's contact boards ([leaderboard.md]"
        "(leaderboard.md), with the needle force against time per board).",
        "",
    ]
    table = folder / "contact.csv"
    if not table.is_file():
        return lines
    rows = read_rows(table)
    lines += [
        "Our algorithms with the needle as contact, graded against the contact truths "
        "([contact/contact.md](contact/contact.md), `tissuebench contact`): on the paper's "
        "grid (N = 20) with the default penalty (kappa = 10),",
        "",
        "| case | run | E_i max (m^2) | force error | interpenetration (mm) | cost (s/s) |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in rows:
        if int(r["N"]) == 20 and float(r["kappa"]) == 10.0:
            lines.append(
                f"| {r['case'].split('-N')[0]} | {r['run']} | {fmt(float(r['interior_error_max']))}"
                f" | {fmt(float(r['force_error']))} | "
                f"{fmt(1e3 * float(r['interpenetration_max']))} | {fmt(float(r['cost']))} |"
            )
    return [*lines, ""]
