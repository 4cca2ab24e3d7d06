"""The figures of a contact case (SPEC 12): the needle's force and the interpenetration against
time, one line per run."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_contact(path: Path, name: str, times: np.ndarray, contacts: dict[str, np.ndarray]) -> None:
    """contact.png: F_x (N/m), the force the tissue exerts on the needle along its motion's
    axis, and the interpenetration (mm) against time (s), each run a line."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    force, depth = fig.subplots(1, 2)
    for k, (label, rows) in enumerate(contacts.items()):
        t = times[: len(rows)]
        style = {"color": f"C{k % 10}", "lw": 1.2, "label": label}
        force.plot(t, rows[:, 0], **style)
        depth.plot(t, 1e3 * rows[:, 2], **style)
    force.set_ylabel("needle force F_x (N/m)")
    depth.set_ylabel("interpenetration, largest -g_n (mm)")
    for ax in (force, depth):
        ax.set_xlabel("time t (s)")
        ax.grid(True, alpha=0.3)
    force.legend(fontsize=8)
    fig.suptitle(f"{name}: the rigid needle's force and how far the tissue passes into it")
    fig.savefig(path, format="png", dpi=110)
