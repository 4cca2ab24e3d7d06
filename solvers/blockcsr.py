"""Matrix-vector products in the time loops: K and M in block CSR (gdim x gdim blocks) with
ghost columns in DOLFINx's local numbering, multiplied by a small C loop compiled on this
machine with -O3 -march=native (through cffi, as FFCx compiles the forms).

Why: the PETSc in the DOLFINx wheel is built for a generic x86-64 (-O2), and its MatMult runs
at 3 to 5 GB/s here; this loop reads the same bytes at 7 to 8 GB/s, close to the machine's
read bandwidth (`tissuebench bench`). The explicit-lumped step fuses its update into the same
loop, so that one pass over K does the whole step.

Products are exact to round-off against PETSc's MatMult (tests/test_system.py); under MPI
the ghost values of x come from DOLFINx's scatter, as in DOLFINx's own MatrixCSR.mult.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import platform
import tempfile
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

SOURCE = r"""
#include <stdint.h>
#define KERNELS(BS)                                                                        \
/* s = row r of A x: block row r has blocks ai[r]..ai[r+1]-1 */                            \
static inline void row##BS(int32_t r, const int32_t* restrict ai,                         \
                           const int32_t* restrict aj, const double* restrict A,           \
                           const double* restrict x, double* restrict s)                   \
{                                                                                          \
  for (int i = 0; i < BS; ++i) s[i] = 0.0;                                                 \
  for (int32_t k = ai[r]; k < ai[r + 1]; ++k) {                                            \
    const double* restrict b = A + (int64_t)k * BS * BS;                                   \
    const double* restrict xc = x + (int64_t)aj[k] * BS;                                   \
    for (int i = 0; i < BS; ++i)                                                           \
      for (int j = 0; j < BS; ++j)                                                         \
        s[i] += b[i * BS + j] * xc[j];                                                     \
  }                                                                                        \
}                                                                                          \
/* y = A x (+ y if add) over nbr block rows */                                             \
void mult##BS(int32_t nbr, const int32_t* restrict ai, const int32_t* restrict aj,        \
              const double* restrict A, const double* restrict x, double* restrict y,      \
              int32_t add)                                                                 \
{                                                                                          \
  for (int32_t r = 0; r < nbr; ++r) {                                                      \
    double s[BS];                                                                          \
    row##BS(r, ai, aj, A, x, s);                                                           \
    for (int i = 0; i < BS; ++i)                                                           \
      y[r * BS + i] = add ? y[r * BS + i] + s[i] : s[i];                                   \
  }                                                                                        \
}                                                                                          \
/* the explicit-lumped update, row by row with K u:                                        \
   a = inv_s (f - K u - alpha_ml v),  v += gh a */                                         \
void explicit_lumped##BS(int32_t nbr, const int32_t* restrict ai,                          \
                         const int32_t* restrict aj, const double* restrict K,             \
                         const double* restrict u, const double* restrict f,               \
                         const double* restrict inv_s, const double* restrict alpha_ml,    \
                         double* restrict v, double* restrict a, double gh)                \
{                                                                                          \
  for (int32_t r = 0; r < nbr; ++r) {                                                      \
    double s[BS];                                                                          \
    row##BS(r, ai, aj, K, u, s);                                                           \
    for (int i = 0; i < BS; ++i) {                                                         \
      const int64_t d = (int64_t)r * BS + i;                                               \
      a[d] = inv_s[d] * ((f[d] - s[i]) - alpha_ml[d] * v[d]);                              \
      v[d] += gh * a[d];                                                                   \
    }                                                                                      \
  }                                                                                        \
}
KERNELS(1)
KERNELS(2)
KERNELS(3)
"""

FLAGS = ["-O3", "-march=native"]
_lib = None


def _declarations():
    lines = []
    for bs in (1, 2, 3):
        lines.append(
            f"void mult{bs}(int32_t, const int32_t*, const int32_t*, const double*, "
            "const double*, double*, int32_t);"
        )
        lines.append(
            f"void explicit_lumped{bs}(int32_t, const int32_t*, const int32_t*, const double*, "
            "const double*, const double*, const double*, const double*, double*, double*, double);"
        )
    return "\n".join(lines)


def cache_dir() -> Path:
    """Where compiled kernels are kept: $TISSUEBENCH_CACHE or ~/.cache/tissuebench."""
    return Path(os.environ.get("TISSUEBENCH_CACHE", Path.home() / ".cache" / "tissuebench"))


def _cpu_key():
    """The CPU's model and flags: -march=native code is only reused on the same kind of CPU."""
    try:
        with open("/proc/cpuinfo") as f:
            return "".join(line for line in f if line.startswith(("model name", "flags")))[:4000]
    except OSError:
        return platform.processor()


