"""leaderboard.md: one screen per case, the page (leaderboard/index.html) holds the rest.

Per case: what it is and its truth, when and where it was timed; the best run of each source
(ours, each simulator, each user's label: the smallest E_i max over the steps against the
truth, or against the case's reference where it has no truth graded, its time-mean beside it:
rows.RANK_RULE; the SPEC 11 frontier's runs are a source of their own, frontier_rows.py); the
SPEC 11 frontier (the closest of its runs at real time by E_i max, its cost the whole run's as
every row's); the notes (what was not run,
and every user's folder or run left out, with why); and the link to the case on the page. The
full rows stay in leaderboard.csv and leaderboard.json. Every text read is escaped (md).
"""

from __future__ import annotations

from tissuebench.workflows.leaderboard.boards import is_contact
from tissuebench.workflows.leaderboard.budget import covers
from tissuebench.workflows.leaderboard.figures import load_note, sessions_line, unit_of
from tissuebench.workflows.leaderboard.page_words import (
    REAL_TIME,
    error_of,
    finished,
    rank_key,
    source_of,
)
from tissuebench.workflows.leaderboard.record import FOLDER, MARKER
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import RANK_RULE, RANKED_BY, Board, Row, fmt, md

PAGE = "leaderboard/index.html"
USERS_SHOWN = 10  # users' runs listed per case (the best first); every one is on the page


def best_per_source(rows: list[Row], truth: bool) -> list[tuple[str, Row]]:
    """(source, its best row) for each source (a user's label is a source of its own), the
    best overall first, by E_i max over the steps (page_words.rank_key: against the truth where
    the case has one, ties by label); a source none of whose runs ranks shows its first row."""
    by: dict[str, list[Row]] = {}
    for r in rows:
        key = f"user {r.label}" if r.kind is Kind.USER else source_of(r)
        by.setdefault(key, []).append(r)

    def rank(r: Row) -> tuple[float, str]:
        e, label = rank_key(r, truth)
        return (e, label if e < float("inf") else "")  # none ranks: its first row, as listed

    best = [(key, min(group, key=rank)) for key, group in by.items()]
    return sorted(best, key=lambda b: (*rank(b[1]), b[0]))


def frontier_line(board: Board, rows: list[Row], unit: str) -> str:
    """The SPEC 11 frontier of the case's truth in one line (or why there is none): the
    closest of the frontier's runs (rows of kind FRONTIER) at a whole-run cost of at most
    REAL_TIME."""
    ok = [
        r
        for r in rows
        if r.kind is Kind.FRONTIER and finished(r) and (error_of(r, True, RANKED_BY) or 0) > 0
    ]
    if not ok:
        return ""
    fast = [r for r in ok if r.cost is not None and r.cost <= REAL_TIME]
    if not fast:
        return f"SPEC 11 frontier ({md(board.truth)}): no run at <= 1 s per simulated s."
    r = min(fast, key=lambda r: (error_of(r, True, RANKED_BY) or 0.0, r.label))
    return (
        f"SPEC 11 frontier ({md(board.truth)}, results/frontier): at <= 1 s per simulated s "
        f"(the whole run) the closest run by E_i max is {md(r.label)} ({r.dofs:,} dofs): E_i "
        f"max {fmt(error_of(r, True, RANKED_BY))} {unit} (mean {fmt(error_of(r, True))}), "
        f"{fmt(r.cost)} s per simulated s."
    )


