"""Matrix-vector products in the time loops: K and M in block CSR (gdim x gdim blocks) with
ghost columns in DOLFINx's local numbering, multiplied by a small C loop compiled on this
machine with -O3 -march=native (through cffi, as FFCx compiles the forms).

Why: the PETSc in the DOLFINx wheel is built for a generic x86-64 (-O2), and its MatMult runs
at 3 to 5 GB/s here; this loop reads the same bytes at 7 to 8 GB/s, close to the machine's
read bandwidth (`tissuebench bench`). The explicit-lumped step fuses its whole update into the
same loop, the next step's predictor included, so that one pass over K and the vectors does the
whole step (solvers/explicit_lumped.py).

Products are exact to round-off against PETSc's MatMult (tests/test_system.py); under MPI
the ghost values of x come from DOLFINx's scatter, as in DOLFINx's own MatrixCSR.mult.
"""

from __future__ import annotations

import errno
import hashlib
import importlib.util
import math
import os
import platform
import re
import shutil
import struct
import sys
import tempfile
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from mpi4py import MPI
    from petsc4py import PETSc

    import dolfinx.la

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
/* one explicit-lumped step, row by row with K u (u: this step's ubar, ghosts included):   \
   vt = v + gv a (v's predictor), a = inv_s (f - K u - alpha_ml vt), v = vt + gh a, and   \
   the next step's predictor u_next = u + (h v + hh a), each vector read and written once */\
