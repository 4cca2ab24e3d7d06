"""io/xdmf.as_series: the Series that study hands the figures in memory is the one that reading
back the XDMF file it writes gives, array for array (so the figures are the same bytes)."""

from mpi4py import MPI

import numpy as np
import pytest
from dolfinx import fem

from tissuebench.meshes import get_benchmark
from tissuebench.metrics.series import InputError
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.io.xdmf import as_series, gather_series, write_series

pytestmark = pytest.mark.serial  # one rank writes and reads; the arrays are rank 0's


@pytest.mark.parametrize("benchmark, size", [("block", 4), ("rod", 1)])
def test_in_memory_series_is_the_file_read_back(tmp_path, benchmark, size):
    bench = get_benchmark(benchmark, mesh_size=size, comm=MPI.COMM_SELF)
    V = fem.functionspace(bench.mesh, ("Lagrange", 1, (bench.mesh.geometry.dim,)))
    rng = np.random.default_rng(3)
    n = V.dofmap.index_map.size_local * V.dofmap.bs
    u = [rng.standard_normal(n) * 1e-3 for _ in range(4)]
    gathered = gather_series(V, {"displacement": u, "velocity": u})
    times = np.arange(len(u)) * (1 / 30)
    path = tmp_path / "run.xdmf"
    write_series(path, gathered, times)
    read, memory = read_series(path), as_series(path, gathered, times)
    assert memory.path == read.path and memory.field == read.field
    assert memory.cell_type == read.cell_type
    for name in ("points", "cells", "times"):
        got, expected = getattr(memory, name), getattr(read, name)
        assert got.dtype == expected.dtype and np.array_equal(got, expected), name
    assert len(memory.displacements) == len(read.displacements)
    for a, b in zip(memory.displacements, read.displacements, strict=True):
        assert a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)


def test_a_run_without_steps_is_refused_alike(tmp_path):
    """A run that diverged at step 0 keeps no step: InputError either way, which the figures
    take as nothing to draw."""
    bench = get_benchmark("block", mesh_size=4, comm=MPI.COMM_SELF)
    V = fem.functionspace(bench.mesh, ("Lagrange", 1, (2,)))
    gathered = gather_series(V, {"displacement": [], "velocity": []})
    path = tmp_path / "run.xdmf"
    write_series(path, gathered, [])
    with pytest.raises(InputError):
        read_series(path)
    with pytest.raises(InputError, match="no time steps"):
        as_series(path, gathered, [])
