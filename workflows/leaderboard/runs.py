"""One case run and timed anew (`--rerun`): our algorithms and models, on the case's mesh and
on simplices, and every outside simulator that poses it, graded against its reference."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from tissuebench.solvers import ALGORITHMS
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.models import run_label
from tissuebench.workflows.io.summary import CaseSummary, read_summary
from tissuebench.workflows.leaderboard.boards import is_contact
from tissuebench.workflows.leaderboard.contact import external_contact, our_forces
from tissuebench.workflows.leaderboard.record import FOLDER
from tissuebench.workflows.leaderboard.rows import (
    Board,
    Row,
    candidate_of,
    external_rows,
    mark_pareto,
    our_rows,
)
from tissuebench.workflows.run.case import model_case, run_case
from tissuebench.workflows.simulators import get_simulator
from tissuebench.workflows.simulators.runner import SimulatorError, run_external

if TYPE_CHECKING:
    pass


def run_board(
    board: Board,
    out: Path,
    solver: str,
    petsc: str,
    comm,
    log=print,
    users: list[Row] | None = None,
):
    """Our runs, then every simulator's, of one case, with the users' rows (read and checked
    before anything runs: read_users); returns (rows, notes)."""
    folder = out / FOLDER / board.name
    reference = run_label("implicit", board.model)
    contact = is_contact(board)  # SPEC 12: explicit ones sub-step (their step counts the penalty)
    more = {"substeps": "auto"} if contact else {}
    case = model_case(
        board.name,
        board.benchmark,
        board.material,
        list(ALGORITHMS),
        list(board.models),
        reference,
        options=board.options,
        mesh_size=board.mesh_size,
        end_time=board.end_time,
        solver=solver,
        petsc=petsc,
        description=board.description,
        **more,
    )
    summary = run_case(case, folder / "ours", comm, log, force=True)
    rows: list[Row] = our_rows(board.name, summary)
    for row in rows:
        row.series = str(folder / "ours" / f"{row.label}.xdmf")
    notes = []
    if contact:
        if comm.rank == 0:
            our_forces(folder / "ours", rows, folder / "forces")
        notes.append(
            "ours on simplices are not run on a contact case (left out to keep its timing "
            "session short): the five algorithms on the case's quadrilaterals only"
        )
    elif board.models == ("linear",):
        rows += simplex_rows(board, case, folder, summary, comm, log)
    if board.skip_note:
        notes.append(board.skip_note)
    for name in board.simulators:
        missing = comm.bcast(get_simulator(name).available() if comm.rank == 0 else None, root=0)
        if missing:
            notes.append(f"{name}: not run on this machine ({missing})")
            continue
        chosen = board.variants.get(name)
        if chosen is not None and not chosen:
            continue  # none at this size: the board's skip_note says why
        try:
            result = run_external(
                name,
                folder / name,
                benchmark=board.benchmark,
                mesh_size=summary.mesh_size,
                options=board.options,
                material=get_material(board.material),
                model=board.simulator_model or board.model,
                h=summary.h,
                steps=summary.steps,
                variants=list(chosen) if chosen is not None else None,
                solver=solver,
                petsc=petsc,
                force=True,
                comm=comm,
                log=log,
            )
        except SimulatorError as exc:
            notes.append(str(exc))
            continue
        graded = external_rows(board.name, result)
        for row, run in zip(graded, result["runs"].values(), strict=True):
            row.series, row.series_field = external_series(folder / name, run.get("variant"))
            if contact:
                external_contact(row, run, external_force(folder / name, run.get("variant")))
        rows += graded
        for variant, why in (result.get("skipped_variants") or {}).items():
            notes.append(f"{name}:{variant} not posed: {why}")
    rows += users or []
    mark_pareto(rows)
    return rows, notes


def simplex_rows(
    board: Board, case, folder: Path, summary: CaseSummary, comm, log=print
) -> list[Row]:
    """Our algorithms on the board's mesh size in simplices (the grid split, and gmsh's
    unstructured mesh: SPEC 9), each graded on its own mesh against the board's reference."""
    from dataclasses import replace

    from tissuebench.meshes import get_entry
    from tissuebench.metrics.compare import summarize
    from tissuebench.workflows.compare.grading import grade
    from tissuebench.workflows.leaderboard.mesh_sensitivity import shapes

    reference = folder / "ours" / f"{summary.reference}.xdmf"
    gdim = get_entry(board.benchmark).gdim
    rows = []
    for shape, options in list(shapes(gdim).items())[1:]:
        name = shape.replace(" ", "-")
        sub = replace(case, name=f"{board.name}-{name}", options={**board.options, **options})
        on_shape = run_case(sub, folder / f"ours-{name}", comm, log, force=True)
        for row in our_rows(board.name, on_shape):
            row.series = str(folder / f"ours-{name}" / f"{row.label}.xdmf")
            graded = grade(reference, row.series, comm=comm)
            for metric, curve in graded.curves.items():
                row.errors[f"{metric}_max"], row.errors[f"{metric}_mean"] = summarize(curve)
            row.label = f"{row.label} ({shape})"
            row.mesh = f"{shape}: {on_shape.num_dofs // gdim} nodes"
            row.reference = False
            row.group = "tissuebench on simplices"
            rows.append(row)
    return rows


def moved(folder: Path, variant: str, file: str) -> str:
    """A file that a variant's summary recorded in the folder's partial copy, as it is under
    the final folder (VARIANT/... on), where it is there or the recorded one is gone."""
    parts = Path(file).parts
    if variant in parts:  # .../<partial folder>/VARIANT/...: the same under the final folder
        at = len(parts) - 1 - parts[::-1].index(variant)
        there = folder.joinpath(*parts[at:])
        if there.is_file() or not Path(file).is_file():
            return str(there)
    return file


def external_force(folder: Path, variant) -> str | None:
    """The needle force file that a simulator variant handed compare on a contact case, as its
    summary.json's contact entry records it (None: it handed none). Rank 0 reads."""
    if not isinstance(variant, str) or not variant:
        return None
    summary = read_summary(folder / variant)
    contact = summary.get("contact") if isinstance(summary, dict) else None
    file = contact.get("force_file") if isinstance(contact, dict) else None
    return moved(folder, variant, file) if isinstance(file, str) and file else None


def external_series(folder: Path, variant) -> tuple[str | None, str | None]:
    """The series file (and its field) that a simulator variant's compare graded, as its
    summary.json (FOLDER/VARIANT/summary.json) records it; the file was recorded in the
    folder's partial copy, so its path is taken from the variant's folder on (None, None
    when nothing is recorded). Rank 0 reads."""
    if not isinstance(variant, str) or not variant:
        return None, None
    summary = read_summary(folder / variant)
    recorded = candidate_of(summary) if isinstance(summary, dict) else {}
    file = recorded.get("series")
    if file is None:
        return None, None
    return moved(folder, variant, file), recorded.get("series_field")
