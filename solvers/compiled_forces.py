"""The internal force f_int(u) = ∫ P(F) : ∇w dX of a nonlinear elastic model (SPEC section 8),
and the smallest J = det F at the quadrature points, in one compiled element loop per step: the
explicit schemes' force, as solvers/blockcsr.py is their linear step's product.

For P1/Q1 vector elements on triangles, quadrilaterals, tetrahedra and hexahedra, with the
quadrature of the UFL form (solvers/elastic.py: QUADRATURE_DEGREE, basix's points and
weights). Once, at construction: per owned cell and quadrature point, the inverse Jacobian
J_e^-1 of the reference map and the weight times |det J_e| (so that the loop reads D^2 + 1
doubles per point and no coordinates), and for a rotated model J_e^-1 at the cell centre.
Per step, for each owned cell: gather its nodal u, form grad_ref u at every point, F = I +
grad_ref u J_e^-1, det F, P(F) by the model's C stress (Model.c_stress), and scatter
(w |det J_e|) P J_e^-T : grad_ref N into f; then the ghost nodes' sums go to their owners (the
reverse scatter add, as DOLFINx's assemble_vector and ghostUpdate do). F-bar (SPEC 11's
mean-dilatation with a nonlinear model) takes each cell's mean J in a first pass over its
points, then P = s P(s F), s = (J_bar / J)^(1/D). A rotated model (corotational) takes R of the
polar decomposition of F at the cell centre by the Newton iteration of
solvers/elastic.py (`_polar_newton`, the same stopping rule); a cell where it fails (det F <= 0
or no convergence) gets its R from solvers/elastic.rotations (the SVD) in Python, and a second
pass over those cells only.

The reference tables (the gradients of the shape functions at the points) are constants in the
C source, which is compiled per (cell, model, F-bar) with -O3 -march=native through cffi and
cached by its hash (blockcsr.compile_module). Units: u in m, f in N, mu and lmbda in Pa.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import basix
import numpy as np

from tissuebench.solvers import elastic
from tissuebench.solvers.blockcsr import compile_module

if TYPE_CHECKING:
    from mpi4py import MPI

    from dolfinx import fem

    from tissuebench.solvers.models.model import Model

CELLS = ("triangle", "quadrilateral", "tetrahedron", "hexahedron")

PREAMBLE = r"""
#include <math.h>
#include <stdint.h>
#include <stddef.h>

static inline void cofactor(const double* restrict F, double* restrict C)
{
#if D == 2
  C[0] = F[3]; C[1] = -F[2]; C[2] = -F[1]; C[3] = F[0];
#else
  for (int i = 0; i < 3; ++i) {
    const int i1 = (i + 1) % 3, i2 = (i + 2) % 3;
    for (int j = 0; j < 3; ++j) {
      const int j1 = (j + 1) % 3, j2 = (j + 2) % 3;
      C[i * 3 + j] = F[i1 * 3 + j1] * F[i2 * 3 + j2] - F[i1 * 3 + j2] * F[i2 * 3 + j1];
    }
  }
#endif
}

static inline double determinant(const double* restrict F)
{
#if D == 2
  return F[0] * F[3] - F[1] * F[2];
#else
  return F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6])
         + F[2] * (F[3] * F[7] - F[4] * F[6]);
#endif
}

static inline void stress(const double* restrict F, double J, const double* restrict R,
                          double mu, double lmbda, double* restrict P)
{
STRESS_BODY
}
"""

KERNEL = r"""
#define GS (D * D + 1) /* doubles per point: J_e^-1, then w |det J_e| */

/* F = I + H Jinv with H = sum_a u_a (x) dN_a (the reference gradient of u) */
static inline void deformation(const double ue[NN][D], const double dN[NN][D],
                               const double* restrict Jinv, double* restrict F)
{
  double H[D][D] = {{0.0}};
  for (int a = 0; a < NN; ++a)
    for (int i = 0; i < D; ++i)
      for (int k = 0; k < D; ++k) H[i][k] += ue[a][i] * dN[a][k];
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j) {
      double s = (i == j);
      for (int k = 0; k < D; ++k) s += H[i][k] * Jinv[k * D + j];
      F[i * D + j] = s;
    }
}

/* fe_a += Q dN_a with Q = scale P Jinv^T */
static inline void scatter(const double* restrict P, double scale, const double dN[NN][D],
                           const double* restrict Jinv, double fe[NN][D])
{
  double Q[D][D];
  for (int i = 0; i < D; ++i)
    for (int k = 0; k < D; ++k) {
      double s = 0.0;
      for (int j = 0; j < D; ++j) s += P[i * D + j] * Jinv[k * D + j];
      Q[i][k] = scale * s;
    }
  for (int a = 0; a < NN; ++a)
    for (int i = 0; i < D; ++i) {
      double s = 0.0;
      for (int k = 0; k < D; ++k) s += Q[i][k] * dN[a][k];
      fe[a][i] += s;
    }
}

