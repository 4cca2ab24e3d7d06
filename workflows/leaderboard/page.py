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

import math

from tissuebench.workflows.leaderboard.budget import covers
from tissuebench.workflows.leaderboard.figures import sessions_line
from tissuebench.workflows.leaderboard.frontier_rows import (  # noqa: F401 (read here before)
    FRONTIER,
    FrontierRowError,
    frontier_row,
    read_frontier,
)
from tissuebench.workflows.leaderboard.page_assets import SCRIPT, STYLE
from tissuebench.workflows.leaderboard.page_svg import budget_plot, case_plot
from tissuebench.workflows.leaderboard.page_words import (
    COLOURS,
    OURS,
    REAL_TIME,
    TOP_RANKED,
    USER_COLOURS,
    USERS,
    closed,
    error_of,
    esc,
    finished,
    g,
    mesh_of,
    model_of,
    source_of,
    tip_lines,  # noqa: F401 (read here before)
)
from tissuebench.workflows.leaderboard.rows import Board, Row, finite

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
