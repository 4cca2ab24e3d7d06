"""From a gmsh model to a distributed DOLFINx mesh with its boundary tags.

The gmsh model is built on rank 0 only; `dolfinx.io.gmsh.model_to_mesh` distributes it.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI  # noqa: F401 (loads libmpi before dolfinx)

import dolfinx.io.gmsh
import dolfinx.mesh
import numpy as np

from tissuebench.core.errors import UserError


class MeshError(UserError):
    """A mesh that cannot be built from the arguments given (bad size, bad file)."""


@dataclass
class TaggedMesh:
    """A DOLFINx mesh and its physical groups.

    `tags[name]` is (dim, MeshTags) for every physical group of the gmsh script; `groups`
    maps name to gmsh physical tag. Lengths are in metres.
    """

    mesh: dolfinx.mesh.Mesh
    tags: dict
    groups: dict

    def entities(self, name: str) -> tuple[int, np.ndarray]:
        """(dim, local entity indices) of the physical group `name`."""
        dim, mt = self.tags[name]
        return dim, mt.find(self.groups[name])


def start_gmsh() -> None:
    import gmsh  # here, not at the top: 40 ms of every command's start

    if not gmsh.isInitialized():
        # gmsh's initialize puts the default SIGTERM action back: keep the caller's handlers
        handlers = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
        gmsh.initialize(interruptible=False)
        if threading.current_thread() is threading.main_thread():
            for number, handler in handlers.items():
                if handler is not None:
                    signal.signal(number, handler)
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.clear()


@contextlib.contextmanager
def gmsh_options(options: dict[str, float]) -> Iterator[None]:
    """gmsh's numeric options set for the context's length and put back after it: gmsh.clear()
    keeps options, so a mesh that sets its own would change every later mesh of the process."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    before = {name: gmsh.option.getNumber(name) for name in options}
    try:
        for name, value in options.items():
            gmsh.option.setNumber(name, value)
        yield
    finally:
        for name, value in before.items():
            gmsh.option.setNumber(name, value)


def to_dolfinx(comm: MPI.Comm, gdim: int, msh_path: str | Path | None = None) -> TaggedMesh:
    """Turn the current gmsh model (on rank 0) into a TaggedMesh on `comm`; optionally save .msh."""
    import gmsh  # here, not at the top: 40 ms of every command's start

    if comm.rank == 0 and msh_path is not None:
        Path(msh_path).parent.mkdir(parents=True, exist_ok=True)
        gmsh.write(str(msh_path))
    data = dolfinx.io.gmsh.model_to_mesh(gmsh.model if comm.rank == 0 else None, comm, 0, gdim=gdim)
    if comm.rank == 0:
        gmsh.clear()
    tdim = data.mesh.topology.dim
    by_codim = {0: data.cell_tags, 1: data.facet_tags, 2: data.ridge_tags, 3: data.peak_tags}
    tags, groups = {}, {}
    for name, group in data.physical_groups.items():
        codim = tdim - group.dim
        if codim == 0:
            continue
        tags[name] = (group.dim, by_codim[codim])
        groups[name] = group.tag
    return TaggedMesh(data.mesh, tags, groups)


def check_positive_int(name: str, value: object) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise MeshError(f"{name} must be a positive whole number, got {value!r}")