def case_lines(board: Board, rows: list[Row], notes: list[str], session: str) -> list[str]:
    unit = unit_of(board)
    truth = any(error_of(r, True) is not None for r in rows)
    if truth:
        against = (
            f"Truth (SPEC 10): `{md(board.truth)}`, its own E_i max {fmt(board.truth_band)} "
            f"{unit}; E_i below is against it."
        )
    else:
        why = board.truth_note or "none"
        against = f"Truth (SPEC 10): {md(why)} E_i below is against the case's reference."
    out = [
        f"## {board.name}",
        "",
        f"{md(board.description)} {against} Timed in the session of "
        f"{md(board.session or session)}"
        + (f" on {md(board.machine)}" if board.machine else "")
        + load_note(board.load)
        + f". [All {len(rows)} runs, the budget and the divisions]({PAGE}#{board.name}).",
        "",
    ]
    contact = is_contact(board)  # SPEC 12: two more columns
    more = " force error | interpenetration (m) |" if contact else ""
    out += [
        f"| source | best run | mesh, dofs | E_i max ({unit}) | E_i mean | s per simulated s |"
        + more,
        "|---|---|---|---|---|---|" + ("---|---|" if contact else ""),
    ]
    best = best_per_source(rows, truth)
    users = [source for source, r in best if r.kind is Kind.USER]
    hidden = set(users[USERS_SHOWN:])  # the best USERS_SHOWN users' runs; the rest on the page
    for source, r in best:
        if source in hidden:
            continue
        e, emax = error_of(r, truth), error_of(r, truth, "max")
        status = "" if r.status == "ok" else f" ({md(r.status)}: over {md(covers(r.status))})"
        mesh = "the case's" if r.mesh == "reference" else md(r.mesh)
        out.append(
            f"| {md(source)} | {md(r.label)}{' (reference)' if r.reference else ''}{status} | "
            f"{mesh}, {r.dofs} | {fmt(emax)} | {fmt(e)} | {fmt(r.cost)} |"
            + (
                f" {fmt(r.contact.get('force_error'))} | "
                f"{fmt(r.contact.get('interpenetration_max'))} |"
                if contact
                else ""
            )
        )
    if hidden:
        cells = " | |" if contact else ""
        out.append(f"| {len(hidden)} more users' runs | on the page | | | | |{cells}")
    line = frontier_line(board, rows, unit) if truth else ""
    if line:
        out += ["", line]
    if contact:
        out += ["", contact_line(board, rows)]
    if notes:
        out += ["", *[f"- {md(n)}" for n in notes]]
    return out + [""]


def contact_line(board: Board, rows: list[Row]) -> str:
    """A contact case's line under its table: what its force error is against, and its force
    figure."""
    how = sorted({r.contact.get("force_error_how") or "" for r in rows if r.force})
    against = "; ".join(md(h) for h in how if h) or "no run handed its needle force"
    return (
        f"Force error (max over the steps of |F - F_ref| / max |F_ref|): {against}. "
        f"Interpenetration: the largest -g_n over the deformed right edge and the steps (m). "
        f"The needle force against time: [{board.name}-force.png]({FOLDER}/{board.name}-force.png)."
    )


def markdown(
    boards: list[Board],
    rows: dict[str, list[Row]],
    notes: dict[str, list[str]],
    session: str,
) -> str:
    """leaderboard.md: the summary of every case (about 15 lines each); `rows` by case, the
    SPEC 11 frontier's among them (frontier_rows.join_frontier)."""
    out = [
        MARKER,
        "",
        "Written by `tissuebench leaderboard --out results`: per case, the best run of each "
        "source by its interior error E_i (SPEC 6), against the truth (SPEC 10), or against "
        f"the case's reference where it has none: {RANK_RULE}, so that a run right only on "
        "average (a quasi-static run on a dynamic case) does not lead; and its cost, wall time "
        f"per simulated second ({sessions_line(boards, session)}; serial). **The page "
        f"[{PAGE}]({PAGE})** has every run: error against cost with the Pareto front and the "
        "real-time line, a tooltip per run, filters, each user's row by its label, the error "
        "budget, and the Closed (the case's mesh and step) and Open divisions, each ranked "
        "the same way. Every row: leaderboard.csv and leaderboard.json.",
        "",
    ]
    for board in boards:
        out += case_lines(
            board,
            rows.get(board.name, []),
            notes.get(board.name, []),
            session,
        )
    return "\n".join(out)