def compile_module(
    prefix: str,
    source: str,
    declarations: str,
    comm: MPI.Comm | None = None,
    flags: list[str] | None = None,
) -> ModuleType:
    """A cffi module (.ffi, .lib) of C `source` with the prototypes `declarations`, compiled
    with FLAGS (and `flags`) on first use and kept in cache_dir() under `prefix` and a hash of
    the source, the flags and the CPU (so that an edited source or another CPU compiles anew).
    Under MPI, rank 0 of `comm` compiles and the others wait."""
    import cffi

    flags = FLAGS + (flags or [])
    key = source + declarations + " ".join(flags) + _cpu_key()
    name = f"{prefix}_{hashlib.sha256(key.encode()).hexdigest()[:16]}"
    folder = cache_dir()
    found = sorted(folder.glob(name + ".*so")) if folder.exists() else []
    if not found and (comm is None or comm.rank == 0):
        folder.mkdir(parents=True, exist_ok=True)
        ffi = cffi.FFI()
        ffi.cdef(declarations)
        ffi.set_source(name, source, extra_compile_args=flags)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:
            built = Path(ffi.compile(tmpdir=tmp))
            os.replace(built, folder / built.name)  # atomic: other processes see all or nothing
    if comm is not None:
        comm.Barrier()
    found = sorted(folder.glob(name + ".*so"))
    spec = importlib.util.spec_from_file_location(name, found[0])
    assert spec is not None and spec.loader is not None  # a file's spec, with its loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def load(comm: MPI.Comm | None = None) -> ModuleType:
    """The compiled kernels (a cffi module: .ffi, .lib), compiled on first use. Under MPI, rank
    0 of `comm` compiles and the others wait."""
    global _lib
    if _lib is None:
        _lib = compile_module("_tissuebench_kernels", SOURCE, _declarations(), comm)
    return _lib


class BlockCSR:
    """A PETSc matrix (AIJ or BAIJ, serial or MPI) copied into block CSR over this rank's
    owned block rows, with local block columns: V's owned nodes, then every other node the
    rows reach (_column_map). `mult(x, y)` takes PETSc Vecs over the owned dofs, as the
    solvers use them."""

    def __init__(self, A, V):
        from petsc4py import PETSc

        import dolfinx.la

        bs = V.dofmap.index_map_bs
        self.bs, self.nbr = bs, V.dofmap.index_map.size_local
        aij = A.convert("aij", PETSc.Mat()) if "baij" in A.getType() else A
        ai, aj, av = aij.getValuesCSR()
        if aij is not A:
            aij.destroy()
        row = np.repeat(np.arange(len(ai) - 1), np.diff(ai))
        position = np.arange(len(aj)) - ai[row]  # place of each entry in its row
        width = np.diff(ai)[::bs]  # entries per row, the same for the bs rows of a block row
        if not (np.diff(ai).reshape(-1, bs) == width[:, None]).all() or (width % bs).any():
            raise ValueError("matrix is not made of full bs x bs blocks")
        block_start = np.concatenate([[0], np.cumsum(width // bs)])
        block = block_start[row // bs] + position // bs
        i, j = row % bs, position % bs
        if ((aj % bs) != j).any():
            raise ValueError("matrix columns are not grouped in bs x bs blocks")
        self.ai = block_start.astype(np.int32)
        self.A = np.zeros((block_start[-1], bs, bs))
        self.A[block, i, j] = av
        first = (i == 0) & (j == 0)
        column_map, self.aj = self._column_map(
            aj[first] // bs, V.dofmap.index_map, A.getComm().tompi4py()
        )
        self._x = dolfinx.la.vector(column_map, bs)  # owned and ghost values of x
        self.nbytes = self.A.nbytes + self.aj.nbytes + self.ai.nbytes  # read by one product
        self.lib = load(V.mesh.comm)
        self._mult = getattr(self.lib.lib, f"mult{bs}")
        self._step = getattr(self.lib.lib, f"explicit_lumped{bs}")
        ptr = self.lib.ffi.from_buffer
        self._args = (
            self.nbr,
            ptr("int32_t[]", self.ai),
            ptr("int32_t[]", self.aj),
            ptr("double[]", self.A),
        )
        self._xp = ptr("double[]", self._x.array)

    @staticmethod
    def _column_map(columns, index_map, comm):
        """(an IndexMap, local block columns): the owned nodes of `index_map`, then as ghosts
        every other node that the owned rows reach (more than the mesh's ghosts: a row also
        gets columns from other ranks' cells)."""
        from dolfinx.common import IndexMap

        first, last = index_map.local_range
        outside = (columns < first) | (columns >= last)
        ghosts = np.unique(columns[outside])
        starts = np.array(comm.allgather(first))
        owners = (np.searchsorted(starts, ghosts, side="right") - 1).astype(np.int32)
        tag = 5219  # any MPI tag: it only labels the messages that build the map
        column_map = IndexMap(comm, index_map.size_local, ghosts.astype(np.int64), owners, tag)
        local = columns - first
        local[outside] = index_map.size_local + np.searchsorted(ghosts, columns[outside])
        return column_map, local.astype(np.int32)

    def _ghosted(self, x):
        """x (a PETSc Vec over the owned dofs) with its ghost values, as a cffi pointer."""
        self._x.array[: self.nbr * self.bs] = x.array_r
        self._x.scatter_forward()
        return self._xp

    def mult(self, x: PETSc.Vec, y: PETSc.Vec, add: bool = False) -> None:
        """y = A x, or y += A x if add."""
        xp = self._ghosted(x)
        self._mult(*self._args, xp, self.lib.ffi.from_buffer("double[]", y.array), int(add))

    def explicit_lumped(
        self,
        u: PETSc.Vec,
        f: PETSc.Vec,
        inv_s: PETSc.Vec,
        alpha_ml: PETSc.Vec,
        v: PETSc.Vec,
        a: PETSc.Vec,
        gh: float,
    ) -> None:
        """With A = K: a = inv_s (f - K u - alpha_ml v), then v += gh a (all owned dofs)."""
        ptr = self.lib.ffi.from_buffer
        self._step(
            *self._args,
            self._ghosted(u),
            ptr("double[]", f.array_r),
            ptr("double[]", inv_s.array_r),
            ptr("double[]", alpha_ml.array_r),
            ptr("double[]", v.array),
            ptr("double[]", a.array),
            gh,
        )
