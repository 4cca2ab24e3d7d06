"""The error budget of a leaderboard case's rows graded against the truth (SPEC 10): total,
discretisation, algorithm and model, in row.budget (error_budget), and whether one is complete;
summarized, an error curve's maximum and time-mean. grading.py grades the rows; budget.py
draws the budget."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mpi4py import MPI

from tissuebench.workflows.leaderboard.caches import Caches
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import E_I, Board, Row, finite

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples


def summarized(curve) -> tuple[float | None, float | None]:
    """(max, time-mean) of an error curve over steps 1..N, None for NaN."""
    from tissuebench.metrics.compare import summarize

    peak, mean = (None if not finite(x) else float(x) for x in summarize(curve))
    return peak, mean


def error_budget(
    rows: list[Row],
    only: list[Row] | None = None,
    board: Board | None = None,
    truth: TruthSamples | None = None,
    caches: Caches | None = None,
) -> None:
    """The error budget (SPEC 10) of every row of a case graded against the truth, in
    row.budget (time-mean E_i, m^gdim): total (the row against the truth), discretisation
    (our implicit on the row's mesh against the truth), algorithm (the row against our
    implicit on its mesh: the same-mesh column on our grid; graded here on our simplices),
    model (none: the linear case's model is the truth's). A user's row on a mesh of its own,
    given the case's `board` and its `truth` (TruthSamples), gets our implicit run here on that
    mesh (workflows/leaderboard/user_mesh.py: all four parts, or one line on why not). Only the
    rows of
    `only` when it is given (the others keep theirs); `caches` shared across rows (Caches),
    the same numbers. Rank 0."""
    from tissuebench.workflows.compare.grading import grade

    reference = next((r for r in rows if r.reference and r.truth), None)
    if reference is None and (board is None or truth is None):
        return
    implicit = {
        r.mesh.split(":")[0]: r
        for r in rows
        if reference is not None and r.label.startswith(f"{reference.label} (")
    }
    for row in rows if only is None else only:
        if not row.truth:
            continue
        b = {"total": row.truth.get(f"{E_I}_mean")}
        ours, how = None, None
        if reference is not None and row.mesh == reference.mesh:  # our grid (ours, SfePy's, ...)
            ours = reference
            element = row.label.rsplit("-", 1)[-1] if row.source.startswith("CalculiX") else ""
            if element and element != "C3D8":
                how = f"our element's (Q1) on its mesh: {element} is an element we do not have"
                b["algorithm_how"] = f"against our Q1 implicit: {element}'s difference included"
        elif row.group and row.mesh.split(":")[0] in implicit:  # ours on simplices
            ours = implicit[row.mesh.split(":")[0]]
        elif row.mesh.startswith("tetrahedra, 6 per hexahedron") and "tetrahedron grid" in implicit:
            ours = implicit["tetrahedron grid"]
            how = (
                "our implicit on our tetrahedron grid (6 per hexahedron on the same nodes; "
                "the diagonals may differ)"
            )
        elif row.kind is Kind.USER and board is not None and truth is not None and row.series:
            from tissuebench.workflows.leaderboard.user_mesh import budget_on_mesh

            if caches is None:
                parts = budget_on_mesh(board, row, truth)
            else:  # the series read once, our implicit run once per mesh
                try:
                    user = caches.series(row.series, row.series_field)
                except Exception:
                    user = None  # budget_on_mesh reads it again and says why it cannot
                parts = budget_on_mesh(
                    board, row, truth, user, caches.on_mesh, caches.located_for(truth)
                )
            row.budget = {**b, **parts}  # our implicit on its mesh
            continue
        elif row.kind is Kind.USER and board is not None and truth is None:
            how = f"the truth {board.truth} is not computed here to grade our implicit on its mesh"
        elif row.kind is Kind.USER and row.mesh == "?":  # compare recorded no mesh
            how = "its mesh is not known here"
        else:
            how = "no run of our implicit on its mesh in this case"
        b["discretisation"] = None if ours is None else ours.truth.get(f"{E_I}_mean")
        b["discretisation_how"] = how
        if ours is not None and ours is reference:
            b["algorithm"] = 0.0 if row is reference else row.errors.get(f"{E_I}_mean")
        elif ours is row:
            b["algorithm"] = 0.0
        elif ours is not None:
            try:
                if ours.series is None or row.series is None:
                    raise TypeError("a row without its series")  # as grade(None) would
                g = grade(
                    ours.series, row.series, comm=MPI.COMM_SELF, candidate_field=row.series_field
                )
                b["algorithm"] = summarized(g.curves[E_I])[1]
                b["algorithm_how"] = f"against {ours.label}"
            except Exception as exc:
                b["algorithm"] = None
                b["algorithm_how"] = f"not graded: {type(exc).__name__}"
        b["model"] = None
        row.budget = b


def complete(budget: dict) -> bool:
    """Whether an error budget holds all four parts as finite numbers."""
    return all(
        finite(budget.get(part)) for part in ("total", "discretisation", "algorithm", "model")
    )
