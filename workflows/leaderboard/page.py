"""results/leaderboard/index.html: the leaderboard as one page that works offline (opened
straight from disk: no server, no download, no script or stylesheet from anywhere else).

Per case: E_i (time-mean) against the truth, or against the case's reference where the case
has no truth graded, against the cost (wall time per simulated second), log-log, in inline
SVG; the Pareto front, the real-time line (1 s per simulated s) and the truth's own error as a
shaded band; every row of the record is one point (`.pt`, with data attributes: case, source,
model, mesh, and the lines its tooltip shows), a run that did not finish or has no error in a
strip above the plot and one below the axis's floor (0 included) in a strip below it; the
SPEC 11 frontier's runs of the case's truth (results/frontier/frontier.csv) are rows of the
case like any other (frontier_rows.py: grey diamonds, their cost the whole run's as every
row's); filters by source, mesh size (dofs) and model; each user's row by its own label, in
its own colour; the error budget as a dot plot; the Closed division (the case's own mesh and
step) and the Open one (any mesh, step or sub-steps, the frontier's runs included), each
ranked. The little JavaScript at the end only shows tooltips and applies the filters;
every text that was read is escaped (html.escape) and the tooltips are set as text.
"""

from __future__ import annotations

import html
import json
import math
from typing import cast

from tissuebench.workflows.leaderboard.budget import covers, marked
from tissuebench.workflows.leaderboard.figures import sessions_line
from tissuebench.workflows.leaderboard.frontier_rows import (  # noqa: F401 (read here before)
    FRONTIER,
    FrontierRowError,
    frontier_row,
    read_frontier,
)
from tissuebench.workflows.leaderboard.rows import E_I, E_N, Board, Row, finite

# --- what a row is, in the page's words ----------------------------------------------------------

OURS = "ours"
USERS = "users"
COLOURS = {
    OURS: "#1f77b4",
    "CalculiX": "#d62728",
    "SfePy": "#2ca02c",
    "Newton": "#9467bd",
    "Drake": "#8c564b",
    "MuJoCo": "#e377c2",
    "Kratos": "#17becf",
    FRONTIER: "#9a9a9a",
}
USER_COLOURS = ("#ff7f0e", "#000000", "#bcbd22", "#e6194b", "#3cb44b", "#4363d8", "#911eb4")
SHAPES = {OURS: "circle", "CalculiX": "square", "SfePy": "triangle", "Newton": "diamond",
          "Drake": "hexagon", "MuJoCo": "cross", "Kratos": "pentagon", USERS: "star",
          FRONTIER: "diamond"}  # fmt: skip
GROUP_SHAPE = "down"  # our runs on simplices
REAL_TIME = 1.0  # s of wall time per simulated second
TOP_RANKED = 10  # rows of each division shown before "all"


def source_of(row: Row) -> str:
    """The source facet of a row: ours, a simulator's name, or users."""
    if row.source == "tissuebench":
        return OURS
    if row.source == "user":
        return USERS
    if row.source == FRONTIER:
        return FRONTIER
    return row.source.split()[0]


def model_of(board: Board, row: Row) -> str:
    """The elastic model a row ran with: ours name it after +, the simulators were given
    the case's simulator model, a user's is the one stated to compare (--model), else the
    case's, as posed."""
    if row.source == "tissuebench":
        return (
            row.label.split(" ")[0].split("+", 1)[1]
            if "+" in row.label.split(" ")[0]
            else ("linear")
        )
    if row.source == "user":
        return row.model or board.model
    if row.source == FRONTIER:  # the frontier runs the truth's (linear) model
        return board.model
    return board.simulator_model or board.model


def mesh_of(row: Row) -> str:
    """The mesh-size facet of a row: its dofs."""
    return f"{row.dofs:,} dofs" if row.dofs else "dofs not known"


def closed(row: Row, board: Board, case_dofs: int | None) -> bool:
    """Whether a row is in the Closed division: the case's own mesh and step (ours and the
    simulators on the reference's mesh; a user's on a mesh of the case's cells and nodes).
    Every row of the record is at the case's step (users are checked for it)."""
    if row.mesh == "reference":
        return True
    if row.source != "user" or not case_dofs or row.dofs != case_dofs:
        return False
    kind = row.mesh.split(":")[0]
    return kind in ("hexahedra", "quadrilaterals")


def wall_meaning(row: Row) -> str:
    """What a row's wall time covers."""
    if row.source == "tissuebench" and row.timing == "this session":
        return (
            "assembly of M, K and f, the integrator's setup and its time loop, in process, "
            "1 rank (timed in the case's session)"
        )
    if row.source == "user":
        return "as reported by the user to compare (--wall-time)"
    if "timed: " in row.description:
        return row.description.split("timed: ", 1)[1]
    return row.timing


def error_of(row: Row, truth: bool, kind: str = "mean") -> float | None:
    """The E_i (time-mean or max) a row is drawn and ranked by: against the truth, or against
    the reference (0 for the reference itself); None when it has none."""
    value = (row.truth if truth else row.errors).get(f"{E_I}_{kind}")
    if not truth and row.reference:
        return 0.0
    return float(value) if finite(value) and value >= 0 else None


