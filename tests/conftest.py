"""The suite runs in serial (`pytest`) and, for the tests marked `parallel`, under MPI as well
(`mpiexec -n 2 pytest -m parallel`), as DOLFINx's own CI does. Tests marked `serial` drive
subprocesses (the command line, or the serial-versus-mpiexec scripts) and run in serial only;
every other test is collective and allreduces before asserting, so that it passes under
`mpiexec -n 2 pytest -m "not serial"` too, but `make test` runs under mpiexec only the tests
marked `parallel`: those whose assertion is about the ranks, namely that every rank gets the
serial numbers (or the committed ones), that rank 0's work reaches every rank, or that owned
and ghost entities are counted once. The parallel code paths of the solvers and metrics are
compared serial against 2 ranks in the serial pass (tests/mpi_*.py, started by tests marked
`serial`), so a physics test that is merely collective is not run again under mpiexec.
`make test` runs the serial pass in one process per core and one more (pytest-xdist, `-n
CORES+1 --dist loadfile`, a test file to a process): each has its own tmp_path, and the caches
they share (compiled forms and kernels, the default truth cache) are put in place atomically or
under a lock, as for the ranks of mpiexec.

The time estimates are the measured ones in every test and in the commands they start
(TISSUEBENCH_SLOWDOWN=1: not scaled by this machine's load, core/speed.py), so that their text
is the same on every machine."""

import os
from pathlib import Path

from mpi4py import MPI

import pytest

os.environ["TISSUEBENCH_SLOWDOWN"] = "1"


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "serial: runs in serial only (subprocesses, or serial-only checks)"
    )
    config.addinivalue_line(
        "markers",
        "parallel: about the ranks (every rank gets the serial numbers, rank 0's work reaches "
        "every rank, owned and ghost entities counted once): make test runs it under mpiexec too",
    )
    config.addinivalue_line(
        "markers",
        "outside: runs an outside simulator (CalculiX's ccx, or a pip extra of make "
        "external-tools): make test leaves it to make external-tests",
    )
    config.addinivalue_line(
        "markers", "browser: drives chromium: make test leaves it to make browser-tests"
    )
    config.addinivalue_line(
        "markers",
        "slow: in a test file of a minute or more in all: its file runs first, so that no process "
        "of the serial pass is left with it at the end",
    )


def pytest_collection_modifyitems(config, items):
    marked = [item for item in items if item.get_closest_marker("parallel")]
    both = [item.nodeid for item in marked if item.get_closest_marker("serial")]
    if both:  # the mpiexec pass (-m parallel) would skip them
        raise pytest.UsageError(f"marked both serial and parallel: {', '.join(both)}")
    # the files with a slow test first (with --dist loadfile --no-loadscope-reorder: handed out
    # first), each file's tests in their order
    slow = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow)
    if MPI.COMM_WORLD.size == 1:
        return
    skip = pytest.mark.skip(reason="serial-only test, skipped under mpiexec")
    for item in items:
        if "serial" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def tmp_path(tmp_path):
    """One folder for all ranks: rank 0's."""
    return Path(MPI.COMM_WORLD.bcast(str(tmp_path), root=0))


@pytest.fixture(scope="module")
def empty_truth_cache(tmp_path_factory):
    """$TISSUEBENCH_CACHE an empty folder of the module's own, for the commands it starts: `run`
    grades a case against its truth only where this machine's cache holds that truth (never in
    CI, which starts from nothing), tens of seconds a run here; the modules that use this check
    nothing of that grading (tests/test_run_truth.py does)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("TISSUEBENCH_CACHE", str(tmp_path_factory.mktemp("empty-cache")))
        yield
