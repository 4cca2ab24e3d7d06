"""A leaderboard row in the page's words (page.py): its source facet (ours, a simulator,
users, the frontier), model, mesh, division, what its wall time covers, the errors it is drawn
by (time-mean) and ranked by (max over the steps: rows.RANK_RULE), the lines its tooltip
shows, and their colours and marker shapes; esc, the escape of every text the page shows."""

from __future__ import annotations

import html
import math

from tissuebench.workflows.leaderboard.budget import covers
from tissuebench.workflows.leaderboard.frontier_rows import FRONTIER
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import (
    E_I,
    E_N,
    RANKED_BY,
    Board,
    Row,
    finite,
    one_line,
)

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
    """The source facet of a row: ours, a simulator's name, users, or the frontier."""
    if row.kind is Kind.OURS:
        return OURS
    if row.kind is Kind.USER:
        return USERS
    if row.kind is Kind.FRONTIER:
        return FRONTIER
    return row.source.split()[0]


def model_of(board: Board, row: Row) -> str:
    """The elastic model a row ran with: ours name it after +, the simulators were given
    the case's simulator model, a user's is the one stated to compare (--model), else the
    case's, as posed."""
    if row.kind is Kind.OURS:
        return (
            row.label.split(" ")[0].split("+", 1)[1]
            if "+" in row.label.split(" ")[0]
            else ("linear")
        )
    if row.kind is Kind.USER:
        return row.model or board.model
    if row.kind is Kind.FRONTIER:  # the frontier runs the truth's (linear) model
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
    if row.kind is not Kind.USER or not case_dofs or row.dofs != case_dofs:
        return False
    kind = row.mesh.split(":")[0]
    return kind in ("hexahedra", "quadrilaterals")


def wall_meaning(row: Row) -> str:
    """What a row's wall time covers."""
    if row.kind is Kind.OURS and row.timing == "this session":
        return (
            "assembly of M, K and f, the integrator's setup and its time loop, in process, "
            "1 rank (timed in the case's session)"
        )
    if row.kind is Kind.USER:
        return "as reported by the user to compare (--wall-time)"
    if "timed: " in row.description:
        return row.description.split("timed: ", 1)[1]
    return row.timing


def error_of(row: Row, truth: bool, kind: str = "mean") -> float | None:
    """A row's E_i (time-mean, which the plot draws, or max, which it ranks by: kind) against
    the truth, or against the reference (0 for the reference itself); None when it has none."""
    value = (row.truth if truth else row.errors).get(f"{E_I}_{kind}")
    if not truth and row.reference:
        return 0.0
    return float(value) if finite(value) and value >= 0 else None


def finished(row: Row) -> bool:
    return row.status == "ok" and finite(row.cost) and row.cost > 0


def rank_error(row: Row, truth: bool) -> float | None:
    """The E_i a row ranks by in a division and among its source's runs (rows.RANK_RULE): its
    max over the steps against the truth where the case has one (truth), else against the
    case's reference; None where it does not rank (it did not finish, has no such error, or
    is the reference graded against itself)."""
    if not finished(row) or (row.reference and not truth):
        return None
    return error_of(row, truth, RANKED_BY)


def rank_key(row: Row, truth: bool, label: str | None = None) -> tuple[float, str]:
    """The order of a ranked table: rank_error (math.inf where the row does not rank), then
    the label (ties: deterministic)."""
    e = rank_error(row, truth)
    return (math.inf if e is None else e, row.label if label is None else label)


def g(x) -> str:
    """A number in three significant figures, or a dash."""
    return "-" if not finite(x) else f"{x:.3g}"


def tip_lines(board: Board, row: Row, unit: str) -> list[str]:
    """What hovering over a row's point shows (plain text lines; the first is its label)."""
    ref = row.errors
    lines = [
        row.label + (" (the reference)" if row.reference else ""),
        f"source: {row.source}" + (" (tissuebench)" if row.kind is Kind.USER else ""),
        *([f"folder: {one_line(row.folder)}"] if row.kind is Kind.USER and row.folder else []),
        f"mesh: {'the case' + chr(39) + 's own' if row.mesh == 'reference' else row.mesh}; "
        f"{row.dofs:,} dofs",
        f"model: {model_of(board, row)}"
        + (
            " (the case's: not stated to compare)"
            if row.kind is Kind.USER and not row.model
            else ""
        )
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
    if row.kind is Kind.FRONTIER:  # its loop's own cost, SPEC 11's figure
        lines.append(row.description.split("; timed: ")[0])
    return [" ".join(str(x).split()) for x in lines]


def esc(text) -> str:
    return html.escape(" ".join(str(text).split()), quote=True)