def finished(row: Row) -> bool:
    return row.status == "ok" and finite(row.cost) and row.cost > 0


def g(x) -> str:
    """A number in three significant figures, or a dash."""
    return "-" if not finite(x) else f"{x:.3g}"


def tip_lines(board: Board, row: Row, unit: str) -> list[str]:
    """What hovering over a row's point shows (plain text lines; the first is its label)."""
    ref = row.errors
    lines = [
        row.label + (" (the reference)" if row.reference else ""),
        f"source: {row.source}" + (" (tissuebench)" if row.source == "user" else ""),
        f"mesh: {'the case' + chr(39) + 's own' if row.mesh == 'reference' else row.mesh}; "
        f"{row.dofs:,} dofs",
        f"model: {model_of(board, row)}"
        + (" (the case's: not stated to compare)" if row.source == "user" and not row.model else "")
        + f"; status: {row.status}"
        + (f" ({row.reason})" if row.reason else ""),
        f"against the reference: E_i mean {g(ref.get(E_I + '_mean'))}, max "
        f"{g(ref.get(E_I + '_max'))} {unit}; E_n max {g(ref.get(E_N + '_max'))}",
    ]
    if row.truth:
        t = row.truth
        lines.append(
            f"against the truth {board.truth}: E_i mean {g(t.get(E_I + '_mean'))}, max "
            f"{g(t.get(E_I + '_max'))} {unit}; E_n max {g(t.get(E_N + '_max'))}"
        )
    elif row.truth_note:
        lines.append(f"against the truth: {row.truth_note}")
    b = row.budget
    if b:
        parts = ", ".join(f"{p} {g(b.get(p))}" for p in ("total", "discretisation", "algorithm"))
        over = "" if row.status == "ok" else f", over {covers(row.status)}"
        lines.append(f"budget (time-mean E_i, {unit}{over}): {parts}, model {g(b.get('model'))}")
    lines.append(
        f"cost: {g(row.cost)} s per simulated s (wall {g(row.wall_time_s)} s over "
        f"{g(row.end_time)} s)"
    )
    lines.append(f"wall time: {wall_meaning(row)}")
    if row.source == FRONTIER:  # its loop's own cost, SPEC 11's figure
        lines.append(row.description.split("; timed: ")[0])
    return [" ".join(str(x).split()) for x in lines]


# --- SVG ----------------------------------------------------------------------------------------


def esc(text) -> str:
    return html.escape(" ".join(str(text).split()), quote=True)


def symbol(shape: str, x: float, y: float, r: float = 5.0) -> str:
    """An SVG path's d for a marker centred on (x, y)."""

    def poly(n: int, start: float, radius: float = r) -> str:
        pts = [
            (x + radius * math.cos(start + 2 * math.pi * k / n),
             y + radius * math.sin(start + 2 * math.pi * k / n))
            for k in range(n)
        ]  # fmt: skip
        return "M" + "L".join(f"{a:.1f},{b:.1f}" for a, b in pts) + "Z"

    if shape == "circle":
        return f"M{x - r:.1f},{y:.1f}a{r},{r} 0 1,0 {2 * r},0a{r},{r} 0 1,0 {-2 * r},0Z"
    if shape == "square":
        return poly(4, math.pi / 4, r * 1.2)
    if shape == "triangle":
        return poly(3, -math.pi / 2, r * 1.2)
    if shape == "down":
        return poly(3, math.pi / 2, r * 1.2)
    if shape == "diamond":
        return poly(4, 0, r * 1.2)
    if shape == "hexagon":
        return poly(6, 0, r * 1.1)
    if shape == "pentagon":
        return poly(5, -math.pi / 2, r * 1.15)
    if shape == "star":
        pts = []
        for k in range(10):
            rad = r * 1.8 if k % 2 == 0 else r * 0.8
            a = -math.pi / 2 + math.pi * k / 5
            pts.append((x + rad * math.cos(a), y + rad * math.sin(a)))
        return "M" + "L".join(f"{a:.1f},{b:.1f}" for a, b in pts) + "Z"
    if shape == "cross":
        d = r * 0.9
        a, b, c, e = x - d, x + d, y - d, y + d
        return f"M{a:.1f},{c:.1f}L{b:.1f},{e:.1f}M{a:.1f},{e:.1f}L{b:.1f},{c:.1f}"
    return poly(4, 0)


