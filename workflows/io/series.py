"""A displacement series read from a file written by any simulator: XDMF (io/xdmf.py),
ParaView .pvd (io/vtk.py), CalculiX .frd and .dat (io/calculix.py); the Series and its checks
are metrics/series.py's."""

from __future__ import annotations

import errno
import os
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

from tissuebench.metrics.series import InputError, Series, series_of
from tissuebench.workflows.io import limits
from tissuebench.workflows.io.fields import DEFAULT_FIELDS, field_names

__all__ = ["DEFAULT_FIELDS", "check_input_path", "read_on_rank0", "read_series"]


def check_input_path(path: str | Path) -> None:
    """Refuse (InputError, one line) an input path that cannot be followed to a file: a
    symbolic-link loop (loop1.xdmf -> loop2.xdmf -> loop1.xdmf), which would otherwise fail
    deep in a reader. A path that does not exist is left to the reader to name."""
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise InputError(
                f"{path}: a symbolic-link loop (its links lead back to themselves, never to a "
                "file): point it at the series file"
            ) from None


def read_series(path: str | Path, field: str | None = None) -> Series:
    """The Series of point field `field` (None: the first of DEFAULT_FIELDS present) in an
    .xdmf, .pvd, .frd or .dat file."""
    from tissuebench.workflows.io.calculix import read_dat, read_frd
    from tissuebench.workflows.io.vtk import read_pvd
    from tissuebench.workflows.io.xdmf import read_xdmf

    path = Path(path)
    check_input_path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    readers = {".xdmf": read_xdmf, ".pvd": read_pvd, ".frd": read_frd, ".dat": read_dat}
    if path.suffix.lower() not in readers:
        raise InputError(
            f"{path}: unknown format {path.suffix!r}; expected .xdmf (with .h5), .pvd (with "
            ".vtu), or CalculiX's .frd or .dat (with its .inp)"
        )
    points, cells, cell_type, times, values, found = readers[path.suffix.lower()](
        path, field_names(field)
    )
    return series_of(path, found, points, cells, cell_type, times, values)


def series_size(path: str | Path, field: str | None = None) -> tuple[float, int, int] | None:
    """(bytes, nodes, steps): a lower bound of the memory that reading the series will hold,
    from its datasets' shapes without reading them (XDMF with HDF5 or inline data; see
    io/xdmf.xdmf_size); None for the other formats, or when the file does not say."""
    from tissuebench.workflows.io.xdmf import xdmf_size

    path = Path(path)
    if path.suffix.lower() != ".xdmf" or not path.is_file():
        return None
    return xdmf_size(path, field_names(field))


def check_memory(files: Sequence[tuple]) -> None:
    """Refuse (InputError, one line naming the numbers) series (path, field) that cannot be
    held together in the machine's available memory (MemAvailable, workflows/io/limits.py), as
    estimated by series_size before anything is read. Series whose size is not known count
    nothing (the estimate is a lower bound: what is refused cannot fit)."""
    available = limits.available_memory()
    if available is None:
        return
    sizes = [(path, series_size(path, field)) for path, field in files]
    need = sum(size[0] for _, size in sizes if size is not None)
    if need <= available:
        return
    parts = ", ".join(
        f"{path}: {nodes:,} nodes x {steps:,} steps, {limits.gb(size)}"
        for path, (size, nodes, steps) in ((p, s) for p, s in sizes if s is not None)
    )
    raise InputError(
        f"reading the series needs at least {limits.gb(need)} of memory ({parts}) and "
        f"{limits.gb(available)} is available: free memory, or grade a series of fewer steps "
        "or nodes"
    )


def read_on_rank0(comm: MPI.Comm, *files: tuple) -> list[Series | None]:
    """The series of each (path, field) read on rank 0 (None on the other ranks), once
    check_memory has found that they fit. Collective: an unreadable file, or series that
    cannot fit in memory, raise one InputError on every rank, so that none is left waiting."""
    series: list[Series | None] = []
    error = None
    if comm.rank == 0:
        try:
            check_memory(files)
        except InputError as exc:
            error = str(exc)
        for path, field in files if error is None else ():
            try:
                series.append(read_series(path, field))
            except InputError as exc:
                error = str(exc)
            except Exception as exc:
                error = (
                    f"{path}: cannot be read ({type(exc).__name__}: {' '.join(str(exc).split())})"
                )
            if error is not None:
                break
    error = comm.bcast(error, root=0)
    if error is not None:
        raise InputError(error)
    return series if comm.rank == 0 else [None] * len(files)
