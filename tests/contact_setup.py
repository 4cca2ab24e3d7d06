"""The set-up that the outside simulators' contact tests share: contact-MP1 exported on the
N = 8 block with our implicit run beside it, and an XDMF series read back whole."""

from pathlib import Path

from mpi4py import MPI

import h5py
import numpy as np

from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.posing import build, run_reference

H = 1 / 30  # s


def series(path: Path, steps: int, field: str = "displacement") -> np.ndarray:
    """The field at steps + 1 time points of an XDMF series (its .h5 beside it): (steps + 1,
    nodes, components), m."""
    with h5py.File(Path(path).with_suffix(".h5")) as f:
        return np.array([f[f"/Function/{field}/{i}"][...] for i in range(steps + 1)])


def contact_case(folder: Path, kappa: float, steps: int):
    """(Exported contact-MP1 of mesh size 8 with `kappa` to steps x H, our implicit's
    displacement (steps + 1, N, 3) m, and its `reference` record with the needle force)."""
    material = get_material("MP1")
    data, bench, _ = build(
        "contact", 8, {"kappa": kappa, "load_scale": 1.0}, material, "linear", H, steps,
        "strain", "dynamic", MPI.COMM_WORLD,
    )  # fmt: skip
    path = Path(folder) / "ours.xdmf"
    info = run_reference(data, bench, material, path, log=lambda *a: None)
    return data, series(path, steps), info