class Axes:
    """A log-log plot area: cost on x, E_i on y."""

    W, H = 860, 470
    LEFT, RIGHT, TOP, BOTTOM = 78, 24, 44, 410  # the plot area; strips above and below

    def __init__(self, xs: list[float], ys: list[float]):
        xs = [x for x in xs if finite(x) and x > 0] + [REAL_TIME]
        self.x0, self.x1 = math.log10(min(xs)) - 0.15, math.log10(max(xs)) + 0.15
        ys = [y for y in ys if finite(y) and y > 0]
        if not ys:
            ys = [1e-6, 1e-3]
        top = max(ys)
        # the axis shows at most 6 decades below the largest error: below that (round-off,
        # a run that is the reference by another code) a point sits in the strip below
        self.floor = max(min(ys), top * 1e-6)
        self.y0, self.y1 = math.log10(self.floor) - 0.15, math.log10(top) + 0.15

    def x(self, value: float) -> float:
        t = (math.log10(value) - self.x0) / (self.x1 - self.x0)
        return min(max(self.LEFT + t * (self.W - self.RIGHT - self.LEFT), self.LEFT), self.W)

    def y(self, value: float) -> float:
        t = (math.log10(value) - self.y0) / (self.y1 - self.y0)
        return self.BOTTOM - t * (self.BOTTOM - self.TOP)

    def frame(self, ylabel: str) -> list[str]:
        """The axes, decade ticks, grid, strips and labels."""
        out = [
            f'<rect x="{self.LEFT}" y="{self.TOP}" width="{self.W - self.RIGHT - self.LEFT}" '
            f'height="{self.BOTTOM - self.TOP}" fill="none" stroke="#444"/>'
        ]
        for k in range(math.ceil(self.x0), math.floor(self.x1) + 1):
            px = self.x(10.0**k)
            out.append(
                f'<line x1="{px:.1f}" x2="{px:.1f}" y1="{self.TOP}" y2="{self.BOTTOM}" '
                'class="grid"/>'
            )
            out.append(
                f'<text x="{px:.1f}" y="{self.BOTTOM + 36}" class="tick" '
                f'text-anchor="middle">1e{k}</text>'
            )
        for k in range(math.ceil(self.y0), math.floor(self.y1) + 1):
            py = self.y(10.0**k)
            out.append(
                f'<line x1="{self.LEFT}" x2="{self.W - self.RIGHT}" y1="{py:.1f}" '
                f'y2="{py:.1f}" class="grid"/>'
            )
            out.append(
                f'<text x="{self.LEFT - 6}" y="{py + 4:.1f}" class="tick" '
                f'text-anchor="end">1e{k}</text>'
            )
        out += [
            f'<text x="{self.LEFT + 4}" y="{self.TOP - 26}" class="strip">did not finish, '
            "or no error or cost: placed by cost where known</text>",
            f'<line x1="{self.LEFT}" x2="{self.W - self.RIGHT}" y1="{self.TOP - 14}" '
            f'y2="{self.TOP - 14}" class="stripline"/>',
            f'<line x1="{self.LEFT}" x2="{self.W - self.RIGHT}" y1="{self.BOTTOM + 16}" '
            f'y2="{self.BOTTOM + 16}" class="stripline"/>',
            f'<text x="{self.W - self.RIGHT}" y="{self.BOTTOM + 12}" class="strip" '
            f'text-anchor="end">error &lt; {self.floor:.2g} or = 0: on this line</text>',
            f'<text x="{(self.LEFT + self.W - self.RIGHT) / 2}" y="{self.H - 4}" class="axis" '
            'text-anchor="middle">cost: wall time per simulated second (s/s), log</text>',
            f'<text transform="translate(16,{(self.TOP + self.BOTTOM) / 2}) rotate(-90)" '
            f'class="axis" text-anchor="middle">{esc(ylabel)}</text>',
        ]
        return out


