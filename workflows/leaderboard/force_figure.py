"""A contact case's force figure (SPEC 12, 13): the force on the tool along its push (F_x in
N/m for the needle in the plane, F_z in N for the capsule in 3D) against time of every
run that hands its force (ours from contact.csv, a simulator's and a user's from its force
file), as the curve its row carries (force_curve.py: the record keeps it, so that a render
anywhere draws it; no file is read here), beside the truth's with its own error as a band where
the truth is computed here (leaderboard/CASE-force.png). Rank 0."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tissuebench.workflows.leaderboard.contact import truth_force
from tissuebench.workflows.leaderboard.force_curve import row_force
from tissuebench.workflows.leaderboard.rows import Board, Row, plain

_LOADED = Path(__file__).read_text()  # this module as this process loaded it (as figures.py)


def force_drawing_code() -> str:
    """The SHA-256 of the code that draws a force figure (the case figures' code and this
    module, as this process loaded them), stamped into it: a figure drawn by other code is
    drawn again."""
    import hashlib

    from tissuebench.workflows.leaderboard.figures import drawing_code

    return hashlib.sha256((drawing_code() + _LOADED).encode()).hexdigest()


def force_png(out: Path, board: Board) -> Path:
    """Where a contact case's force figure goes: OUT/leaderboard/CASE-force.png (beside the
    page, index.html, which links it)."""
    from tissuebench.workflows.leaderboard.record import FOLDER

    return out / FOLDER / f"{board.name}-force.png"


def plot_force(path: Path, board: Board, rows: list[Row]) -> None:
    """The force along the push against t of each row that carries its force curve (row_force;
    ours solid, the simulators' dashed, a run that did not finish to where it ended, marked
    there with x and its status in the legend, so that one that ended at its first step is
    seen), and the truth's (black, with its own error as a grey band) where it is in the cache;
    a row that handed a force file whose curve is not recorded is named in the figure's note."""
    from matplotlib.figure import Figure

    from tissuebench.workflows.leaderboard.figures import STAMP

    fig = Figure(figsize=(11.5, 5.4), layout="constrained")
    ax = fig.subplots()
    tool, unit = push_component(board)
    name = f"F_{'xyz'[tool]}"
    force = truth_force(board.truth) if board.truth else None
    if force is not None:
        h = board_h(board, rows)
        t = np.arange(len(force.force)) * h
        band = force.own_error * np.linalg.norm(force.force, axis=1).max()
        fx = force.force[:, tool]
        ax.fill_between(t, fx - band, fx + band, color="0.82", lw=0)
        ax.plot(t, fx, "k-", lw=2.2, label=f"truth {board.truth} (band: its own error)")
    missing = []
    # ours with the case's model only (every model of ours on a nonlinear case: 25 curves)
    handed = [r for r in rows if r.force or r.force_curve is not None]
    shown = [r for r in handed if r.source != "tissuebench" or of_model(r, board)]
    others = sum(1 for r in handed if r not in shown)
    for k, row in enumerate(shown):
        found = row_force(row)
        if found is None:
            missing.append(row.label)
            continue
        times, f = found
        ours = row.source == "tissuebench"
        ended = row.status != "ok"  # its curve stops where the run did: marked there
        ax.plot(
            times,
            f[:, tool] if f.shape[1] > tool else np.full(len(times), np.nan),
            "-" if ours else "--",
            marker="x" if ended else None,
            markevery=[len(times) - 1] if ended else None,
            lw=2.4 if row.reference else (1.0 if ours else 0.8),
            zorder=3 if row.reference else 2,  # on top: the others are graded against it
            alpha=0.75 if row.reference or not ours else 1.0,  # a simulator's may chatter
            color=f"C{k % 10}",
            label=plain(row.label)
            + (" (reference)" if row.reference else "")
            + (f" ({row.status} at t = {times[-1]:.3g} s: x)" if ended else ""),
        )
    untold = [r.label for r in rows if r.contact and not (r.force or r.force_curve is not None)]
    ax.set_xlabel("time t (s)")
    ax.set_ylabel(f"force on the tool {name} ({unit})")
    title = f"{board.name}: the force the tissue exerts on the rigid tool, along its push"
    if force is None:
        title += " (no truth force here)"
    ax.set_title(title, fontsize=10)
    note = []
    if untold:
        note.append("no needle force reported by " + ", ".join(plain(x) for x in untold))
    if others:
        note.append(f"{others} runs of ours with other models: in leaderboard.csv")
    if missing:
        note.append(
            f"{len(missing)} runs' forces not in the record (run before the record carried "
            f"them: `tissuebench leaderboard --rerun {board.name}` records them): "
            + ", ".join(plain(x) for x in missing)
        )
    if note:
        import textwrap

        lines = textwrap.wrap("; ".join(note), 150)
        shown = "\n".join(lines[:4]) + (" ..." if len(lines) > 4 else "")
        ax.text(0.01, 0.01, shown, transform=ax.transAxes, fontsize=7, va="bottom")
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:  # beside: no curve hidden
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.savefig(path, format="png", dpi=110, metadata={STAMP: force_drawing_code()})


def push_component(board: Board) -> tuple[int, str]:
    """The component of the tool's force drawn, the one along its push (its entry's tool's
    axis: x for SPEC 12's needle, z for SPEC 13's capsule), and the force's unit."""
    from tissuebench.meshes import get_entry

    make = get_entry(board.benchmark).tool
    if make is None:
        return 0, "N/m"
    tool = make()
    return int(tool.axis), tool.force_unit


def board_h(board: Board, rows: list[Row]) -> float:
    """The case's time step h (s): the benchmark's (the boards keep it)."""
    from tissuebench.meshes import get_entry

    return float(get_entry(board.benchmark).dt)


def of_model(row: Row, board: Board) -> bool:
    """Whether a row of ours runs the case's model (its label ALGORITHM, or ALGORITHM+MODEL)."""
    model = row.label.partition("+")[2] or "linear"
    return model == board.model
