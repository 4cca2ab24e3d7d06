"""The mesh-sensitivity study's report (mesh_sensitivity.py runs it): mesh-sensitivity.md with
the reference's own error and the trade-offs found, mesh-sensitivity.csv, and a figure per
case."""

from __future__ import annotations

from pathlib import Path

from tissuebench.core import interrupt
from tissuebench.meshes import get_entry
from tissuebench.meshes.benchmark import CELLS
from tissuebench.solvers import ALGORITHMS, REFERENCE
from tissuebench.workflows.io.tables import write_rows
from tissuebench.workflows.leaderboard.mesh_sensitivity_cases import MARKER, NAME, Study, shapes
from tissuebench.workflows.leaderboard.rows import fmt


def own_error(rows: list[dict], study: Study) -> float:
    """The reference's own error: E_i max of `implicit` on the grid of size N against 2N."""
    grid = next(iter(shapes(get_entry(study.benchmark).gdim)))
    return next(
        r["interior_error_max"]
        for r in rows
        if r["algorithm"] == REFERENCE and r["shape"] == grid and r["size"] == study.size
    )


def trade_offs(rows: list[dict], floor: float) -> list[tuple[dict, dict, str, float]]:
    """Where a coarser mesh with `implicit` beats, or does not beat, a finer mesh with another
    algorithm at no more cost: for every finished run of another algorithm, the implicit run
    of the same shape on a coarser mesh with the smallest E_i max among those that cost no
    more. (fast, exact, winner, ratio): winner "coarse + exact", "fine + fast" or "none" when
    both E_i are below `floor` (the reference's own error); ratio = larger / smaller E_i."""
    found = []
    for fast in rows:
        if fast["algorithm"] == REFERENCE or fast["status"] != "ok":
            continue
        exact = [
            r
            for r in rows
            if r["algorithm"] == REFERENCE
            and r["shape"] == fast["shape"]
            and r["size"] < fast["size"]
            and r["cost_s_per_s"] <= fast["cost_s_per_s"]
        ]
        if not exact:
            continue
        best = min(exact, key=lambda r: r["interior_error_max"])
        a, b = best["interior_error_max"], fast["interior_error_max"]
        winner = "none" if max(a, b) < floor else "coarse + exact" if a < b else "fine + fast"
        found.append((fast, best, winner, max(a, b) / min(a, b)))
    return found


def trade_off_lines(found: list[tuple[dict, dict, str, float]]) -> list[str]:
    """The table rows of trade_offs, then a summary paragraph."""
    lines = []
    for fast, best, winner, ratio in found:
        verdict = (
            "no finding: both below the reference's own error"
            if winner == "none"
            else f"**{winner} wins** ({ratio:.3g}x smaller E_i)"
        )
        lines.append(
            f"| {fast['shape']} | implicit, size {best['size']}: E_i max "
            f"{best['interior_error_max']:.3g}, {best['cost_s_per_s']:.3g} s/s | "
            f"{fast['algorithm']}, size {fast['size']}: E_i max {fast['interior_error_max']:.3g}, "
            f"{fast['cost_s_per_s']:.3g} s/s | {verdict} |"
        )
    if not lines:
        return ["| — | no implicit run on a coarser mesh costs as little | | |"]
    lines.append("")
    for winner in ("coarse + exact", "fine + fast", "none"):
        mine = [(f, r) for f, _, w, r in found if w == winner]
        if not mine:
            continue
        against = sorted({f["algorithm"] for f, _ in mine}, key=list(ALGORITHMS).index)
        ratios = [r for _, r in mine]
        what = "no finding" if winner == "none" else f"**{winner}** wins"
        lines.append(
            f"- {what} in {len(mine)} of {len(found)} pairings (against "
            f"{', '.join(against)}), by {min(ratios):.3g}x to {max(ratios):.3g}x in E_i max."
        )
    return lines