def case_plot(board: Board, rows: list[Row], unit: str) -> tuple[str, dict]:
    """The case's SVG (error against cost) and the colour of each user's label."""
    truth = any(error_of(r, True) is not None for r in rows)
    xs = [r.cost for r in rows if finite(r.cost)]
    ys = [error_of(r, truth) for r in rows if finished(r)]
    ys = [y for y in ys if y is not None]
    if truth and finite(board.truth_band):
        ys.append(board.truth_band)
    ax = Axes(xs, ys)
    what = f"against the truth {board.truth}" if truth else "against the case's reference"
    out = [
        f'<svg class="plot" viewBox="0 0 {ax.W} {ax.H}" width="{ax.W}" height="{ax.H}" '
        f'role="img" aria-label="{esc(board.name)}: E_i against cost">'
    ]
    out += ax.frame(f"time-mean E_i {what} ({unit})")
    band = board.truth_band
    if truth and finite(band) and band > 0:
        top = max(min(ax.y(band), ax.BOTTOM), ax.TOP)
        out.append(
            f'<rect class="band" x="{ax.LEFT}" y="{top:.1f}" width="{ax.W - ax.RIGHT - ax.LEFT}" '
            f'height="{ax.BOTTOM - top:.1f}"><title>the truth&#39;s own error: E_i max '
            f"{band:.3g} {unit}; no difference below it is resolved</title></rect>"
        )
        out.append(
            f'<text x="{ax.LEFT + 6}" y="{top - 4:.1f}" class="bandlabel">the truth&#39;s own '
            f"error ({band:.2g} {unit}): not resolved below</text>"
        )
    rt = ax.x(REAL_TIME)
    out.append(
        f'<line x1="{rt:.1f}" x2="{rt:.1f}" y1="{ax.TOP}" y2="{ax.BOTTOM}" class="realtime"/>'
    )
    # the Pareto front (from the record's flags)
    front = sorted(
        (r for r in rows if (r.truth_pareto if truth else r.pareto).get("mean")),
        key=lambda r: cast(float, r.cost),  # flagged: rows with a finite cost
    )
    front = [r for r in front if finished(r) and (error_of(r, truth) or 0) > 0]
    if front:
        pts: list[str] = []
        for k, r in enumerate(front):
            e = error_of(r, truth)
            assert e is not None and r.cost is not None  # front: finished rows with an error
            px, py = ax.x(r.cost), ax.y(e) if e >= ax.floor else ax.BOTTOM + 16
            if k:
                pts.append(f"{px:.1f},{pts[-1].split(',')[1]}")
            pts.append(f"{px:.1f},{py:.1f}")
        pts.append(f"{ax.W - ax.RIGHT},{pts[-1].split(',')[1]}")
        out.append(f'<polyline class="front" points="{" ".join(pts)}"/>')
    users: dict[str, str] = {}
    labels: list[tuple[float, float, float]] = []  # placed labels: x, y, width
    # the frontier's runs first (under the others), users last (on top)
    order = sorted(rows, key=lambda r: (r.source != FRONTIER, r.source == "user"))
    for r in order:
        src = source_of(r)
        colour = COLOURS.get(src, "#555")
        if src == USERS:
            colour = users.setdefault(r.label, USER_COLOURS[len(users) % len(USER_COLOURS)])
        shape = GROUP_SHAPE if r.group else SHAPES.get(src, "circle")
        e = error_of(r, truth)
        placed = "plotted"
        if finished(r) and e is not None:
            px = ax.x(cast(float, r.cost))  # finished: a finite cost
            py = ax.y(e) if e >= ax.floor else ax.BOTTOM + 16
            placed = "plotted" if e >= ax.floor else "below"
        else:
            px = ax.x(r.cost) if finite(r.cost) and r.cost > 0 else ax.W - ax.RIGHT - 8
            py, placed = ax.TOP - 14, "strip"
        size = 6.5 if src == USERS else 5.0
        hollow = placed != "plotted" or not r.status == "ok"
        style = f'fill="{"none" if hollow else colour}" stroke="{colour}"'
        if shape == "cross":
            style = f'fill="none" stroke="{colour}" stroke-width="2.2"'
        out.append(
            f'<path class="pt f{" user" if src == USERS else ""}" '
            f'd="{symbol(shape, px, py, size)}" '
            f"{style} "
            f'data-case="{esc(board.name)}" data-source="{esc(src)}" '
            f'data-mesh="{esc(mesh_of(r))}" data-model="{esc(model_of(board, r))}" '
            f'data-label="{esc(r.label)}" data-placed="{placed}" '
            f'data-tip="{esc(json.dumps(tip_lines(board, r, unit)))}"/>'
        )
        if src == USERS or r in front:
            text = (r.label if src == USERS else r.label.split(":", 1)[-1])[:48]
            cls = "ulabel" if src == USERS else "flabel"
            fill = f' fill="{colour}"' if src == USERS else ""
            width = (7.5 if src == USERS else 6.2) * len(text)
            right = px + 8 + width > ax.W  # near the right edge: the label to the left
            anchor = ' text-anchor="end"' if right else ""
            x0 = px - 8 - width if right else px + 8
            ty = None
            for dy in (-6, 16, -18, 28, -30, 40):  # the first place that overlaps no label
                if not any(
                    x0 < b[0] + b[2] and b[0] < x0 + width and abs(py + dy - b[1]) < 12
                    for b in labels
                ):
                    ty = py + dy
                    break
            if ty is None:
                continue  # no room left beside a crowded point: its tooltip and the list say it
            labels.append((x0, ty, width))
            facets = (
                f'data-case="{esc(board.name)}" data-source="{esc(src)}" '
                f'data-mesh="{esc(mesh_of(r))}" data-model="{esc(model_of(board, r))}"'
            )
            if abs(ty - (py - 6)) > 1:  # moved off its point: a thin line leads to it
                out.append(
                    f'<line class="leader f" x1="{px:.1f}" y1="{py:.1f}" '
                    f'x2="{px - 6 if right else px + 6:.1f}" y2="{ty - 4:.1f}" {facets}/>'
                )
            out.append(
                f'<text class="{cls} f" x="{px - 8 if right else px + 8:.1f}" '
                f'y="{ty:.1f}"{fill}{anchor} '
                f'data-case="{esc(board.name)}" data-source="{esc(src)}" '
                f'data-mesh="{esc(mesh_of(r))}" data-model="{esc(model_of(board, r))}">'
                f"{esc(text)}</text>"
            )
    out.append(  # last: over the points, which would cover it
        f'<text x="{rt - 4:.1f}" y="{ax.TOP + 14}" class="rtlabel" text-anchor="end">'
        "real time: 1 s per s</text>"
    )
    out.append("</svg>")
    return "\n".join(out), users


