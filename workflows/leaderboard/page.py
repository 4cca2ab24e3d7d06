"""results/leaderboard/index.html: the leaderboard as one page that works offline (opened
straight from disk: no server, no download, no script or stylesheet from anywhere else).

Per case: E_i (its max over the steps, which it ranks by) against the truth, or against the
case's reference where the case has no truth graded, against the cost (wall time per simulated
second), log-log, in inline SVG; the Pareto front, the real-time line (1 s per simulated s) and
the truth's own error as a shaded band; every row of the record is one point (`.pt`, with data
attributes: case, source, model, mesh, and the lines its tooltip shows), a run that did not
finish or has no error in a strip above the plot and one below the axis's floor (0 included) in
a strip below it; the SPEC 11 frontier's runs of the case's truth
(results/frontier/frontier.csv) are rows of the case like any other (frontier_rows.py: grey
diamonds, their cost the whole run's as every row's); filters by source, mesh size (dofs) and
model; each user's row by its own label, in its own colour; the error budget as a dot plot; the
Closed division (the case's own mesh and step) and the Open one (any mesh, step or sub-steps,
the frontier's runs included), each ranked by E_i max over the steps, the time-mean beside it
(rows.RANK_RULE). The little JavaScript at the end only shows tooltips and applies the filters.

Made in two steps: the view model (PageView, CaseView, Division, Entry, Box: plain data,
every text as read and unescaped, computed from the rows here) and the Jinja2 templates
templates/page.html.j2 (the page) and templates/parts.html.j2 (its division tables and filter
boxes), with the stylesheet templates/page.css and the script templates/page.js (package data,
read with importlib.resources), rendered with autoescape on. Every value the
template prints is made one line and escaped as html.escape does (finalize: esc), unless it
is Markup: the plots (page_svg.py, which escapes what it reads itself), the stylesheet and the
script. The tooltips are set as text by the script.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cache
from importlib import resources

import jinja2
from markupsafe import Markup

from tissuebench.workflows.leaderboard.boards import is_contact
from tissuebench.workflows.leaderboard.budget import covers
from tissuebench.workflows.leaderboard.figures import sessions_line
from tissuebench.workflows.leaderboard.frontier_rows import (  # noqa: F401 (read here before)
    FRONTIER,
    FrontierRowError,
    frontier_row,
    read_frontier,
)
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
    g,
    mesh_of,
    model_of,
    rank_error,
    rank_key,
    source_of,
    tip_lines,  # noqa: F401 (read here before)
)
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import RANK_RULE, Board, Row, finite

TEMPLATES = "templates"  # the package's folder of the template, stylesheet and script
USERS_LISTED = 20  # users' labels listed above a case's plot; more are folded

# --- the view model -----------------------------------------------------------------------------


@dataclass
class Entry:
    """A line of a division's table, as text (unescaped)."""

    rank: str  # its place, or "-" where it does not rank
    label: str
    status: str  # "" where it finished (ok), else its status
    over: str  # what its numbers cover (budget.covers)
    source: str  # the row's source as recorded
    facet: str  # its source facet (page_words.source_of)
    mesh: str
    dofs: str  # with thousands separators
    mean: str  # E_i, time-mean and max (which it ranks by), in the case's unit
    max: str
    cost: str  # s per simulated s
    real_time: str  # "yes" or "-"
    user: bool
    model: str
    mesh_facet: str
    force_error: str = "-"  # a contact case's columns (SPEC 12): dimensionless, how, m
    force_how: str = ""
    interpenetration: str = "-"


@dataclass
class Division:
    """A division's ranked table: every line, the best first, and those shown unfolded."""

    case: str
    unit: str  # E_i's
    contact: bool  # SPEC 12's two more columns
    entries: list[Entry]
    top: list[Entry]


@dataclass
class Box:
    """A filter's checkbox: its facet (source, mesh, model), its value and its swatch."""

    facet: str
    value: str
    colour: str | None = None