void explicit_lumped##BS(int32_t nbr, const int32_t* restrict ai,                          \
                         const int32_t* restrict aj, const double* restrict K,             \
                         const double* restrict u, const double* restrict f,               \
                         const double* restrict inv_s, const double* restrict alpha_ml,    \
                         double* restrict v, double* restrict a, double* restrict u_next,  \
                         double gv, double gh, double h, double hh)                        \
{                                                                                          \
  for (int32_t r = 0; r < nbr; ++r) {                                                      \
    double s[BS];                                                                          \
    row##BS(r, ai, aj, K, u, s);                                                           \
    for (int i = 0; i < BS; ++i) {                                                         \
      const int64_t d = (int64_t)r * BS + i;                                               \
      const double vt = v[d] + gv * a[d];                                                  \
      const double an = inv_s[d] * ((f[d] - s[i]) - alpha_ml[d] * vt);                     \
      const double vn = vt + gh * an;                                                      \
      a[d] = an;                                                                           \
      v[d] = vn;                                                                           \
      u_next[d] = u[d] + (h * vn + hh * an);                                               \
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
            "const double*, const double*, const double*, const double*, double*, double*, "
            "double*, double, double, double, double);"
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


FREE_BYTES = 16 << 20  # a compilation that fails with less free in the cache: the disk is full


def _say(line: str) -> None:
    print(f"tissuebench: {line}", file=sys.stderr, flush=True)


def _file_hash(path: Path) -> str:
    """The SHA-256 of a file's bytes, as hex."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _elf_header(data: bytes) -> tuple[bytes, int] | None:
    """(class, byte order and machine: the bytes an architecture is told by; e_type) of an ELF
    file's first bytes, or None if they are not an ELF header."""
    if len(data) < 20 or data[:4] != b"\x7fELF" or data[4] not in (1, 2) or data[5] not in (1, 2):
        return None
    order = "<" if data[5] == 1 else ">"
    (kind,) = struct.unpack_from(order + "H", data, 16)
    return data[4:6] + data[18:20], kind


def _own_architecture() -> bytes | None:
    """The ELF class, byte order and machine of this process's interpreter (None where it
    cannot be read: then any architecture is taken, and dlopen decides)."""
    for exe in ("/proc/self/exe", sys.executable):
        try:
            with open(exe, "rb") as f:
                header = _elf_header(f.read(64))
        except OSError:
            continue
        if header is not None:
            return header[0]
    return None


def _elf_extent(data: bytes) -> int:
    """The bytes an ELF file's headers say it holds: the end of its program and section header
    tables and of every segment's bytes in the file (a file shorter than that was cut short)."""
    order = "<" if data[5] == 1 else ">"
    wide = data[4] == 2  # 64-bit: wider offsets, another layout
    phoff, shoff = struct.unpack_from(order + ("QQ" if wide else "II"), data, 32 if wide else 28)
    sizes = struct.unpack_from(order + "HHHH", data, 54 if wide else 42)
    phentsize, phnum, shentsize, shnum = sizes
    end = max(phoff + phentsize * phnum, shoff + shentsize * shnum)
    # p_offset and p_filesz: at 8 and 32 in a 64-bit program header, at 4 and 16 in a 32-bit one
    word = order + ("Q" if wide else "I")
    at_offset, at_filesz = (8, 32) if wide else (4, 16)
    for k in range(phnum):
        at = phoff + k * phentsize
        if at + phentsize > len(data):
            break  # the table itself is cut short: end says so
        (start,) = struct.unpack_from(word, data, at + at_offset)
        (size,) = struct.unpack_from(word, data, at + at_filesz)
        end = max(end, start + size)
    return end


def library_problem(path: Path, digest: str) -> str | None:
    """What makes a cached shared library unfit to load (dlopen maps it: one cut short would
    end the process with SIGBUS where its missing pages are read), or None: empty, not ELF,
    not a shared library, of another architecture, shorter than its headers say, or bytes
    other than the SHA-256 `digest` (hex) it was built with."""
    try:
        data = path.read_bytes()
    except OSError as err:
        return f"cannot be read ({err.strerror or err})"
    if not data:
        return "empty"
    header = _elf_header(data[:64])
    if header is None or len(data) < 64:
        return "not a shared library (no ELF header)"
    own = _own_architecture()
    if own is not None and header[0] != own:
        return "built for another architecture"
    if header[1] != 3:  # ET_DYN
        return f"not a shared library (ELF type {header[1]})"
    extent = _elf_extent(data)
    if len(data) < extent:
        return f"cut short ({len(data)} bytes, its headers say {extent})"
    if hashlib.sha256(data).hexdigest() != digest:
        return "its bytes are not those it was built with (SHA-256)"
    return None


def _cached(folder: Path, name: str) -> Path | None:
    """The first fit library of this name in the cache (`NAME.SHA256.so`, its bytes' hash in
    its name); each unfit one is said in one line and removed."""
    pattern = re.compile(re.escape(name) + r"\.(?P<digest>[0-9a-f]{64})\.so")
    for path in sorted(folder.glob(name + ".*.so")) if folder.is_dir() else []:
        m = pattern.fullmatch(path.name)
        if m is None:
            continue
        problem = library_problem(path, m["digest"])
        if problem is None:
            return path
        _say(f"{path}: {problem}; compiling it again")
        path.unlink(missing_ok=True)
    return None


def _no_space(folder: Path) -> OSError:
    """The one-line error of a full cache disk (cli.fault says FOLDER: no space left on the
    device), raised outside any handler so that no other error rides along as its context."""
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(folder))


def _free_bytes(folder: Path) -> float:
    """Bytes free for us in the folder (or its nearest existing parent); inf if unknown."""
    for place in [folder, *folder.parents]:
        if place.exists():
            try:
                return shutil.disk_usage(place).free
            except OSError:
                return math.inf
    return math.inf


def _build(folder: Path, name: str, source: str, declarations: str, flags: list[str]) -> Path:
    """Compile the module into the cache as NAME.SHA256.so (put in place atomically: other
    processes see all or nothing). A full disk is an OSError ENOSPC naming the folder, also
    where the compiler failed for want of space."""
    import cffi

    full = False
    try:
        folder.mkdir(parents=True, exist_ok=True)
        ffi = cffi.FFI()
        ffi.cdef(declarations)
        ffi.set_source(name, source, extra_compile_args=flags)
        with tempfile.TemporaryDirectory(dir=folder) as tmp:
            built = Path(ffi.compile(tmpdir=tmp))
            path = folder / f"{name}.{_file_hash(built)}.so"
            os.replace(built, path)
        return path
    except OSError as err:
        if err.errno != errno.ENOSPC:
            raise
        full = True
    except Exception:
        if _free_bytes(folder) >= FREE_BYTES:
            raise
        full = True  # the compiler could not write its output
    assert full
    raise _no_space(folder)


def _imported(name: str, path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # a file's spec, with its loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def compile_module(
    prefix: str,
    source: str,
    declarations: str,
    comm: MPI.Comm | None = None,
    flags: list[str] | None = None,
) -> ModuleType:
    """A cffi module (.ffi, .lib) of C `source` with the prototypes `declarations`, compiled
    with FLAGS (and `flags`) on first use and kept in cache_dir() under `prefix` and a hash of
    the source, the flags and the CPU (so that an edited source or another CPU compiles anew),
    as PREFIX_KEY.SHA256.so with the SHA-256 of its bytes. A cached file is checked before it
    is loaded (library_problem: empty, cut short, garbage, another architecture, other bytes),
    and one that is unfit or fails to load is said in one line and compiled again, once. The
    one cache of the compiled kernels: solvers/blockcsr.py, solvers/compiled_forces.py and
    metrics/kernels.py. Under MPI, rank 0 of `comm` compiles and the others wait."""
    flags = FLAGS + (flags or [])
    key = source + declarations + " ".join(flags) + _cpu_key()
    name = f"{prefix}_{hashlib.sha256(key.encode()).hexdigest()[:16]}"
    folder = cache_dir()
    module = path = error = None
    if comm is None or comm.rank == 0:
        try:
            path = _cached(folder, name)
            if path is not None:
                try:
                    module = _imported(name, path)
                except ImportError as err:
                    _say(f"{path}: does not load ({err}); compiling it again")
                    path.unlink(missing_ok=True)
                    path = None
            if path is None:
                path = _build(folder, name, source, declarations, flags)
                module = _imported(name, path)
        except Exception as err:
            error = err
    if comm is not None and comm.size > 1:
        path, error = comm.bcast((path, error), root=0)
    if error is not None:
        raise error
    assert path is not None
    return module if module is not None else _imported(name, path)


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

    def vector(self) -> dolfinx.la.Vector:
        """A new vector over this matrix's columns: the owned dofs (as in a PETSc Vec over the
        owned dofs), then the ghost dofs that the owned rows reach."""
        import dolfinx.la

        return dolfinx.la.vector(self._x.index_map, self.bs)

    def explicit_lumped(
        self,
        u: dolfinx.la.Vector,
        f: PETSc.Vec,
        inv_s: PETSc.Vec,
        alpha_ml: PETSc.Vec,
        v: PETSc.Vec,
        a: PETSc.Vec,
        u_next: np.ndarray,
        gamma: float,
        h: float,
    ) -> None:
        """One explicit-lumped step with A = K, in one pass over K and the vectors (all owned
        dofs; u a vector of self.vector() with its owned values set, its ghosts scattered here):
        v = v + (1 - gamma) h a, a = inv_s (f - K u - alpha_ml v), v += gamma h a, then the next
        step's predictor u_next = u + h v + h^2/2 a (owned dofs, another array than u's). Units:
        u in m, f in N, inv_s in 1/kg, alpha_ml in kg/s, v in m/s, a in m/s^2, h in s."""
        ptr = self.lib.ffi.from_buffer
        u.scatter_forward()
        self._step(
            *self._args,
            ptr("double[]", u.array),
            ptr("double[]", f.array_r),
            ptr("double[]", inv_s.array_r),
            ptr("double[]", alpha_ml.array_r),
            ptr("double[]", v.array),
            ptr("double[]", a.array),
            ptr("double[]", u_next),
            (1 - gamma) * h,
            gamma * h,
            h,
            h * h / 2,
        )