def budget_plot(board: Board, rows: list[Row], unit: str) -> str:
    """The error budget (SPEC 10) as a dot plot: one line per run, its parts as markers on a
    log axis (total black, discretisation blue, algorithm orange, model green); a part that
    is 0 or below the axis sits at the axis's left end, hollow."""
    parts = {"total": "#222", "discretisation": "#1f77b4", "algorithm": "#ff7f0e",
             "model": "#2ca02c"}  # fmt: skip
    kept = [r for r in rows if r.budget and finite(r.budget.get("total"))]
    if not kept:
        return ""
    kept.sort(key=lambda r: r.budget["total"])
    values = [r.budget.get(p) for r in kept for p in parts]
    positive = [v for v in values if finite(v) and v > 0]
    if not positive:
        return ""
    top = max(positive)
    floor = max(min(positive), top * 1e-4)
    x0, x1 = math.log10(floor) - 0.1, math.log10(top) + 0.1
    left, right, row_h, head = 300, 880, 18, 46
    height = head + row_h * len(kept) + 34

    def px(v: float) -> float:
        return left + (math.log10(max(v, floor)) - x0) / (x1 - x0) * (right - 20 - left)

    out = [
        f'<svg class="budget" viewBox="0 0 {right} {height}" width="{right}" height="{height}" '
        f'role="img" aria-label="{esc(board.name)}: error budget">'
    ]
    for k, (part, colour) in enumerate(parts.items()):
        out.append(
            f'<circle cx="{left + 8 + 140 * k}" cy="14" r="5" fill="{colour}"/>'
            f'<text x="{left + 18 + 140 * k}" y="18" class="tick">{part}</text>'
        )
    out.append(f'<text x="4" y="18" class="tick">time-mean E_i ({unit}), log; hover for how</text>')
    for k in range(math.ceil(x0), math.floor(x1) + 1):
        x = px(10.0**k)
        out.append(
            f'<line x1="{x:.1f}" x2="{x:.1f}" y1="{head - 10}" y2="{height - 28}" class="grid"/>'
            f'<text x="{x:.1f}" y="{height - 12}" class="tick" text-anchor="middle">1e{k}</text>'
        )
    for i, r in enumerate(kept):
        y = head + row_h * i + row_h / 2
        src = source_of(r)
        b = r.budget
        lines = [marked(r.label, r.status)] + [
            f"{p}: {g(b.get(p))}" + (f" ({b[p + '_how']})" if b.get(p + "_how") else "")
            for p in parts
        ]
        out.append(
            f'<g class="brow f" data-case="{esc(board.name)}" data-source="{esc(src)}" '
            f'data-mesh="{esc(mesh_of(r))}" data-model="{esc(model_of(board, r))}" '
            f'data-tip="{esc(json.dumps([" ".join(x.split()) for x in lines]))}">'
            f'<rect x="0" y="{y - row_h / 2:.1f}" width="{right}" height="{row_h}" '
            f'class="{"odd" if i % 2 else "even"}"/>'
            f'<text x="{left - 8}" y="{y + 4:.1f}" class="tick" text-anchor="end">'
            f"{esc(marked(r.label[:44], r.status, short=True))}</text>"
        )
        xs = [px(b[p]) for p in parts if finite(b.get(p))]
        if xs:
            out.append(
                f'<line x1="{min(xs):.1f}" x2="{max(xs):.1f}" y1="{y:.1f}" y2="{y:.1f}" '
                'stroke="#bbb"/>'
            )
        for part, colour in parts.items():
            v = b.get(part)
            if not finite(v):
                continue
            fill = colour if v >= floor else "none"
            out.append(
                f'<circle cx="{px(v):.1f}" cy="{y:.1f}" r="{5 if part == "total" else 4}" '
                f'fill="{fill}" stroke="{colour}"/>'
            )
        out.append("</g>")
    out.append("</svg>")
    return "\n".join(out)


# --- tables -------------------------------------------------------------------------------------