#if ROTATED
/* R of F = R U by X <- (g X + X^-T / g) / 2, g = det(X)^(-1/D), from X = F, until no entry
   changes by more than POLAR_STOP (solvers/elastic.py _polar_newton); 0 if it fails */
static int polar(const double* restrict F, double* restrict R)
{
  double X[D * D], C[D * D];
  for (int k = 0; k < D * D; ++k) X[k] = F[k];
  cofactor(X, C);
  double det = determinant(X);
  if (!(det > 0.0) || !isfinite(det)) return 0;
  for (int it = 0; it < POLAR_MAX; ++it) {
    double scale = pow(det, -1.0 / D);
    const double work = 0.5 / (scale * det);
    scale *= 0.5;
    double change = 0.0;
    for (int k = 0; k < D * D; ++k) {
      const double y = X[k] * scale + C[k] * work;
      const double d = fabs(X[k] - y);
      change = d > change || isnan(d) ? d : change;
      X[k] = y;
    }
    if (change <= POLAR_STOP) {
      for (int k = 0; k < D * D; ++k) R[k] = X[k];
      return 1;
    }
    if (!isfinite(change)) return 0;
    cofactor(X, C);
    det = determinant(X);
  }
  return 0;
}
#endif

/* f += f_int of the cells (cells[0..n-1], or 0..n-1 if cells is NULL); returns the number
   of cells whose R failed (rotated models: their index in failed[], F at their centre in
   R[cell], and no force), and sets *min_det (and *nonfinite if some det F is not finite).
   With given_R, R[cell] is taken as it is. */
int32_t forces(int32_t n, const int32_t* restrict cells, const int32_t* restrict dofs,
               const double* restrict geo, const double* restrict centre,
               const double* restrict u, double* restrict f, double mu, double lmbda,
               double* restrict R, int32_t given_R, int32_t* restrict failed,
               double* restrict min_det, int32_t* restrict nonfinite)
{
  int32_t nfailed = 0, bad = 0;
  double smallest = INFINITY;
  for (int32_t m = 0; m < n; ++m) {
    const int32_t c = cells ? cells[m] : m;
    const int32_t* restrict cd = dofs + (int64_t)c * NN;
    const double* restrict g = geo + (int64_t)c * NQ * GS;
    double ue[NN][D], fe[NN][D];
    for (int a = 0; a < NN; ++a)
      for (int i = 0; i < D; ++i) {
        ue[a][i] = u[(int64_t)cd[a] * D + i];
        fe[a][i] = 0.0;
      }
    const double* Rc = NULL;
#if ROTATED
    double* Rcell = R + (int64_t)c * D * D;
    if (!given_R) {
      double Fc[D * D];
      deformation(ue, DNC, centre + (int64_t)c * D * D, Fc);
      if (!polar(Fc, Rcell)) {
        for (int k = 0; k < D * D; ++k) Rcell[k] = Fc[k];
        failed[nfailed++] = c;
        continue;
      }
    }
    Rc = Rcell;
#endif
    double F[NQ][D * D], J[NQ];
    for (int q = 0; q < NQ; ++q) {
      deformation(ue, DN[q], g + q * GS, F[q]);
      J[q] = determinant(F[q]);
      if (!isfinite(J[q])) bad = 1;
      else if (J[q] < smallest) smallest = J[q];
    }
#if FBAR
    double volume = 0.0, integral = 0.0;
    for (int q = 0; q < NQ; ++q) {
      volume += g[q * GS + D * D];
      integral += g[q * GS + D * D] * J[q];
    }
    const double Jbar = integral / volume;
#endif
    for (int q = 0; q < NQ; ++q) {
      double P[D * D];
#if FBAR
      const double ratio = Jbar / J[q];
#if D == 2
      const double s = sqrt(ratio);
#else
      const double s = cbrt(ratio);
#endif
      double Fb[D * D];
      for (int k = 0; k < D * D; ++k) Fb[k] = s * F[q][k];
      stress(Fb, determinant(Fb), Rc, mu, lmbda, P);
      scatter(P, s * g[q * GS + D * D], DN[q], g + q * GS, fe);
#else
      stress(F[q], J[q], Rc, mu, lmbda, P);
      scatter(P, g[q * GS + D * D], DN[q], g + q * GS, fe);
#endif
    }
    for (int a = 0; a < NN; ++a)
      for (int i = 0; i < D; ++i) f[(int64_t)cd[a] * D + i] += fe[a][i];
  }
  *min_det = smallest;
  *nonfinite = bad;
  return nfailed;
}

