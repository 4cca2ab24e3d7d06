"""The leaderboard as a document (`tissuebench leaderboard`): one figure per case (accuracy
against cost, the Pareto front, against the truth below) and leaderboard.md (each case's
table, its runs against the truth with their error budget, and the runs across mesh sizes),
from the ranked rows of workflows/leaderboard/rows.py. Rank 0 only. Every text that was read is
escaped (rows.md, rows.plain).
"""

from __future__ import annotations

import hashlib
import math
import os
import platform
import textwrap
from pathlib import Path
from typing import cast

from tissuebench.core import interrupt
from tissuebench.meshes import get_entry
from tissuebench.workflows.leaderboard.budget import budget_rows, marked
from tissuebench.workflows.leaderboard.rows import (
    E_I,
    E_N,
    RANK_RULE,
    RANKED_BY,
    Board,
    Row,
    finite,
    fmt,
    md,
    plain,
    ranked_error,
    truth_error,
)
from tissuebench.workflows.run import style
from tissuebench.workflows.run.style import place_labels

LABELLED = 24  # a case with more runs shown labels its Pareto front only
STAMP = "tissuebench-figure"  # the PNG text key that holds the hash of the code that drew it
DECADES = 6  # the E_i axis spans at most this many decades below the largest error


@interrupt.drawing  # a signal while drawing: raised once drawn (core/interrupt.py)
def plot_case(path: Path, board: Board, rows: list[Row]) -> None:
    """Two panels, time-mean and maximum E_i against wall time per simulated second (log-log),
    one marker and colour per source (the same in every panel, in one legend below the
    panels, where it covers no point), the Pareto front as a dashed staircase, the reference's
    cost as a dotted line; labels on every point, or on the front's when more
    than LABELLED are shown (a user's always, by its label), each moved clear of the labels
    before it; a group of rows (our runs on simplices) has its own marker, and labels on the
    front only. When rows were graded against the truth (SPEC 10), a second row of two panels:
    the same against the truth, with the truth's own error as a dotted line."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    against_truth = any(truth_error(r, k) for r in rows for k in ("mean", "max"))
    fig = Figure(figsize=(12, 10.6 if against_truth else 5.6), layout="constrained")
    FigureCanvasAgg(fig)  # a renderer, to place the labels
    axes = fig.subplots(2 if against_truth else 1, 2, squeeze=False)
    reference = next((r for r in rows if r.reference), None)
    not_shown = [r for r in rows if not r.reference and (r.status != "ok" or r.cost is None)]
    colours = {
        s: f"C{k % 10}" for k, s in enumerate(dict.fromkeys(r.group or r.source for r in rows))
    }
    labels: dict = {}  # each panel's point labels, placed last
    for ax, kind in zip(axes[0], ("mean", "max"), strict=True):
        labels[ax] = _panel(
            ax,
            rows,
            colours,
            lambda r, kind=kind: ranked_error(r, kind),
            lambda r, kind=kind: r.pareto.get(kind),
            f"{'time-mean' if kind == 'mean' else 'maximum'} interior error E_i, same mesh "
            f"against {plain(reference.label) if reference else 'the reference'}",
        )
        if reference is not None and reference.cost is not None:
            ax.axvline(
                reference.cost,
                ls=":",
                color="0.5",
                lw=1,
                label=f"cost of the reference {plain(reference.label)} (E = 0)",
            )
    if against_truth:
        band = board.truth_band
        for ax, kind in zip(axes[1], ("mean", "max"), strict=True):
            labels[ax] = _panel(
                ax,
                rows,
                colours,
                lambda r, kind=kind: truth_error(r, kind),
                lambda r, kind=kind: r.truth_pareto.get(kind),
                f"{'time-mean' if kind == 'mean' else 'maximum'} E_i against the truth "
                f"{plain(board.truth)} (SPEC 10); front labelled",
                front_only=True,
            )
            if finite(band) and band > 0:
                ax.axhline(
                    band, ls=":", color="0.5", lw=1, label=f"the truth's own E_i max {band:.2g}"
                )
    for ax in axes.flat:  # where: in the title (the rows' timing session's machine)
        ax.set_xlabel("wall time per simulated second (s/s)")
    legend: dict = {}  # one entry per label, from every panel
    for ax in axes.flat:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            legend.setdefault(label, handle)
    fig.legend(
        list(legend.values()),
        list(legend),
        loc="outside lower center",
        ncols=min(len(legend), 6 if max(map(len, legend), default=0) < 40 else 4),  # long: fewer
        fontsize=8,
    )
    title = textwrap.wrap(f"{board.name}: {board.description}", 150)
    title.append(f"wall times measured on {board.machine or machine()}")
    if not_shown:
        title += textwrap.wrap(
            f"not shown (failed or diverged): {', '.join(plain(r.label) for r in not_shown)}",
            150,
        )
    fig.suptitle("\n".join(title), fontsize=10)
    for ax, placed in labels.items():  # once the layout (legend, title) is settled
        place_labels(fig, ax, placed)
    fig.savefig(path, format="png", dpi=110, metadata={STAMP: drawing_code()})


def _sources_hash(*files: str) -> str:
    digest = hashlib.sha256()
    for file in files:
        digest.update(Path(file).read_bytes())
    return digest.hexdigest()


# read once, as this module loads: the code this process draws with, not the files as they are
# when a figure is saved (a render of many minutes while the files were edited stamped figures
# drawn by the old code with the new code's hash, and they were never drawn again)
_LOADED = _sources_hash(__file__, style.__file__)


def drawing_code() -> str:
    """The SHA-256 of the code that draws a case's figure (this module and run/style.py, as this
    process loaded them), stamped into each PNG, so that a figure drawn by other code is drawn
    again."""
    return _LOADED


def stamp_of(path: Path) -> str | None:
    """The drawing code's hash stamped into a PNG (its tEXt chunk STAMP), None without one."""
    data = path.read_bytes()
    at = 8  # the signature, then chunks: length, type, data, CRC
    while at + 8 <= len(data):
        length = int.from_bytes(data[at : at + 4], "big")
        kind, body = data[at + 4 : at + 8], data[at + 8 : at + 8 + length]
        if kind == b"tEXt" and body.startswith(STAMP.encode() + b"\0"):
            return body[len(STAMP) + 1 :].decode("latin-1")
        if kind == b"IDAT":
            return None  # text chunks before the image only
        at += 12 + length
    return None