def division(board: Board, rows: list[Row], truth: bool, open_: bool, unit: str) -> str:
    """A division's ranked table: the finished rows by time-mean E_i, the best first; the
    rest listed after. The Closed division: the case's own mesh and step (closed); the Open
    one: every row, the SPEC 11 frontier's included."""
    dofs = next((r.dofs for r in rows if r.reference), None)
    mine = [r for r in rows if open_ or closed(r, board, dofs)]
    entries = []
    for r in mine:
        e = error_of(r, truth)
        ranks = finished(r) and e is not None and not (r.reference and not truth)
        entries.append(
            (
                e if ranks else math.inf,
                {
                    "label": r.label + (" (the reference)" if r.reference else ""),
                    "source": r.source,
                    "facet": source_of(r),
                    "mesh": "the case's" if r.mesh == "reference" else r.mesh,
                    "dofs": r.dofs,
                    "mean": e,
                    "max": error_of(r, truth, "max"),
                    "cost": r.cost,
                    "status": r.status,
                    "ranks": ranks,
                    "user": r.source == "user",
                    "model": model_of(board, r),
                    "meshf": mesh_of(r),
                    "contact": r.contact,
                },
            )
        )
    entries.sort(key=lambda e: (e[0], e[1]["label"]))
    contact = board.benchmark == "contact"  # SPEC 12: two more columns
    head = (
        "<tr><th>#</th><th>run</th><th>source</th><th>mesh</th><th>dofs</th>"
        f"<th>E_i mean ({unit})</th><th>E_i max</th><th>s per simulated s</th>"
        "<th>real time</th>"
        + ("<th>force error</th><th>interpenetration (m)</th>" if contact else "")
        + "</tr>"
    )

    def line(k: int, e: dict) -> str:
        rt = "yes" if finite(e["cost"]) and e["cost"] <= REAL_TIME else "-"
        rank = str(k) if e["ranks"] else "-"
        status = "" if e["status"] == "ok" else f" ({esc(e['status'])}: over {covers(e['status'])})"
        return (
            f'<tr class="f{" userrow" if e["user"] else ""}" data-case="{esc(board.name)}" '
            f'data-source="{esc(e["facet"])}" data-model="{esc(e["model"])}" '
            f'data-mesh="{esc(e["meshf"])}"><td>{rank}</td><td>{esc(e["label"])}{status}</td>'
            f"<td>{esc(e['source'])}</td><td>{esc(e['mesh'])}</td><td>{e['dofs']:,}</td>"
            f"<td>{g(e['mean'])}</td><td>{g(e['max'])}</td><td>{g(e['cost'])}</td>"
            f"<td>{rt}</td>" + (contact_cells(e["contact"]) if contact else "") + "</tr>"
        )

    ranked = [e for _, e in entries]
    numbered, k = [], 0
    for e in ranked:
        if e["ranks"]:
            k += 1
        numbered.append(line(k, e))
    top = numbered[:TOP_RANKED]
    rest = numbered[TOP_RANKED:]
    table = f'<table class="rank">{head}{"".join(top)}</table>'
    if rest:
        table += (
            f"<details><summary>all {len(numbered)} runs</summary>"
            f'<table class="rank">{head}{"".join(numbered)}</table></details>'
        )
    return table


def contact_cells(contact: dict) -> str:
    """A contact case's two cells: the force error (its basis as the cell's title) and the
    interpenetration (m)."""
    how = contact.get("force_error_how") or ""
    return (
        f'<td title="{esc(how)}">{g(contact.get("force_error"))}</td>'
        f"<td>{g(contact.get('interpenetration_max'))}</td>"
    )


def contact_note(board: Board, rows: list[Row]) -> str:
    """A contact case's paragraph: what its two columns are, and its force figure."""
    how = sorted({r.contact.get("force_error_how") or "" for r in rows if r.force})
    against = "; ".join(h for h in how if h) or "no run handed its needle force"
    return (
        '<p class="note">Force error: max over the steps of |F - F_ref| / max |F_ref|, F the '
        f"needle force per unit thickness (N/m): {esc(against)}. Interpenetration: the largest "
        "-g_n over the deformed right edge and the steps (m). The needle force F_x against time: "
        f'<a href="{esc(board.name)}-force.png">{esc(board.name)}-force.png</a>.</p>'
    )


# --- the page -----------------------------------------------------------------------------------

STYLE = """
body{font:15px/1.45 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0;color:#222;
background:#fafafa}
header,section{max-width:1180px;margin:0 auto;padding:10px 22px}
section{background:#fff;border:1px solid #ddd;border-radius:6px;margin:18px auto}
h1{font-size:24px;margin:14px 0 6px}h2{font-size:20px;margin:8px 0}
h3{font-size:16px;margin:14px 0 6px}
.note{color:#555;font-size:13.5px}
.grid{stroke:#e4e4e4}.stripline{stroke:#bbb;stroke-dasharray:3 3}
.tick{font-size:11.5px;fill:#444}.axis{font-size:13px;fill:#222}.strip{font-size:11px;fill:#777}
.band{fill:#f3d9a4;opacity:.55}.bandlabel{font-size:11.5px;fill:#8a5a00}
.realtime{stroke:#c00;stroke-width:1.5;stroke-dasharray:6 4}
.rtlabel{font-size:12px;fill:#c00;paint-order:stroke;stroke:#fff;stroke-width:3px;pointer-events:none}
.front{fill:none;stroke:#333;stroke-width:1.3;stroke-dasharray:5 3}
.pt{cursor:pointer}.pt:hover{stroke-width:3}
.ulabel{font-size:13px;font-weight:600;paint-order:stroke;stroke:#fff;stroke-width:3px}
.flabel{font-size:11px;fill:#333;paint-order:stroke;stroke:#fff;stroke-width:3px}
.leader{stroke:#888;stroke-width:.8}
.even{fill:#fff}.odd{fill:#f5f7fa}.brow:hover rect{fill:#ffeebb}
.hidden{display:none}
.filters{display:flex;flex-wrap:wrap;gap:4px 18px;font-size:13.5px;margin:6px 0}
.filters fieldset{border:1px solid #ddd;border-radius:4px;padding:2px 8px}
.filters label{margin-right:8px;white-space:nowrap}
.swatch{display:inline-block;width:10px;height:10px;border-radius:2px;margin-right:3px}
table.rank{border-collapse:collapse;font-size:13px;margin:4px 0 8px}
table.rank td,table.rank th{border-bottom:1px solid #e6e6e6;padding:2px 8px;text-align:left}
table.rank th{background:#f0f2f5}tr.userrow td{background:#fff4e0;font-weight:600}
.cols{display:flex;flex-wrap:wrap;gap:14px}.cols>div{flex:1 1 520px}
#tip{position:fixed;z-index:10;max-width:560px;background:#fffff4;border:1px solid #999;
border-radius:4px;padding:6px 9px;font-size:13px;box-shadow:0 2px 8px rgba(0,0,0,.2);
pointer-events:none}
#tip .t{font-weight:700}
.users{background:#fff4e0;border:1px solid #f0c070;border-radius:5px;padding:6px 12px}
svg{max-width:100%;height:auto}
"""

