"""Before any heavy work: the steps, memory and disk a case will need, against what the machine
has. A case that cannot finish is refused in one line naming the numbers.

The estimates are lower bounds on purpose (a case refused must really not fit): memory
counts the loaded libraries, the matrices and factorisations at a measured cost per degree of
freedom, and the histories held until the end of the case; disk counts the HDF5 series, the
XDMF text, the CSV rows and the figures.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from tissuebench.core.errors import UserError

BASE_MEMORY = 400e6  # bytes per process: Python with DOLFINx, PETSc, gmsh, matplotlib, pyvista
# bytes per dof for K, M, M_L, the step matrices and their MUMPS factors, five algorithms:
# measured 3.2e3 (block N = 100 -> 300) and 1.2e4 (rod n = 8 -> 16) as peak RSS growth per dof
SOLVER_MEMORY = {2: 2.5e3, 3: 1.0e4}
XDMF_TEXT = 700  # bytes of XDMF per step and field
CSV_ROW = 150  # bytes per metrics.csv or tip.csv row
FIGURES = 3e6  # bytes: the PNG figures and the GIF of one case
MAX_STEPS = 10**9  # steps in one run: beyond any run this machine can hold


class LimitError(UserError):
    """A case that cannot finish on this machine: one line, exit status 2."""


@dataclass
class Need:
    """What a case needs: bytes of memory (all ranks together) and of disk."""

    memory: float
    disk: float
    dofs: int
    steps: int
    runs: int


def step_count(h: float, end_time: float) -> int:
    """The number of steps of h (s) that end at end_time (s): round(T / h), at least 1."""
    ratio = end_time / h
    if not math.isfinite(ratio) or ratio > MAX_STEPS:
        raise LimitError(
            f"end time {end_time:g} s with h = {h:g} s makes {ratio:.3g} steps, more than "
            f"{MAX_STEPS:.0e}: use a larger h or a shorter end time"
        )
    return max(1, round(ratio))


def estimate(gdim: int, nodes: int, steps: int, runs: int, ranks: int = 1) -> Need:
    """Memory and disk of a case of `runs` runs of `steps` steps on a mesh of `nodes` nodes."""
    dofs = gdim * nodes
    history = 2 * (steps + 1) * dofs * 8.0  # u and v of every step, kept for the metrics
    gathered = 2 * (
        2 * (steps + 1) * nodes * 3 * 8.0
    )  # one run's fields gathered, and its HDF5 image
    memory = ranks * BASE_MEMORY + SOLVER_MEMORY[gdim] * dofs + runs * history + gathered
    series = runs * (2 * (steps + 1) * nodes * 3 * 8.0 + 2 * (steps + 1) * XDMF_TEXT)
    disk = series + 2 * runs * (steps + 1) * CSV_ROW + FIGURES
    return Need(memory, disk, dofs, steps, runs)


def available_memory() -> float | None:
    """MemAvailable of /proc/meminfo in bytes, or None where there is none."""
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return float(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def free_disk(path: Path) -> float:
    """Free bytes on the file system that holds path (or its nearest existing parent)."""
    existing = next(p for p in [Path(path), *Path(path).parents] if p.exists())
    return float(shutil.disk_usage(existing).free)


def gb(x: float) -> str:
    return f"{x / 1e9:.3g} GB"


def check(need: Need, out: Path, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Raise LimitError on every rank if the case cannot fit in memory or on disk (rank 0's
    view of the machine)."""
    error = None
    if comm.rank == 0:
        size = f"{need.dofs:,} dofs, {need.steps:,} steps, {need.runs} run(s)"
        memory = available_memory()
        disk = free_disk(out)
        if memory is not None and need.memory > memory:
            error = (
                f"this case needs at least {gb(need.memory)} of memory ({size}) and {gb(memory)} "
                "is available: use a smaller mesh, fewer steps or fewer algorithms"
            )
        elif need.disk > disk:
            error = (
                f"this case writes at least {gb(need.disk)} ({size}) and {out} has {gb(disk)} "
                "free: use a smaller mesh, fewer steps or fewer algorithms, or another --out"
            )
    error = comm.bcast(error, root=0)
    if error is not None:
        raise LimitError(error)
