"""The leaderboard page's inline SVG (page.py): a case's plot of E_i against cost (log-log,
with the Pareto front, the real-time line, the truth's own error as a band and every row as a
point with its tooltip's lines) and its error budget as a dot plot."""

from __future__ import annotations

import json
import math
from typing import cast

from tissuebench.workflows.leaderboard.budget import marked
from tissuebench.workflows.leaderboard.page_words import (
    COLOURS,
    GROUP_SHAPE,
    REAL_TIME,
    SHAPES,
    USER_COLOURS,
    error_of,
    esc,
    finished,
    g,
    mesh_of,
    model_of,
    source_of,
    tip_lines,
)
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import RANKED_BY, Board, Row, finite

RT_LABEL = "real time: 1 s per s"  # the real-time line's label


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


# the E_i a case's plot draws: the one the divisions rank by (its max over the steps), so that
# a point's height is what its rank says
PLOTTED = RANKED_BY


def case_plot(board: Board, rows: list[Row], unit: str) -> tuple[str, dict]:
    """The case's SVG (error against cost) and the colour of each user's label."""
    truth = any(error_of(r, True, PLOTTED) is not None for r in rows)
    xs = [r.cost for r in rows if finite(r.cost)]
    ys = [error_of(r, truth, PLOTTED) for r in rows if finished(r)]
    ys = [y for y in ys if y is not None]
    if truth and finite(board.truth_band):
        ys.append(board.truth_band)
    ax = Axes(xs, ys)
    what = f"against the truth {board.truth}" if truth else "against the case's reference"
    out = [
        f'<svg class="plot" viewBox="0 0 {ax.W} {ax.H}" width="{ax.W}" height="{ax.H}" '
        f'role="img" aria-label="{esc(board.name)}: E_i against cost">'
    ]
    out += ax.frame(f"maximum E_i over the steps {what} ({unit})")
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
        (r for r in rows if (r.truth_pareto if truth else r.pareto).get(PLOTTED)),
        key=lambda r: cast(float, r.cost),  # flagged: rows with a finite cost
    )
    front = [r for r in front if finished(r) and (error_of(r, truth, PLOTTED) or 0) > 0]
    if front:
        pts: list[str] = []
        for k, r in enumerate(front):
            e = error_of(r, truth, PLOTTED)
            assert e is not None and r.cost is not None  # front: finished rows with an error
            px, py = ax.x(r.cost), ax.y(e) if e >= ax.floor else ax.BOTTOM + 16
            if k:
                pts.append(f"{px:.1f},{pts[-1].split(',')[1]}")
            pts.append(f"{px:.1f},{py:.1f}")
        pts.append(f"{ax.W - ax.RIGHT},{pts[-1].split(',')[1]}")
        out.append(f'<polyline class="front" points="{" ".join(pts)}"/>')
    users: dict[str, str] = {}

    def where(r: Row) -> tuple[float, float, str]:
        """A row's point (px, py) and where it is: "plotted", "below" the axis or in the
        top "strip" (unfinished, or no error)."""
        e = error_of(r, truth, PLOTTED)
        if finished(r) and e is not None:
            px = ax.x(cast(float, r.cost))  # finished: a finite cost
            if e >= ax.floor:
                return px, ax.y(e), "plotted"
            return px, ax.BOTTOM + 16, "below"
        px = ax.x(r.cost) if finite(r.cost) and r.cost > 0 else ax.W - ax.RIGHT - 8
        return px, ax.TOP - 14, "strip"

    # the real-time line's label: at the first of its places (left or right of the line, at
    # the top or the bottom) that covers no point and stays inside the plot
    rt_width = 6.2 * len(RT_LABEL)
    points = [where(r)[:2] for r in rows]
    spots = [(rt - 4, ax.TOP + 14, "end"), (rt + 4, ax.TOP + 14, "start")]
    spots += [(rt - 4, ax.BOTTOM - 6, "end"), (rt + 4, ax.BOTTOM - 6, "start")]

    def clear(x: float, y: float, anchor: str) -> bool:
        x0 = x - rt_width if anchor == "end" else x
        inside = ax.LEFT <= x0 and x0 + rt_width <= ax.W - ax.RIGHT
        return inside and not any(
            x0 - 7 < px < x0 + rt_width + 7 and y - 18 < py < y + 8 for px, py in points
        )

    rt_x, rt_y, rt_anchor = next((s for s in spots if clear(*s)), spots[0])
    # placed labels (x, y, width): the real-time line's first, so that no point's sits on it
    labels: list[tuple[float, float, float]] = [
        (rt_x - rt_width if rt_anchor == "end" else rt_x, rt_y, rt_width)
    ]
    # the frontier's runs first (under the others), users last (on top)
    order = sorted(rows, key=lambda r: (r.kind is not Kind.FRONTIER, r.kind is Kind.USER))
    for r in order:
        src = source_of(r)
        user = r.kind is Kind.USER
        colour = COLOURS.get(src, "#555")
        if user:
            colour = users.setdefault(r.label, USER_COLOURS[len(users) % len(USER_COLOURS)])
        shape = GROUP_SHAPE if r.group else SHAPES.get(src, "circle")
        px, py, placed = where(r)
        size = 6.5 if user else 5.0
        hollow = placed != "plotted" or not r.status == "ok"
        style = f'fill="{"none" if hollow else colour}" stroke="{colour}"'
        if shape == "cross":
            style = f'fill="none" stroke="{colour}" stroke-width="2.2"'
        out.append(
            f'<path class="pt f{" user" if user else ""}" '
            f'd="{symbol(shape, px, py, size)}" '
            f"{style} "
            f'data-case="{esc(board.name)}" data-source="{esc(src)}" '
            f'data-mesh="{esc(mesh_of(r))}" data-model="{esc(model_of(board, r))}" '
            f'data-label="{esc(r.label)}" data-placed="{placed}" '
            f'data-tip="{esc(json.dumps(tip_lines(board, r, unit)))}"/>'
        )
        if user or r in front:
            text = (r.label if user else r.label.split(":", 1)[-1])[:48]
            cls = "ulabel" if user else "flabel"
            fill = f' fill="{colour}"' if user else ""
            width = (7.5 if user else 6.2) * len(text)
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
        f'<text x="{rt_x:.1f}" y="{rt_y:.1f}" class="rtlabel" text-anchor="{rt_anchor}">'
        f"{RT_LABEL}</text>"
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