@dataclass
class CaseView:
    """A case's section."""

    name: str
    description: str
    session: str
    machine: str
    runs: int
    unit: str
    truth: bool  # graded against a truth
    truth_name: str
    band: str  # the truth's own E_i max
    truth_note: str
    sources: list[Box]
    meshes: list[Box]
    models: list[Box]
    only: list[str]  # the sources with an "only" button
    users: list[tuple[str, str]]  # each user's label and colour
    users_listed: int
    plot: Markup  # the inline SVG (page_svg.case_plot)
    frontier: bool  # the SPEC 11 frontier's runs among the points
    budget: Markup  # the error budget's SVG, or empty
    closed: Division
    open: Division
    contact: bool
    force_against: str  # a contact case's: what its force error is against
    notes: list[str] = field(default_factory=list)


@dataclass
class PageView:
    """The page: when and where it was timed, every case, and every user's run."""

    sessions: str
    cases: list[CaseView]
    users: list[tuple[str, str]]  # (case, label) of each user's run
    rule: str = RANK_RULE  # what every division ranks by, in words


def division_view(board: Board, rows: list[Row], truth: bool, open_: bool, unit: str) -> Division:
    """A division's ranked table (rows.RANK_RULE): the finished rows by E_i max over the
    steps (against the truth where the case has one: truth), the best first, ties by label;
    the time-mean a column beside it; the rest listed after. The Closed division: the case's
    own mesh and step (closed); the Open one: every row, the SPEC 11 frontier's included."""
    dofs = next((r.dofs for r in rows if r.reference), None)
    contact = is_contact(board)  # SPEC 12: two more columns
    ranked: list[tuple[tuple[float, str], str, Row, bool]] = []
    for r in rows:
        if not (open_ or closed(r, board, dofs)):
            continue
        label = r.label + (" (the reference)" if r.reference else "")
        ranked.append((rank_key(r, truth, label), label, r, rank_error(r, truth) is not None))
    ranked.sort(key=lambda x: x[0])
    entries, k = [], 0
    for _, label, r, ranks in ranked:
        k += ranks
        cost = r.cost
        entry = Entry(
            rank=str(k) if ranks else "-",
            label=label,
            status="" if r.status == "ok" else r.status,
            over=covers(r.status),
            source=r.source,
            facet=source_of(r),
            mesh="the case's" if r.mesh == "reference" else r.mesh,
            dofs=f"{r.dofs:,}",
            mean=g(error_of(r, truth)),
            max=g(error_of(r, truth, "max")),
            cost=g(cost),
            real_time="yes" if finite(cost) and cost <= REAL_TIME else "-",
            user=r.kind is Kind.USER,
            model=model_of(board, r),
            mesh_facet=mesh_of(r),
        )
        if contact:
            entry.force_error = g(r.contact.get("force_error"))
            entry.force_how = r.contact.get("force_error_how") or ""
            entry.interpenetration = g(r.contact.get("interpenetration_max"))
        entries.append(entry)
    return Division(board.name, unit, contact, entries, entries[:TOP_RANKED])


def boxes(board: Board, rows: list[Row]) -> tuple[list[Box], list[Box], list[Box]]:
    """The case's filter boxes, each ticked: source (ours, each simulator, users, the
    frontier; each in its colour), mesh size (dofs, the smallest first) and model."""
    sources = list(dict.fromkeys(source_of(r) for r in rows))
    meshes = sorted(
        {mesh_of(r) for r in rows},
        key=lambda m: int(m.split()[0].replace(",", "")) if m[0].isdigit() else 0,
    )
    models = list(dict.fromkeys(model_of(board, r) for r in rows))
    colour: dict[str, str | None] = {}  # each source's swatch: the users' the first user's
    for r in rows:
        mine = USER_COLOURS[0] if r.kind is Kind.USER else COLOURS.get(source_of(r))
        colour.setdefault(source_of(r), mine)
    return (
        [Box("source", s, colour[s]) for s in sources],
        [Box("mesh", m) for m in meshes],
        [Box("model", m) for m in models],
    )