SCRIPT = """
(function(){
  var tip=document.getElementById('tip');
  function place(e){
    var x=e.clientX+14,y=e.clientY+14,w=tip.offsetWidth,h=tip.offsetHeight;
    if(x+w>window.innerWidth-8)x=Math.max(8,e.clientX-w-14);
    if(y+h>window.innerHeight-8)y=Math.max(8,e.clientY-h-14);
    tip.style.left=x+'px';tip.style.top=y+'px';
  }
  document.addEventListener('mouseover',function(e){
    var el=e.target.closest?e.target.closest('[data-tip]'):null;
    if(!el){tip.hidden=true;return;}
    var lines=JSON.parse(el.getAttribute('data-tip'));
    tip.textContent='';
    lines.forEach(function(line,i){
      var d=document.createElement('div');d.textContent=line;
      if(!i)d.className='t';tip.appendChild(d);
    });
    tip.hidden=false;place(e);
  });
  document.addEventListener('mousemove',function(e){if(!tip.hidden)place(e);});
  function apply(sec){
    var on={};
    sec.querySelectorAll('.filters input').forEach(function(cb){
      (on[cb.getAttribute('data-facet')]=on[cb.getAttribute('data-facet')]||{})[cb.value]=cb.checked;
    });
    sec.querySelectorAll('.f').forEach(function(el){
      var show=['source','model','mesh'].every(function(k){
        var v=el.getAttribute('data-'+k);
        return !(k in on)||v===null||on[k][v]!==false;
      });
      el.classList.toggle('hidden',!show);
    });
  }
  document.querySelectorAll('section.case').forEach(function(sec){
    sec.querySelectorAll('.filters input').forEach(function(cb){
      cb.addEventListener('change',function(){apply(sec);});
    });
    sec.querySelectorAll('button.only').forEach(function(b){
      b.addEventListener('click',function(){
        sec.querySelectorAll('.filters input[data-facet="source"]').forEach(function(cb){
          cb.checked=(b.getAttribute('data-value')==='*'||cb.value===b.getAttribute('data-value'));
        });
        apply(sec);
      });
    });
  });
})();
"""


def filters(board: Board, rows: list[Row], users: dict) -> str:
    """The case's filter boxes: source (ours, each simulator, users, the frontier), mesh size
    (dofs) and model, each box ticked."""
    sources = list(dict.fromkeys(source_of(r) for r in rows))
    meshes = sorted(
        {mesh_of(r) for r in rows},
        key=lambda m: int(m.split()[0].replace(",", "")) if m[0].isdigit() else 0,
    )
    models = list(dict.fromkeys(model_of(board, r) for r in rows))

    def box(facet: str, value: str, colour: str | None = None) -> str:
        sw = f'<span class="swatch" style="background:{colour}"></span>' if colour else ""
        return (
            f'<label><input type="checkbox" checked data-facet="{facet}" value="{esc(value)}">'
            f"{sw}{esc(value)}</label>"
        )

    colour = {s: COLOURS.get(s) for s in sources}
    if USERS in colour:
        colour[USERS] = USER_COLOURS[0]
    out = ['<div class="filters">']
    out.append(
        "<fieldset><legend>source</legend>"
        + "".join(box("source", s, colour[s]) for s in sources)
        + " ".join(
            f'<button class="only" data-value="{esc(s)}">only {esc(s)}</button>'
            for s in [OURS, USERS]
            if s in sources
        )
        + ' <button class="only" data-value="*">all</button></fieldset>'
    )
    out.append(
        "<fieldset><legend>mesh size</legend>"
        + "".join(box("mesh", m) for m in meshes)
        + "</fieldset>"
    )
    out.append(
        "<fieldset><legend>model</legend>"
        + "".join(box("model", m) for m in models)
        + "</fieldset>"
    )
    out.append("</div>")
    if users:
        listed = ", ".join(
            f'<b style="color:{c}">&#9733; {esc(label)}</b>' for label, c in users.items()
        )
        if len(users) <= 20:
            out.append(f'<p class="users">Users&#39; runs on this case: {listed}</p>')
        else:  # many: folded (the browser's find still finds a label in it)
            out.append(
                f'<details class="users"><summary>{len(users)} users&#39; runs on this case '
                f"(each in its own colour)</summary>{listed}</details>"
            )
    return "".join(out)