def timed(studies: list[Study], results: dict) -> str:
    """When the runs were timed: one session, or (a resumed study) which."""
    sessions = sorted({t for s in studies for t in results[s.name]["sessions"]})
    if len(sessions) == 1:
        return f"every run timed in one session, {sessions[0]}."
    return (
        f"runs timed in {len(sessions)} sessions ({', '.join(sessions)}: the study was "
        "resumed), so that ratios across sessions carry the machine's drift."
    )


def markdown(studies: list[Study], results: dict, quick: bool, ranks: int) -> str:
    lines = [
        f"{MARKER}{' (quick check, not the results)' if quick else ''}",
        "",
        "How sensitive each algorithm is to mesh density and mesh shape (the paper's future "
        "work; SPEC 9), written by `tissuebench sensitivity`. Every run is graded on its own "
        "mesh against `implicit` on the grid of twice the finest size (E_n at the reference's "
        "nodes, E_i by quadrature on the reference's cells with u′ located in the candidate's "
        "mesh). The reference's own error is `implicit` on the finest grid against it: below "
        "it, no difference is a finding. Cost: the wall time of the System's assembly, the "
        "integrator's set-up and its time loop, per simulated second, "
        f"{ranks} MPI process(es); {timed(studies, results)}",
        "",
    ]
    for study in studies:
        res = results[study.name]
        rows = res["rows"]
        floor = own_error(rows, study)
        entry = get_entry(study.benchmark)
        options = ", ".join(f"{k} = {v}" for k, v in study.options.items()) or "no options"
        lines += [
            f"## {study.name}",
            "",
            f"{study.benchmark}, {study.material}, {options}; h = {fmt(res['h'], '.4g')} s, "
            f"T = {fmt(res['end_time'], '.4g')} s; sizes {', '.join(map(str, study.sizes))} "
            f"(spacing {', '.join(fmt(entry.cell_size(s), '.4g') for s in study.sizes)} m); "
            f"reference: implicit on the {CELLS[entry.gdim][0]} grid of size "
            f"{res['reference']['size']}. **Reference's own error (E_i max, implicit at size "
            f"{study.size}): {floor:.3g}.**",
            "",
            f"![{study.name}]({NAME}-{study.name}.png)",
            "",
            "| algorithm | mesh | size | nodes | E_n max | E_i max | E_i time-mean | cost (s/s) "
            "| status |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in sorted(
            rows, key=lambda r: (list(ALGORITHMS).index(r["algorithm"]), r["shape"], r["size"])
        ):
            status = (
                "ok" if r["status"] == "ok" else f"diverged at {fmt(r['diverged_time_s'], '.3g')} s"
            )
            lines.append(
                f"| {r['algorithm']} | {r['shape']} | {r['size']} | {r['nodes']} | "
                f"{fmt(r['relative_error_max'])} | {fmt(r['interior_error_max'])} | "
                f"{fmt(r['interior_error_mean'])} | {fmt(r['cost_s_per_s'])} | {status} |"
            )
        diverged = [r for r in rows if r["status"] != "ok"]
        if diverged:
            lines += [
                "",
                f"Diverged at h = {fmt(res['h'], '.4g')} s (an explicit scheme's critical step "
                "shrinks with the cells, faster on simplices: `tissuebench stability`; the "
                "errors above are up to the divergence): "
                + "; ".join(
                    f"{r['algorithm']} on the {r['shape']} of size {r['size']} at "
                    f"t = {fmt(r['diverged_time_s'], '.3g')} s"
                    for r in diverged
                )
                + ".",
            ]
        lines += [
            "",
            "### Coarse and exact against fine and fast, at no more cost",
            "",
            "For every finished run of another algorithm on a finer mesh, the most accurate "
            "`implicit` run of the same shape on a coarser mesh that costs no more (E_i max). "
            "These runs are small: their costs are mostly fixed costs, and single timings "
            "under 0.2 s vary by tens of per cent between sessions.",
            "",
            "| shape | coarse + implicit | fine + faster | verdict |",
            "|---|---|---|---|",
            *trade_off_lines(trade_offs(rows, floor)),
            "",
        ]
    return "\n".join(lines)


