"""Run directories that are whole or absent: everything is written into a hidden partial
directory beside the target, which replaces the target only when complete."""

import json
import shutil
from contextlib import contextmanager
from pathlib import Path

from mpi4py import MPI

SUMMARY = "summary.json"


def is_complete(out_dir):
    """A run directory is complete when its summary lists files that all exist."""
    path = Path(out_dir) / SUMMARY
    try:
        summary = json.loads(path.read_text())
        return all((Path(out_dir) / f).is_file() for f in summary["files"])
    except (OSError, ValueError, KeyError, TypeError):
        return False


def check_writable(out_dir):
    """Raise PermissionError unless out_dir can be created and written (nothing is created)."""
    from tissuebench.metrics.compare import check_output
    from tissuebench.metrics.series import InputError

    try:
        check_output(out_dir)
    except InputError as err:
        raise PermissionError(f"output cannot be written: {err}") from None


@contextmanager
def partial_directory(out_dir, comm=MPI.COMM_WORLD):
    """Yield a fresh hidden directory; on success it replaces out_dir (rank 0 moves it)."""
    out = Path(out_dir).absolute()
    partial = out.parent / f".partial-{out.name}"
    if comm.rank == 0:
        shutil.rmtree(partial, ignore_errors=True)
        partial.mkdir(parents=True)
    comm.barrier()
    yield partial
    comm.barrier()
    if comm.rank == 0:
        old = out.parent / f".old-{out.name}"
        shutil.rmtree(old, ignore_errors=True)
        if out.exists():
            out.rename(old)
        partial.rename(out)
        shutil.rmtree(old, ignore_errors=True)
    comm.barrier()
