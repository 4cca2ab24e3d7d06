"""The loop of E_i against the truth (metrics/truth.py), in C compiled on this machine (cffi,
solvers/blockcsr.compile_module: -O3 -march=native, cached by its hash in ~/.cache/tissuebench
or $TISSUEBENCH_CACHE).

For each step s: Σ_p w_p ‖Σ_k φ_pk u_s[c_pk] − u_q[s, p]‖ over the truth's quadrature points
p, with the candidate's nodal displacement u_s interpolated at p from the nodes c_pk of its
cell (weights φ_pk, crossmesh.PointValues). One pass over the truth's values, which are most
of the bytes: in numpy the interpolated values and their differences were arrays as large as
the truth's, made and read again, several times slower. The sum over p is compensated (Kahan),
so that it is the exact sum to about one rounding whatever the number of points.
"""

from __future__ import annotations

import numpy as np

SOURCE = r"""
#include <math.h>
#include <stdint.h>
void interior_norms(int64_t steps, int64_t n, int64_t k, int64_t d, int64_t nodes,
                    const int64_t* restrict cells, const double* restrict phi,
                    const double* restrict u, const double* restrict uq,
                    const double* restrict w, double* restrict out)
{
  for (int64_t s = 0; s < steps; ++s) {
    const double* restrict us = u + s * nodes * d;
    const double* restrict qs = uq + s * n * d;
    double sum = 0.0, carry = 0.0;
    for (int64_t p = 0; p < n; ++p) {
      double v[3] = {0.0, 0.0, 0.0};
      for (int64_t j = 0; j < k; ++j) {
        const double f = phi[p * k + j];
        const double* restrict x = us + cells[p * k + j] * d;
        for (int64_t c = 0; c < d; ++c) v[c] += f * x[c];
      }
      double sq = 0.0;
      for (int64_t c = 0; c < d; ++c) {
        const double e = v[c] - qs[p * d + c];
        sq += e * e;
      }
      const double y = w[p] * sqrt(sq) - carry;
      const double t = sum + y;
      carry = (t - sum) - y;
      sum = t;
    }
    out[s] = sum;
  }
}
"""
DECLARATIONS = (
    "void interior_norms(int64_t, int64_t, int64_t, int64_t, int64_t, const int64_t*, "
    "const double*, const double*, const double*, const double*, double*);"
)
_lib = None


def load():
    """The compiled module (.ffi, .lib), compiled on first use (each process on its own: the
    compiled file is put in place atomically)."""
    global _lib
    if _lib is None:
        from tissuebench.solvers.blockcsr import compile_module

        _lib = compile_module("_tissuebench_truth_grading", SOURCE, DECLARATIONS)
    return _lib


def interior_norms(
    cells: np.ndarray, phi: np.ndarray, u: np.ndarray, uq: np.ndarray, w: np.ndarray
) -> np.ndarray:
    """(steps,) Σ_p w_p ‖Σ_k phi[p, k] u[s, cells[p, k]] − uq[s, p]‖ for cells (n, k) node
    indices, phi (n, k), the candidate's u (steps, N′, d), the truth's uq (steps, n, d) and
    weights w (n,); d at most 3."""
    mod = load()
    ffi = mod.ffi
    cells = np.ascontiguousarray(cells, dtype=np.int64)
    phi = np.ascontiguousarray(phi, dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    uq = np.ascontiguousarray(uq, dtype=np.float64)
    w = np.ascontiguousarray(w, dtype=np.float64)
    steps, n, d = uq.shape
    k = cells.shape[1]
    if not (d <= 3 and u.shape[0] == steps and u.shape[2] == d and cells.shape == (n, k)):
        raise ValueError(f"interior_norms: shapes {cells.shape}, {u.shape}, {uq.shape}")
    if len(cells) and (cells.min() < 0 or cells.max() >= u.shape[1]):
        raise ValueError("interior_norms: a node index outside the candidate's nodes")
    out = np.empty(steps)
    if steps == 0 or n == 0:
        out[:] = 0.0
        return out

    def ptr(kind, a):
        return ffi.from_buffer(kind, a)

    mod.lib.interior_norms(
        steps, n, k, d, u.shape[1],
        ptr("int64_t[]", cells), ptr("double[]", phi), ptr("double[]", u),
        ptr("double[]", uq), ptr("double[]", w), ptr("double[]", out),
    )  # fmt: skip
    return out
