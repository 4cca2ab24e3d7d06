"""One row of the leaderboard (Row: a graded run of a case) and what its values are checked
and written with: real and finite numbers, the error keys, and text made one line, literal
Markdown and HTML (md) or literal matplotlib text (plain). rows.py reads and ranks the rows."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TypeGuard

from tissuebench.metrics.table import METRICS

E_I = "interior_error"
E_N = "relative_error"

# the sources of the rows that are not a simulator's (whose source is its name and version)
OUR_SOURCE = "tissuebench"
USER_SOURCE = "user"
FRONTIER_SOURCE = "SPEC 11 frontier"  # frontier_rows.py (FRONTIER)


class Kind(StrEnum):
    """What a row is: one of our runs, an outside simulator's, a user's (graded from a compare
    folder) or one of the SPEC 11 frontier's runs. Set once, where the row is made or read
    (Row.kind); nothing else tells them apart by a row's source or label."""

    OURS = "ours"
    SIMULATOR = "simulator"
    USER = "user"
    FRONTIER = "frontier"


def kind_of(source: str) -> Kind:
    """The kind of a row by the source it was recorded with (leaderboard.json, leaderboard.csv,
    which keep no kind): our, a user's and the frontier's sources are fixed (OUR_SOURCE,
    USER_SOURCE, FRONTIER_SOURCE), any other is a simulator's name."""
    known = {OUR_SOURCE: Kind.OURS, USER_SOURCE: Kind.USER, FRONTIER_SOURCE: Kind.FRONTIER}
    return known.get(source, Kind.SIMULATOR)


@dataclass
class Row:
    """One graded run of a case."""

    case: str
    label: str
    source: str  # OUR_SOURCE, "CalculiX 2.20", ..., USER_SOURCE, FRONTIER_SOURCE
    description: str
    mesh: str
    dofs: int
    status: str
    reason: str | None
    errors: dict  # "<metric>_max" / "<metric>_mean" -> value or None
    wall_time_s: float | None  # s
    end_time: float  # s, simulated
    timing: str  # "this session" or "reported by the user"
    reference: bool = False
    pareto: dict = field(default_factory=dict)  # "mean" / "max" -> bool
    group: str | None = None  # its own legend entry and marker in the figure (default: source)
    series: str | None = None  # the run's own series file (graded against the truth)
    series_field: str | None = None  # its point field (None: series.DEFAULT_FIELDS)
    truth: dict = field(default_factory=dict)  # TRUTH_KEYS -> value or None, against the truth
    truth_pareto: dict = field(default_factory=dict)  # "mean" / "max" -> bool, against the truth
    truth_note: str | None = None  # why the row has no truth columns
    budget: dict = field(default_factory=dict)  # the error budget (SPEC 10): workflows/leaderboard
    # a user's row: the SHA-256 of its series' files (series_hash), which its grades are of
    series_hash: str | None = None
    # a contact case's row (SPEC 12; {} on other cases): "force_error" (dimensionless) and
    # "interpenetration_max" (m), numbers or None, and "force_error_how" (words: against what,
    # or why none)
    contact: dict = field(default_factory=dict)
    # a contact case's row: its needle force file as its run of this session wrote it
    # (write_force_csv; kept as where it was, never read back) and the force itself, which the
    # record carries (force_curve.py: {"times", "force", "unit"}; None: none handed or read)
    force: str | None = None
    force_curve: dict | None = None
    model: str | None = None  # a user's row: its model as stated to compare (None: the case's)
    folder: str | None = (
        None  # a user's row: its compare folder's name (OUT/leaderboard/CASE/user/)
    )
    # what the row is: given by the code that makes it (rows.our_rows, rows.external_rows,
    # checks.user_rows, frontier_rows.as_row); where none is given, its source's (kind_of: a
    # row read back from the record). Not written to the record (record.row_record).
    kind: Kind | None = None

    def __post_init__(self) -> None:
        self.kind = kind_of(self.source) if self.kind is None else Kind(self.kind)

    @property
    def cost(self) -> float | None:
        """Wall time per simulated second (s/s); None unless both are finite, T > 0."""
        if not finite(self.wall_time_s) or not finite(self.end_time) or self.end_time <= 0:
            return None
        return self.wall_time_s / self.end_time

    @property
    def cost_per_dof(self) -> float | None:
        """Wall time per simulated second and per dof (µs/s)."""
        return None if self.cost is None or not self.dofs else 1e6 * self.cost / self.dofs


def error_keys() -> list[str]:
    return [f"{name}_{kind}" for name in METRICS for kind in ("max", "mean")]


TRUTH_KEYS = [f"{name}_{kind}" for name in (E_N, E_I) for kind in ("max", "mean")]


def real(x: object) -> TypeGuard[float]:
    """True for a real number that is not a bool (it may be NaN or infinite)."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool)


def finite(x: object) -> TypeGuard[float]:
    """True for a real number (not a bool) that is neither NaN nor infinite."""
    return real(x) and math.isfinite(x)


def one_line(text) -> str:
    """text with every character that is not printable (a newline, a tab) shown escaped:
    safe in a one-line message."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


MARKDOWN = str.maketrans(
    {c: "\\" + c for c in "\\`*_[]|~$#"} | {"&": "&amp;", "<": "&lt;", ">": "&gt;"}
)


def md(text) -> str:
    """text as literal Markdown and HTML on one line (a table cell, a list item): every
    character that is not printable becomes a space, Markdown's inline marks and | are
    backslash-escaped and <, >, & become entities."""
    line = "".join(c if c.isprintable() else " " for c in str(text))
    return line.translate(MARKDOWN)


def plain(text) -> str:
    """text as literal text for matplotlib (no mathtext), on one line."""
    return "".join(c if c.isprintable() else " " for c in str(text)).replace("$", r"\$")


def fmt(x: float | None, spec: str = ".3g") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)