def case_section(board: Board, rows: list[Row], notes: list[str], unit: str) -> str:
    truth = any(error_of(r, True) is not None for r in rows)
    if not truth:  # the frontier is graded against the truth only
        rows = [r for r in rows if r.source != FRONTIER]
    frontier = any(r.source == FRONTIER for r in rows)
    svg, users = case_plot(board, rows, unit)
    against = (
        f"against the truth <b>{esc(board.truth)}</b> (SPEC 10; its own E_i max "
        f"{g(board.truth_band)} {unit}, shaded)"
        if truth
        else "against the case's reference (our implicit on its mesh: SPEC 6)"
        + (f"; truth: {esc(board.truth_note.rstrip('.'))}" if board.truth_note else "")
    )
    budget = budget_plot(board, rows, unit)
    parts = [
        f'<section class="case" id="{esc(board.name)}" data-case="{esc(board.name)}">',
        f"<h2>{esc(board.name)}</h2>",
        f'<p class="note">{esc(board.description)} Timed {esc(board.session or "")} on '
        f"{esc(board.machine or 'this machine')}. {len(rows)} runs; E_i {against}.</p>",
        filters(board, rows, users),
        svg,
        '<p class="note">Each point is a run (hover for its numbers). Filled: plotted; '
        "hollow: in a strip (did not finish, or below the axis). Dashed black: the Pareto front "
        "(no other run at most as costly and at most as wrong); red: real time. "
        + (
            f"Grey diamonds: the SPEC 11 frontier's runs of {esc(board.truth)} "
            "(results/frontier; their cost, as every run's, is the whole run's: set-up "
            "included; the loop's alone in their tooltips)."
            if frontier
            else ""
        )
        + "</p>",
    ]
    if budget:
        parts += [
            "<h3>Error budget (SPEC 10)</h3>",
            '<p class="note">total: the run against the truth; discretisation: our implicit on '
            "the run's mesh against the truth; algorithm: the run against our implicit on its "
            "mesh; model: not measured where the run's model is the truth's. The parts are not "
            "additive.</p>",
            budget,
        ]
    parts += [
        '<div class="cols"><div>',
        "<h3>Closed division: the case's own mesh and step</h3>",
        division(board, rows, truth, False, unit),
        "</div><div>",
        "<h3>Open division: any mesh, step or sub-steps</h3>",
        division(board, rows, truth, True, unit),
        "</div></div>",
    ]
    if board.benchmark == "contact":
        parts.append(contact_note(board, rows))
    if notes:
        parts.append(
            f"<details><summary>notes ({len(notes)})</summary><ul>"
            + "".join(f"<li>{esc(n)}</li>" for n in notes)
            + "</ul></details>"
        )
    parts.append("</section>")
    return "\n".join(parts)


def render(
    boards: list[Board],
    rows: dict[str, list[Row]],
    notes: dict[str, list[str]],
    session: str,
    unit_of,
) -> str:
    """The page (text of index.html): `rows` by case, the SPEC 11 frontier's among them
    (frontier_rows.join_frontier); `unit_of(board)` is E_i's unit on the case."""
    users = [(b.name, r.label) for b in boards for r in rows.get(b.name, []) if r.source == "user"]
    index = " · ".join(f'<a href="#{esc(b.name)}">{esc(b.name)}</a>' for b in boards)
    head = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        "<title>tissuebench leaderboard</title>",
        f"<style>{STYLE}</style></head><body>",
        '<div id="tip" hidden></div>',
        "<header><h1>tissuebench leaderboard: accuracy against cost</h1>",
        '<p class="note">Written by <code>tissuebench leaderboard</code> from '
        "the record <code>leaderboard.json</code> (every row also in <code>leaderboard.csv</code>"
        "; the summary is <code>leaderboard.md</code>). Per case: E_i, the interior error "
        "(SPEC 6: m^3 on the rod, m^2 on the block), time-mean over the steps, against the "
        "truth where the case has one graded (SPEC 10), else against the case's reference; "
        f"cost: wall time per simulated second, {esc(sessions_line(boards, session))} on one "
        "core; a user's run carries the wall time given to compare. "
        "This page works offline.</p>",
        f"<p>Cases: {index}</p>",
    ]
    if users:
        head.append(
            '<p class="users">Users&#39; runs: '
            + ", ".join(
                f'<a href="#{esc(case)}">{esc(label)}</a> ({esc(case)})' for case, label in users
            )
            + "</p>"
        )
    head.append("</header>")
    body = [
        case_section(
            b,
            rows.get(b.name, []),
            notes.get(b.name, []),
            unit_of(b),
        )
        for b in boards
    ]
    return "\n".join(head + body + [f"<script>{SCRIPT}</script></body></html>", ""])