def _panel(
    ax, rows: list[Row], colours: dict[str, str], error_of, on_front, ylabel: str, front_only=False
) -> list[tuple[str, tuple[float, float]]]:
    """One log-log panel of plot_case: error_of(row) (None: not shown) against cost, one marker
    per source or group in its colour, the front (on_front(row)) as a dashed staircase; the
    labels to place (the front's only when front_only: against the truth, runs of one mesh
    crowd one error) are returned, (text, (x, y)) each, to be placed once the layout is done."""
    markers = {"tissuebench": "o", "CalculiX": "s", "SfePy": "^", "Newton": "D", "Drake": "h",
               "MuJoCo": "X", "Kratos": "p", "user": "*"}  # fmt: skip
    shown = [r for r in rows if (error_of(r) or 0) > 0 and r.cost is not None and r.cost > 0]
    # the axis spans at most DECADES below the largest error: a point below (round-off, a run
    # that is the reference by another code) sits on the axis's floor, said in the legend
    errors = [error_of(r) for r in shown]
    floor = max(errors) * 10.0**-DECADES if errors else 0.0
    if errors and min(errors) < floor:
        raw = error_of
        error_of = lambda r: max(raw(r), floor)  # noqa: E731
        ax.axhline(
            floor,
            color="0.75",
            lw=0.8,
            label=f"E_i more than {DECADES} decades below the largest: drawn on this line",
        )
    labels: list[tuple[str, tuple[float, float]]] = []
    crowded = front_only or sum(r.group is None for r in shown) > LABELLED
    for source in dict.fromkeys(r.group or r.source for r in shown):
        group = [r for r in shown if (r.group or r.source) == source]
        marker = "v" if group[0].group else markers.get(source.split()[0], "P")
        ax.scatter(
            [r.cost for r in group],
            [error_of(r) for r in group],
            marker=marker,
            s=46,
            color=colours[source],
            label=plain(source),
            zorder=3,
        )
        for r in group:
            if (crowded or r.group) and not on_front(r) and r.source != "user":
                continue  # a crowd, or a group: only its front is labelled (the table has all)
            # a simulator's variant without the simulator's name
            text = plain(r.label if r.source == "user" else r.label.split(":", 1)[-1])
            labels.append((text, (cast(float, r.cost), error_of(r))))  # shown: with a cost
    front = sorted((r for r in shown if on_front(r)), key=lambda r: cast(float, r.cost))
    if front:
        ax.step(
            [r.cost for r in front],
            [error_of(r) for r in front],
            where="post",
            ls="--",
            color="0.3",
            lw=1,
            label="Pareto front",
            zorder=2,
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylabel("\n".join(textwrap.wrap(ylabel, 46)), fontsize=9)  # a long reference: 2 lines
    ax.grid(True, which="both", alpha=0.25)
    return labels


def table(rows: list[Row]) -> list[str]:
    """The markdown table of one case's rows: the reference first, then the finished rows by
    E_i max over the steps, the best first, ties by label (rows.RANK_RULE; the time-mean in
    the column beside it), then the rest."""
    head = (
        "| run | source | mesh, dofs | status | E_i mean | E_i max | E_n max | wall (s) "
        "| s per simulated s | µs per dof per simulated s | Pareto (mean/max) |"
    )
    lines = [head, "|" + "---|" * 11]

    def key(r: Row):
        e = r.errors.get(f"{E_I}_{RANKED_BY}")
        return (not r.reference, r.status != "ok", e if finite(e) else math.inf, r.label)

    for r in sorted(rows, key=key):
        status = md(r.status if not r.reason else f"{r.status}: {r.reason}")
        front = "/".join("yes" if r.pareto.get(k) else "-" for k in ("mean", "max"))
        lines.append(
            f"| {md(r.label)}{' (reference)' if r.reference else ''} | {md(r.source)} | "
            f"{md(r.mesh)}, {r.dofs} | {status} | {fmt(r.errors.get(f'{E_I}_mean'))} | "
            f"{fmt(r.errors.get(f'{E_I}_max'))} | {fmt(r.errors.get(f'{E_N}_max'))} | "
            f"{fmt(r.wall_time_s)} | {fmt(r.cost)} | {fmt(r.cost_per_dof)} | {front} |"
        )
    return lines


def truth_table(rows: list[Row]) -> list[str]:
    """The markdown table of one case's rows graded against the truth, the best E_i max over
    the steps against the truth first, ties by label (rows.RANK_RULE; its time-mean beside
    it); the same-mesh E_i mean (SPEC 6) beside them, unchanged."""
    head = (
        "| run | source | mesh, dofs | E_i mean, truth | E_i max, truth | E_n max, truth "
        "| E_i mean, same mesh (SPEC 6) | s per simulated s | Pareto against the truth "
        "(mean/max) |"
    )
    lines = [head, "|" + "---|" * 9]
    graded = [r for r in rows if r.truth]

    def key(r: Row):
        e = r.truth.get(f"{E_I}_{RANKED_BY}")
        return (r.status != "ok", e if finite(e) else math.inf, r.label)

    for r in sorted(graded, key=key):
        front = "/".join("yes" if r.truth_pareto.get(k) else "-" for k in ("mean", "max"))
        same = "0 (the reference)" if r.reference else fmt(r.errors.get(f"{E_I}_mean"))
        status = "" if r.status == "ok" else f" ({md(r.status)})"
        lines.append(
            f"| {md(r.label)}{status} | {md(r.source)} | {md(r.mesh)}, {r.dofs} | "
            f"{fmt(r.truth.get(f'{E_I}_mean'))} | {fmt(r.truth.get(f'{E_I}_max'))} | "
            f"{fmt(r.truth.get(f'{E_N}_max'))} | {same} | {fmt(r.cost)} | {front} |"
        )
    return lines


BUDGET_PARTS = ("total", "discretisation", "algorithm", "model")


def budget_table(rows: list[Row]) -> list[str]:
    """The error budget (SPEC 10) of the rows that have one: each part's time-mean E_i, how it
    was measured, and the part that dominates (the largest of discretisation, algorithm and
    model)."""
    lines = [
        "| run | total: against the truth | discretisation: our implicit on its mesh against "
        "the truth | algorithm: against our implicit on its mesh | model | dominates |",
        "|" + "---|" * 6,
    ]
    for r in sorted(
        (r for r in rows if r.budget),
        key=lambda r: cast(float, r.budget["total"]) if finite(r.budget.get("total")) else math.inf,
    ):
        b = r.budget
        cells = []
        for part in BUDGET_PARTS:
            how = b.get(f"{part}_how")
            cells.append(fmt(b.get(part)) + (f" ({md(how)})" if how else ""))
        lines.append(
            f"| {md(marked(r.label, r.status))} | {' | '.join(cells)} | {md(dominant(b))} |"
        )
    return lines


def dominant(budget: dict) -> str:
    """The part of an error budget that dominates (the largest finite one of discretisation,
    algorithm, model) with its share of their sum, or "-" when none is known."""
    parts: dict[str, float] = {p: budget[p] for p in BUDGET_PARTS[1:] if finite(budget.get(p))}
    if not parts:
        return "-"
    top = max(parts, key=lambda p: parts[p])
    total = sum(parts.values())
    return top if total == 0 else f"{top} ({100 * parts[top] / total:.0f} %)"


def unit_of(board: Board) -> str:
    """The unit of E_i on a case (SPEC 6): m^3 in 3D, m^2 in 2D."""
    return "m^3" if get_entry(board.benchmark).gdim == 3 else "m^2"


def truth_header(board: Board, rows: list[Row]) -> str:
    """One line for the case's header on its truth (SPEC 10): the truth and its own error band,
    or why there is none (board.truth_note)."""
    if board.truth is not None and any(r.truth for r in rows):
        return (
            f"Truth (SPEC 10): `{md(board.truth)}`, its own E_i max {fmt(board.truth_band)} "
            f"{unit_of(board)}; every run is also ranked against it (below the table)."
        )
    return f"Truth (SPEC 10): {md(board.truth_note or 'none')}"


def truth_lines(board: Board, rows: list[Row]) -> list[str]:
    """The part of a case's section in leaderboard.md against the truth (SPEC 10): one line
    when the case has none or it is not computed, else its own error band, the table ranked
    against the truth, the rows not graded against it and why, and the error budget."""
    if board.truth is None or not any(r.truth for r in rows):
        return []
    unit = unit_of(board)
    out = [
        f"### Against the truth `{md(board.truth)}` (SPEC 10)",
        "",
        f"Every run graded on its own mesh against the truth {md(board.truth)} (E_i by "
        "quadrature on the truth's cells, E_n at its vertices; metrics/truth.py). The truth's "
        f"own error band: E_i max {fmt(board.truth_band)} {unit} (estimated from its levels, "
        "results/truth.md): an E_i against the truth below it is not resolved. Our `implicit` "
        "ranks here too.",
        "",
        *truth_table(rows),
    ]
    missing = [r for r in rows if not r.truth and r.truth_note]
    if missing:
        out += ["", "Not graded against the truth:", ""]
        out += [f"- {md(r.label)}: {md(r.truth_note)}" for r in missing]
    if any(r.budget for r in rows):
        out += [
            "",
            "#### Error budget (SPEC 10), time-mean E_i (" + unit + ")",
            "",
            "total: the run against the truth; discretisation: our `implicit` on the run's mesh "
            "against the truth; algorithm: the run against our `implicit` on its mesh (SPEC 6); "
            "model: our `implicit` with the run's model against it with the truth's, not "
            "measured here: ours are linear, as the truth, but an outside simulator's elastic "
            "model is its own (MuJoCo's is St Venant-Kirchhoff, whose nonlinearity at this load "
            "stays in its algorithm part). The parts are not additive (the total is "
            "at most their sum).",
            "",
            *(
                [f"![{board.name}: error budget](leaderboard/{board.name}-budget.png)", ""]
                if budget_rows(rows)
                else []
            ),
            *budget_table(rows),
        ]
    return out + [""]


def size_series(boards: list[Board]) -> list[list[Board]]:
    """The cases of each series of mesh sizes (Board.sizes), ordered by mesh size (series of
    two cases or more)."""
    groups: dict[str, list[tuple[int, Board]]] = {}
    for b in boards:
        if b.sizes is not None:
            size = b.mesh_size or get_entry(b.benchmark).mesh_size
            groups.setdefault(b.sizes, []).append((size, b))
    return [[b for _, b in sorted(g, key=lambda x: x[0])] for g in groups.values() if len(g) > 1]


def size_rows(series: list[Board], rows: dict[str, list[Row]]) -> dict[str, list[Row | None]]:
    """label -> its row at each mesh size of the series (None where it did not run), for the
    runs (ours and the simulators') that ran at two sizes or more; users' rows left out."""
    found: dict[str, list[Row | None]] = {}
    for k, board in enumerate(series):
        for r in rows.get(board.name, []):
            if r.source not in ("user", "SPEC 11 frontier"):  # the same runs at every size
                found.setdefault(r.label, [None] * len(series))[k] = r
    return {label: rs for label, rs in found.items() if sum(r is not None for r in rs) > 1}


def growth_lines(series: list[Board], rows: dict[str, list[Row]]) -> list[str]:
    """What the finest mesh of a series changes, in words: for each run that finished at the
    coarsest and the finest size, how many times its cost grew and its E_i max against the
    truth fell (less than 2x: said to have stopped falling, its error not its mesh's), and
    the runs that finished at the coarsest but not at the finest."""
    found = size_rows(series, rows)
    ends = {label: (rs[0], rs[-1]) for label, rs in found.items() if rs[0] is not None and rs[-1]}

    def error(r: Row) -> float | None:
        value = r.truth.get(f"{E_I}_max") if r.status == "ok" else None
        return value if finite(value) and value > 0 else None

    grown = []
    for label, (a, b) in ends.items():
        if error(a) and error(b) and finite(a.cost) and finite(b.cost) and a.cost > 0:
            grown.append(
                (label, b.cost / a.cost, cast(float, error(a)) / cast(float, error(b)), b.cost)
            )
    if not grown:
        return []
    grown.sort(key=lambda g: g[3])
    first, last = series[0], series[-1]
    n0 = first.mesh_size or get_entry(first.benchmark).mesh_size
    n1 = last.mesh_size or get_entry(last.benchmark).mesh_size
    out = [
        f"What the finest mesh changes (n = {n0} to {n1}; cost and E_i max against the truth, "
        "each run against itself, cheapest at the finest first):",
        "",
    ]
    for label, cost, fall, at in grown:
        stalled = " (its error stopped falling: not its mesh's)" if fall < 2 else ""
        change = f"/{fall:.3g}" if fall >= 1 else f"x{1 / fall:.3g}"
        out.append(
            f"- {md(label)}: cost x{cost:.3g} (to {at:.3g} s per simulated s), E_i max "
            f"{change}{stalled}"
        )
    lost = sorted(label for label, (a, b) in ends.items() if a.status == "ok" and b.status != "ok")
    if lost:
        out += ["", f"Finished at n = {n0}, not at n = {n1}: {', '.join(md(x) for x in lost)}."]
    return out + [""]


def size_table(series: list[Board], rows: dict[str, list[Row]]) -> list[str]:
    """The markdown table of the runs across the mesh sizes of one series: against the truth
    (E_i max, m^gdim) and cost (s per simulated s) at each size, the finest's best first."""
    sizes = [b.mesh_size or get_entry(b.benchmark).mesh_size for b in series]
    dofs = []
    for b in series:
        ours = [r for r in rows.get(b.name, []) if r.reference]
        dofs.append(ours[0].dofs if ours else 0)
    head = "| run | " + " | ".join(
        f"n = {n} ({d:,} dofs): E_i max, truth | s per s" for n, d in zip(sizes, dofs, strict=True)
    )
    lines = [head + " |", "|" + "---|" * (1 + 2 * len(series))]
    found = size_rows(series, rows)

    def finest(label: str) -> float:
        for r in reversed(found[label]):
            if r is not None:
                value = r.truth.get(f"{E_I}_max") if r.status == "ok" else None
                return value if finite(value) else math.inf
        return math.inf

    for label in sorted(found, key=finest):
        cells = []
        for r in found[label]:
            if r is None:
                cells += ["not run", ""]
            elif r.status != "ok":
                cells += [md(r.status), fmt(r.cost)]
            else:
                cells += [fmt(r.truth.get(f"{E_I}_max")), fmt(r.cost)]
        lines.append(f"| {md(label)} | " + " | ".join(cells) + " |")
    return lines


def machine() -> str:
    """One line on where the wall times were measured."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{platform.node() or 'this machine'}, {cpu}, {os.cpu_count()} cores, {platform.system()}"
    )


def load_note(load: tuple[float, ...]) -> str:
    """The load average while a case was timed, and what it means for its wall times."""
    if len(load) != 2 or not all(math.isfinite(x) for x in load):
        return ""
    cores = os.cpu_count() or 1
    said = f"; load average {load[0]:.2f} as its timing began, {load[1]:.2f} as it ended"
    if max(load) > cores - 0.5:  # more runnable processes than the timed run's core to spare
        return said + f" on {cores} cores: every core was busy, so its times are upper bounds"
    return said


def sessions_line(boards: list[Board], session: str) -> str:
    """Where and when the wall times were measured: one session, or each case's (its section
    names it: a case rerun alone, `--rerun CASE`, is timed in its own)."""
    sessions = {b.session or session for b in boards}
    machines = {b.machine or machine() for b in boards}
    where = (
        f"on {next(iter(machines))}" if len(machines) == 1 else "on the machine its section names"
    )
    if len(sessions) == 1:
        return f"measured in one session ({next(iter(sessions))}) {where}"
    return f"measured case by case, each in the session its section names, {where}"


def markdown(
    boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]], session: str
) -> str:
    """leaderboard.md."""
    out = [
        "# Leaderboard: accuracy against cost",
        "",
        "Written by `tissuebench leaderboard --out results`. Every run of a case is graded "
        "against the same reference (our `implicit`, with the case's model; the simulators of a "
        "case whose model none of them has, with the model the case gives them instead) by the "
        "same code "
        "as `tissuebench compare`: E_i is the interior error (SPEC 6), E_n the relative nodal "
        "error; time-mean and maximum over steps 1..N. Cost is the wall time per simulated "
        "second, and per dof.",
        "",
        f"Wall times: {sessions_line(boards, session)}; serial (1 rank, 1 "
        "thread). Ours: assembly of M, K and f, the integrator's setup (factorisations) and "
        "its time loop, in process. CalculiX: the whole `ccx` process, including its reading "
        "of the deck and writing of .frd and .dat. SfePy, Newton, Drake and MuJoCo: their "
        "setup and time loop in process (Newton's kernel compilation excluded). Kratos: its "
        "model's creation and time loop in a child process (interpreter start and import "
        "excluded). Each outside run's own line below says what its time covers. A user's "
        "run (`user/`) carries the wall time given to compare. The paper's meshes are small "
        "(336 dofs on the rod): there fixed costs weigh heavily, and single timings of runs "
        "under 0.2 s vary by tens of per cent between sessions; the rod at n = 6 and 12 "
        "shows how each cost grows with the dofs.",
        "",
        f"Each case's tables are {RANK_RULE}, so that a run right only on average (a "
        "quasi-static run on a dynamic case) does not lead. Pareto: a run is on the front when "
        "no other finished run is at most as costly and at most as wrong (better in one), for "
        "the time-mean and for the max; the reference is left out (its error is 0).",
        "",
    ]
    for board in boards:
        out += [
            f"## {board.name}",
            "",
            board.description,
            "",
            truth_header(board, rows[board.name]),
            "",
            f"Timed in the session of {md(board.session or session)}"
            + (f" on {md(board.machine)}" if board.machine else "")
            + load_note(board.load)
            + ".",
            "",
            f"![{board.name}](leaderboard/{board.name}.png)",
            "",
        ]
        out += table(rows[board.name])
        outside = [r for r in rows[board.name] if r.source != "tissuebench"]
        if outside:
            out += ["", "What each outside run is:", ""]
            out += [
                f"- **{md(r.label)}**: {md(r.description)}; mesh: {md(r.mesh)}; timing: "
                f"{md(r.timing)}"
                for r in outside
            ]
        if notes.get(board.name):
            out += ["", *[f"- {md(n)}" for n in notes[board.name]]]
        against = truth_lines(board, rows[board.name])
        if against:
            out += ["", *against[:-1]]
        out.append("")
    for series in size_series(boards):
        names = ", ".join(b.name for b in series)
        out += [
            f"## Against mesh size: {names}",
            "",
            "Each run that ran at several of these mesh sizes: its E_i max against the truth "
            f"({unit_of(series[0])}) and its cost (wall time per simulated second) at each. "
            "The coarse cases' costs are mostly fixed costs (start-up, set-up); the finest "
            "shows how each run's cost grows with its dofs and where refining stops paying "
            "(its E_i stops falling: the run's own algorithm or model error, not its mesh's).",
            "",
            *size_table(series, rows),
            "",
            *growth_lines(series, rows),
        ]
    return "\n".join(out)