/* the explicit-lumped step's update (solvers/nonlinear.py ExplicitLumpedModel) over the
   owned dofs: a = inv_s (f - fint - alpha_ml v), v += gh a */
void explicit_update(int64_t n, const double* restrict f, const double* restrict fint,
                     const double* restrict inv_s, const double* restrict alpha_ml,
                     double* restrict v, double* restrict a, double gh)
{
  for (int64_t d = 0; d < n; ++d) {
    a[d] = inv_s[d] * ((f[d] - fint[d]) - alpha_ml[d] * v[d]);
    v[d] += gh * a[d];
  }
}
"""

DECLARATIONS = """
int32_t forces(int32_t, const int32_t*, const int32_t*, const double*, const double*,
               const double*, double*, double, double, double*, int32_t, int32_t*, double*,
               int32_t*);
void explicit_update(int64_t, const double*, const double*, const double*, const double*,
                     double*, double*, double);
"""


def _c_array(name: str, values: np.ndarray) -> str:
    """A C constant array definition with the values to full precision (repr)."""

    def braced(x: np.ndarray) -> str:
        if x.ndim == 1:
            return "{" + ", ".join(repr(float(v)) for v in x) + "}"
        return "{" + ", ".join(braced(y) for y in x) + "}"

    dims = "".join(f"[{n}]" for n in values.shape)
    return f"static const double {name}{dims} __attribute__((unused)) = {braced(values)};\n"


def available(model: Model, cell: str) -> bool:
    """Whether the compiled loop serves `model` on cells of this name (its C stress, P1/Q1)."""
    return bool(model.c_stress) and cell in CELLS


def source(model: Model, cell: str, gdim: int, fbar: bool) -> str:
    """The C source of the loop for `model` on `cell` in gdim dimensions (F-bar if fbar)."""
    cell_type = getattr(basix.CellType, cell)
    points, _ = basix.make_quadrature(cell_type, elastic.QUADRATURE_DEGREE)
    element = basix.create_element(basix.ElementFamily.P, cell_type, 1)
    tdim = points.shape[1]
    if tdim != gdim:
        raise ValueError(f"{cell} cells in {gdim} dimensions: only tdim = gdim is compiled")
    dN = element.tabulate(1, points)[1 : 1 + tdim, :, :, 0].transpose(1, 2, 0)  # (q, a, k)
    centre = basix.geometry(cell_type).mean(axis=0)[None, :]
    dNc = element.tabulate(1, centre)[1 : 1 + tdim, 0, :, 0].T  # (a, k)
    nq, nn = dN.shape[:2]
    head = (
        f"#define D {gdim}\n#define NN {nn}\n#define NQ {nq}\n"
        f"#define ROTATED {int(model.rotated)}\n#define FBAR {int(fbar)}\n"
        f"#define POLAR_STOP {elastic.POLAR_STOP!r}\n"
        f"#define POLAR_MAX {elastic.POLAR_MAX_ITERATIONS}\n"
    )
    tables = _c_array("DN", dN) + _c_array("DNC", dNc)
    return head + PREAMBLE.replace("STRESS_BODY", model.c_stress) + tables + KERNEL


class CompiledForces:
    """f_int(u) and the smallest det F of `model` on the vector P1/Q1 space V (block size gdim),
    Lamé constants mu and lmbda (Pa), by the compiled element loop; F-bar if `fbar`.

    `evaluate(u)` takes the owned dof values of u (m) and returns f_int (N) on the owned dofs
    (a view of an internal array, valid until the next call); `min_det` is then the smallest
    det F at a quadrature point of this rank's cells (-inf if one is not finite)."""

    def __init__(self, V: fem.FunctionSpace, model: Model, mu: float, lmbda: float, fbar: bool):
        import dolfinx.la

        mesh = V.mesh
        cell = mesh.topology.cell_name()
        if not available(model, cell):
            raise ValueError(f"no compiled force for {model.name} on {cell} cells")
        if fbar and model.rotated:
            raise ValueError(f"mean-dilatation (F-bar) takes no rotated model, not {model.name}")
        self.gdim = gdim = mesh.geometry.dim
        self.comm: MPI.Comm = mesh.comm
        self.model, self.mu, self.lmbda = model, float(mu), float(lmbda)
        tdim = mesh.topology.dim
        n_cells = mesh.topology.index_map(tdim).size_local
        self.n_cells = n_cells
        self.dofs = np.ascontiguousarray(V.dofmap.list[:n_cells], dtype=np.int32)
        # the geometry of each owned cell: its nodes in the same local order as V's dofs
        # (both P1/Q1 on the same reference cell)
        x = mesh.geometry.x[:, :gdim]
        nodes = x[mesh.geometry.dofmap[:n_cells]]  # (cell, a, i)
        cell_type = getattr(basix.CellType, cell)
        points, weights = basix.make_quadrature(cell_type, elastic.QUADRATURE_DEGREE)
        element = basix.create_element(basix.ElementFamily.P, cell_type, 1)
        nq = len(weights)
        self.geo = np.empty((n_cells, nq, gdim * gdim + 1))
        for q in range(nq):
            dN = element.tabulate(1, points[q : q + 1])[1 : 1 + tdim, 0, :, 0]  # (k, a)
            Je = np.einsum("cai,ka->cik", nodes, dN)  # dx_i / dxi_k
            self.geo[:, q, : gdim * gdim] = np.linalg.inv(Je).reshape(n_cells, -1)
            self.geo[:, q, -1] = weights[q] * np.abs(np.linalg.det(Je))
        self.centre = np.zeros((n_cells, gdim, gdim))
        self.R = np.zeros((n_cells if model.rotated else 1, gdim, gdim))
        if model.rotated:
            centre = basix.geometry(cell_type).mean(axis=0)[None, :]
            dN = element.tabulate(1, centre)[1 : 1 + tdim, 0, :, 0]
            self.centre = np.linalg.inv(np.einsum("cai,ka->cik", nodes, dN))
        self._failed = np.zeros(max(n_cells, 1), dtype=np.int32)
        self._u = dolfinx.la.vector(V.dofmap.index_map, gdim)
        self._f = dolfinx.la.vector(V.dofmap.index_map, gdim)
        self.n_owned = V.dofmap.index_map.size_local * gdim
        self.module = compile_module(
            "_tissuebench_forces", source(model, cell, gdim, fbar), DECLARATIONS, mesh.comm
        )
        ffi = self.module.ffi
        self._min, self._bad = ffi.new("double*"), ffi.new("int32_t*")
        self._fp = ffi.from_buffer("double[]", self._f.array)
        self._args = (
            ffi.from_buffer("int32_t[]", self.dofs),
            ffi.from_buffer("double[]", self.geo),
            ffi.from_buffer("double[]", self.centre),
            ffi.from_buffer("double[]", self._u.array),
            self._fp,
            self.mu,
            self.lmbda,
            ffi.from_buffer("double[]", self.R),
        )
        self.min_det = np.inf
        self.u = self._u.array  # the last evaluation's u, owned and ghost dofs (m)
        self.fallbacks = 0  # evaluations in which some cell's R came from the Python path

    def evaluate(self, u: np.ndarray) -> np.ndarray:
        """f_int(u) (N) on the owned dofs for the owned dof values u (m): a view of an internal
        array, overwritten by the next call. Collective (ghost updates)."""
        from dolfinx.la import InsertMode

        self._u.array[: self.n_owned] = u
        self._u.scatter_forward()
        self._f.array[:] = 0.0
        lib, ffi = self.module.lib, self.module.ffi
        failed = ffi.from_buffer("int32_t[]", self._failed)
        n_failed = lib.forces(
            self.n_cells, ffi.NULL, *self._args, 0, failed, self._min, self._bad
        )
        smallest = -np.inf if self._bad[0] else self._min[0]
        if n_failed:  # R by the Python path (the SVD where Newton fails) for those cells
            self.fallbacks += 1
            cells = self._failed[:n_failed].copy()
            self.R[cells] = elastic.rotations(self.R[cells])
            lib.forces(
                n_failed,
                ffi.from_buffer("int32_t[]", cells),
                *self._args,
                1,
                failed,
                self._min,
                self._bad,
            )
            smallest = -np.inf if self._bad[0] else min(smallest, self._min[0])
        self.min_det = smallest
        self._f.scatter_reverse(InsertMode.add)
        return self._f.array[: self.n_owned]

    def explicit_update(
        self,
        f: np.ndarray,
        fint: np.ndarray,
        inv_s: np.ndarray,
        alpha_ml: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        gh: float,
    ) -> None:
        """a = inv_s (f - fint - alpha_ml v), then v += gh a, over the owned dofs (arrays of
        equal length; f, fint in N, inv_s in 1/kg, alpha_ml in kg/s, v in m/s, a in m/s^2,
        gh in s)."""
        ffi = self.module.ffi
        self.module.lib.explicit_update(
            len(a),
            ffi.from_buffer("double[]", f),
            ffi.from_buffer("double[]", fint),
            ffi.from_buffer("double[]", inv_s),
            ffi.from_buffer("double[]", alpha_ml),
            ffi.from_buffer("double[]", v),
            ffi.from_buffer("double[]", a),
            gh,
        )
