"""The figures of a contact case (SPEC 12): the needle's force and the interpenetration against
time, one line per run."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_contact(
    path: Path, name: str, times: np.ndarray, contacts: dict[str, np.ndarray], tool=None
) -> None:
    """contact.png: the force the tissue exerts on the needle along its motion's axis (F_x in
    N/m for the 2D needle, F_z in N for the 3D capsule: the tool's axis and unit), and the
    interpenetration (mm) against time (s), each run a line."""
    axis = tool.axis if tool is not None else 0
    unit = tool.force_unit if tool is not None else "N/m"
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    force, depth = fig.subplots(1, 2)
    for k, (label, rows) in enumerate(contacts.items()):
        t = times[: len(rows)]
        style = {"color": f"C{k % 10}", "lw": 1.2, "label": label}
        force.plot(t, rows[:, axis], **style)
        depth.plot(t, 1e3 * rows[:, -1], **style)
    force.set_ylabel(f"needle force F_{'xyz'[axis]} ({unit})")
    depth.set_ylabel("interpenetration, largest -g_n (mm)")
    for ax in (force, depth):
        ax.set_xlabel("time t (s)")
        ax.grid(True, alpha=0.3)
    force.legend(fontsize=8)
    fig.suptitle(f"{name}: the rigid needle's force and how far the tissue passes into it")
    fig.savefig(path, format="png", dpi=110)