def write_csv(path: Path, rows: list[dict]) -> None:
    """mesh-sensitivity.csv: the rows' keys as its header (io/tables.py)."""
    write_rows(path, rows, empty_nan=False)


LINES = ("-", "--", ":")  # the shapes' line styles, in the order of shapes()


@interrupt.drawing  # a signal while drawing: raised once drawn (core/interrupt.py)
def plot(path: Path, study: Study, rows: list[dict]) -> None:
    """E_i max and time-mean against spacing (colour: algorithm; line: mesh shape; diverged
    runs left out), and E_i max against cost; the reference's own error as a grey line."""
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator

    fig = Figure(figsize=(15, 5.4), layout="constrained")
    axes = fig.subplots(1, 3)
    colours = {name: f"C{k}" for k, name in enumerate(ALGORITHMS)}
    shape_names = list(dict.fromkeys(r["shape"] for r in rows))
    line = dict(zip(shape_names, LINES, strict=False))
    keys = ("interior_error_max", "interior_error_mean", "interior_error_max")
    for algorithm in ALGORITHMS:
        for shape in shape_names:
            mine = sorted(
                (
                    r
                    for r in rows
                    if r["algorithm"] == algorithm and r["shape"] == shape and r["status"] == "ok"
                ),
                key=lambda r: r["spacing_m"],
            )
            xs = ([r["spacing_m"] for r in mine],) * 2 + ([r["cost_s_per_s"] for r in mine],)
            for ax, key, x in zip(axes, keys, xs, strict=True):
                ax.plot(
                    x,
                    [r[key] for r in mine],
                    line[shape],
                    marker="o",
                    ms=4,
                    color=colours[algorithm],
                )
    grid = shape_names[0]
    implicit_n = next(
        r
        for r in rows
        if r["algorithm"] == REFERENCE and r["shape"] == grid and r["size"] == study.size
    )
    spacings = sorted({r["spacing_m"] for r in rows})
    for ax, key, what in zip(
        axes, keys, ("max over time", "time-mean", "max over time"), strict=True
    ):
        ax.axhline(implicit_n[key], color="0.5", lw=1.2, zorder=0)
        ax.text(
            0.01,
            implicit_n[key],
            " reference's own error (implicit, grid of size N)",
            color="0.35",
            va="bottom",
            fontsize=7,
            transform=ax.get_yaxis_transform(),
        )
        ax.set_yscale("log")
        ax.set_xscale("log")
        ax.set_ylabel(f"E_i, {what}")
        ax.grid(True, which="both", alpha=0.3)
    for ax in axes[:2]:
        ax.xaxis.set_major_locator(FixedLocator(spacings))
        ax.xaxis.set_minor_locator(NullLocator())
        ax.set_xticklabels([f"{x:.4g}" for x in spacings])
        ax.set_xlabel("mesh spacing (m)")
    axes[2].xaxis.set_minor_formatter(NullFormatter())  # decades only: no crowded labels
    axes[2].set_xlabel("cost: wall time per simulated second (s/s)")
    handles = [Line2D([], [], color=colours[a], marker="o", ms=4, label=a) for a in ALGORITHMS]
    handles += [Line2D([], [], color="k", ls=line[s], label=s) for s in shape_names]
    fig.legend(handles=handles, loc="outside right center", fontsize=8)
    diverged = sorted(
        f"{r['algorithm']} ({r['shape']}, {r['size']})" for r in rows if r["status"] != "ok"
    )
    title = (
        f"Mesh sensitivity, {study.name}: E_i of each run on its own mesh against implicit on "
        f"the grid of size {2 * study.size}"
    )
    if diverged:
        title += "\nleft out, diverged: " + "; ".join(diverged)
    fig.suptitle(title, fontsize=10, wrap=True)
    fig.savefig(path, dpi=110)
