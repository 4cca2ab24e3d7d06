"""The suite runs in serial (`pytest`) and, for the tests that are parallel-safe, under MPI
(`mpiexec -n 2 pytest -m "not serial"`), as DOLFINx's own CI does. Tests marked `serial` drive
subprocesses (the command line, or the serial-versus-mpiexec scripts) and run in serial only;
every other test is collective and allreduces before asserting.

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


def pytest_collection_modifyitems(config, items):
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