def case_view(board: Board, rows: list[Row], notes: list[str], unit: str) -> CaseView:
    """A case's section: its rows (the frontier's only where the case is graded against the
    truth), `unit` E_i's."""
    truth = any(error_of(r, True) is not None for r in rows)
    if not truth:  # the frontier is graded against the truth only
        rows = [r for r in rows if r.kind is not Kind.FRONTIER]
    svg, users = case_plot(board, rows, unit)
    sources, meshes, models = boxes(board, rows)
    kinds = {r.kind for r in rows}  # an "only" button for ours and for the users
    how = sorted({r.contact.get("force_error_how") or "" for r in rows if r.force})
    return CaseView(
        name=board.name,
        description=board.description,
        session=board.session or "",
        machine=board.machine or "this machine",
        runs=len(rows),
        unit=unit,
        truth=truth,
        truth_name=board.truth or "",
        band=g(board.truth_band),
        truth_note=(board.truth_note or "").rstrip("."),
        sources=sources,
        meshes=meshes,
        models=models,
        only=[facet for kind, facet in ((Kind.OURS, OURS), (Kind.USER, USERS)) if kind in kinds],
        users=list(users.items()),
        users_listed=USERS_LISTED,
        plot=Markup(svg),  # page_svg escapes what it reads
        frontier=any(r.kind is Kind.FRONTIER for r in rows),
        budget=Markup(budget_plot(board, rows, unit)),
        closed=division_view(board, rows, truth, False, unit),
        open=division_view(board, rows, truth, True, unit),
        contact=is_contact(board),
        force_against="; ".join(h for h in how if h) or "no run handed its needle force",
        notes=list(notes),
    )


def page_view(
    boards: list[Board],
    rows: dict[str, list[Row]],
    notes: dict[str, list[str]],
    session: str,
    unit_of,
) -> PageView:
    """The page's view model: `rows` and `notes` by case, `unit_of(board)` E_i's unit."""
    return PageView(
        sessions=sessions_line(boards, session),
        cases=[
            case_view(b, rows.get(b.name, []), notes.get(b.name, []), unit_of(b)) for b in boards
        ],
        users=[
            (b.name, r.label) for b in boards for r in rows.get(b.name, []) if r.kind is Kind.USER
        ],
    )


# --- the template -------------------------------------------------------------------------------


def asset(name: str) -> str:
    """A file of the package's templates/ folder (a template, page.css, page.js), as text."""
    return resources.files(__package__).joinpath(TEMPLATES, name).read_text(encoding="utf-8")


def finalize(value):
    """Every value the template prints: Markup as it is, anything else made one line and
    escaped, quotes included (esc)."""
    return value if isinstance(value, Markup) else Markup(esc(value))


@cache
def environment() -> jinja2.Environment:
    """The templates of the package's templates/ folder (page.html.j2, parts.html.j2), with
    autoescape on (every value printed: finalize)."""
    return jinja2.Environment(
        loader=jinja2.FunctionLoader(asset),
        autoescape=True,
        finalize=finalize,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined,
    )


def division(board: Board, rows: list[Row], truth: bool, open_: bool, unit: str) -> str:
    """A division's table as the page shows it: division_view through parts.html.j2's macro."""
    table = environment().get_template("parts.html.j2").module.division  # type: ignore[attr-defined]
    return str(table(division_view(board, rows, truth, open_, unit)))


def render(
    boards: list[Board],
    rows: dict[str, list[Row]],
    notes: dict[str, list[str]],
    session: str,
    unit_of,
) -> str:
    """The page (text of index.html): `rows` by case, the SPEC 11 frontier's among them
    (frontier_rows.join_frontier); `unit_of(board)` is E_i's unit on the case."""
    return (
        environment()
        .get_template("page.html.j2")
        .render(
            page=page_view(boards, rows, notes, session, unit_of),
            style=Markup(asset("page.css")),  # ours, inlined as it is
            script=Markup(asset("page.js")),
        )
    )
