"""A displacement series read from a file written by any simulator: XDMF (io/xdmf.py),
ParaView .pvd (io/vtk.py), CalculiX .frd and .dat (io/calculix.py); the Series and its checks
are metrics/series.py's."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

from tissuebench.metrics.series import InputError, Series, series_of
from tissuebench.workflows.io.fields import DEFAULT_FIELDS, field_names

__all__ = ["DEFAULT_FIELDS", "read_on_rank0", "read_series"]


def read_series(path: str | Path, field: str | None = None) -> Series:
    """The Series of point field `field` (None: the first of DEFAULT_FIELDS present) in an
    .xdmf, .pvd, .frd or .dat file."""
    from tissuebench.workflows.io.calculix import read_dat, read_frd
    from tissuebench.workflows.io.vtk import read_pvd
    from tissuebench.workflows.io.xdmf import read_xdmf

    path = Path(path)
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


def read_on_rank0(comm: MPI.Comm, *files: tuple) -> list[Series | None]:
    """The series of each (path, field) read on rank 0 (None on the other ranks). Collective:
    an unreadable file raises one InputError on every rank, so that none is left waiting."""
    series, error = [], None
    if comm.rank == 0:
        for path, field in files:
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
