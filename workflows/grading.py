"""Grading a simulator's output against a reference, with files: `compare` checks that the
output folder can be written, grades (metrics/compare.py) and writes OUT/metrics.csv and
OUT/metrics.png, each renamed into place once complete (rank 0 writes)."""

from __future__ import annotations

import os
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.compare import grade
from tissuebench.metrics.errors import METRICS, panels
from tissuebench.workflows.files import spans_decades, write_metrics_csv
from tissuebench.workflows.output import check_writable, collective


def compare(
    reference: str | Path,
    candidate: str | Path,
    out_dir: str | Path,
    field: str = "displacement",
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> dict[str, str]:
    """Grade the candidate series against the reference series (XDMF or PVD files), write
    out_dir/metrics.csv and out_dir/metrics.png, and return the one-line summaries (see
    metrics.compare.Grading). Collective; nothing is written unless everything was read,
    checked and computed."""
    check_writable(out_dir, comm)
    g = grade(reference, candidate, field, comm)
    collective(comm, lambda: write_grading(Path(out_dir), g), Path(out_dir))
    return g.summaries


def write_grading(out: Path, g) -> None:
    """metrics.csv and metrics.png in out, each renamed into place once complete."""
    out.mkdir(parents=True, exist_ok=True)
    final = [out / "metrics.csv", out / "metrics.png"]
    temporary = [p.with_name(f".{p.name}.{os.getpid()}.tmp") for p in final]
    try:
        write_metrics_csv(temporary[0], g.times, {g.label: g.curves}, {g.label: g.status})
        plot(temporary[1], g.title, g.times, g.curves)
        for tmp, path in zip(temporary, final):
            os.replace(tmp, path)
    finally:
        for tmp in temporary:
            tmp.unlink(missing_ok=True)


def plot(path, title, times, curves):
    """One panel per metric against time (E_n, E_s, E_i; a variant such as E_i's nodal form
    dashed in its metric's panel)."""
    from matplotlib.figure import Figure  # no pyplot: no global backend state

    groups = panels()
    fig = Figure(figsize=(7, 2.7 * len(groups)), layout="constrained")
    axes = fig.subplots(len(groups), 1, sharex=True, squeeze=False)[:, 0]
    for ax, names in zip(axes, groups):
        for name, style in zip(names, ["-", "--"]):
            ax.plot(times, curves[name], style, label=METRICS[name].label)
        if spans_decades(np.concatenate([curves[n] for n in names])):
            ax.set_yscale("log")
        ax.set_ylabel(METRICS[names[0]].label)
        ax.grid(True, alpha=0.3)
        if len(names) > 1:
            ax.legend()
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title)
    fig.savefig(path, format="png", dpi=120)
