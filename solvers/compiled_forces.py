"""The internal force f_int(u) = ∫ P(F) : ∇w dX of a nonlinear elastic model (SPEC section 8),
and the smallest J = det F at the quadrature points, in one compiled element loop per step: the
explicit schemes' force, as solvers/blockcsr.py is their linear step's product.

For P1/Q1 vector elements on triangles, quadrilaterals, tetrahedra and hexahedra, with the
quadrature of the UFL form (solvers/models/model.py: QUADRATURE_DEGREE, basix's points and
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
solvers/polar.py (`_polar_newton`, the same stopping rule); a cell where it fails (det F <= 0
or no convergence) gets its R from solvers/polar.rotations (the SVD) in Python, and a second
pass over those cells only.

The reference tables (the gradients of the shape functions at the points) are constants in the
C source, which is compiled per (cell, model, F-bar) with -O3 -march=native through cffi and
cached by its hash (blockcsr.compile_module). Units: u in m, f in N, mu and lmbda in Pa.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import basix
import numpy as np

from tissuebench.solvers import polar
from tissuebench.solvers.blockcsr import compile_module
from tissuebench.solvers.models.model import QUADRATURE_DEGREE

if TYPE_CHECKING:
    from mpi4py import MPI

    import dolfinx.la
    from dolfinx import fem

    from tissuebench.solvers.models.model import Model

CELLS = ("triangle", "quadrilateral", "tetrahedron", "hexahedron")
LANES = 8  # cells per batch: one AVX-512 register of doubles per batched value
# the lane loop around the model's stress (OpenMP's simd pragma only, no runtime); without
# trapping math a select such as J > 0 ? a : NAN vectorises (no value changes)
SIMD_FLAGS = ["-fopenmp-simd", "-fno-trapping-math"]

PREAMBLE = r"""
#include <math.h>
#include <stdint.h>
#include <stddef.h>
#include <string.h>

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

/* x^(-1/3) for a positive normal x, to round-off: a first guess from the exponent (x as a
   float: the inverse cube root's bit trick), then Newton's y <- y (4 - x y^3) / 3, which
   converges quadratically and divides nothing (vectorisable, unlike libm's cbrt). NaN for
   x <= 0 and not finite beyond the float range (1e-38 to 3e38). */
static inline double inv_cbrt(double x)
{
  float xf = (float)x;
  int32_t i;
  memcpy(&i, &xf, sizeof i);
  i = 0x54a2fa8c - i / 3;
  memcpy(&xf, &i, sizeof i);
  double y = xf;
  for (int k = 0; k < 4; ++k) y = y * (4.0 - x * y * y * y) * (1.0 / 3.0);
  return x > 0.0 ? y : NAN;
}

static inline void stress(const double* restrict F, double J, const double* restrict R,
                          double mu, double lmbda, double* restrict P)
{
STRESS_BODY
}
"""

KERNEL = r"""
#define GS (D * D + 1) /* doubles per point: J_e^-1, then w |det J_e| */

/* Every array below is batched: W cells side by side, the lane (cell) index last, so that
   each loop over the lanes is one SIMD operation. */

/* F = I + H Jinv with H = sum_a u_a (x) dN_a (the reference gradient of u) */
static inline void deformation(const double ue[NN][D][W], const double dN[NN][D],
                               const double* restrict Jinv, double F[D * D][W])
{
  double H[D][D][W] = {{{0.0}}};
  for (int a = 0; a < NN; ++a)
    for (int i = 0; i < D; ++i)
      for (int k = 0; k < D; ++k)
        for (int l = 0; l < W; ++l) H[i][k][l] += ue[a][i][l] * dN[a][k];
  for (int i = 0; i < D; ++i)
    for (int j = 0; j < D; ++j)
      for (int l = 0; l < W; ++l) {
        double s = (i == j);
        for (int k = 0; k < D; ++k) s += H[i][k][l] * Jinv[(k * D + j) * W + l];
        F[i * D + j][l] = s;
      }
}

/* fe_a += Q dN_a with Q = scale P Jinv^T */
static inline void scatter(const double P[D * D][W], const double scale[W],
                           const double dN[NN][D], const double* restrict Jinv,
                           double fe[NN][D][W])
{
  double Q[D][D][W];
  for (int i = 0; i < D; ++i)
    for (int k = 0; k < D; ++k)
      for (int l = 0; l < W; ++l) {
        double s = 0.0;
        for (int j = 0; j < D; ++j) s += P[i * D + j][l] * Jinv[(k * D + j) * W + l];
        Q[i][k][l] = scale[l] * s;
      }
  for (int a = 0; a < NN; ++a)
    for (int i = 0; i < D; ++i)
      for (int l = 0; l < W; ++l) {
        double s = 0.0;
        for (int k = 0; k < D; ++k) s += Q[i][k][l] * dN[a][k];
        fe[a][i][l] += s;
      }
}

/* the stress of one lane, its matrices by value: so the lane loop below vectorises (gcc
   does not vectorise it with the lane's arrays passed by address) */
typedef struct { double a[D * D]; } Mat;
static inline Mat lane_stress(Mat F, double J, Mat R, double mu, double lmbda)
{
  Mat P;
  stress(F.a, J, ROTATED ? R.a : NULL, mu, lmbda, P.a);
  return P;
}

/* P = stress(F) lane by lane, J = det F, R the lanes' rotations (rotated models) */
static inline void stresses(const double F[D * D][W], const double J[W],
                            const double R[D * D][W], double mu, double lmbda,
                            double P[D * D][W])
{
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    Mat Fl, Rl;
    for (int k = 0; k < D * D; ++k) {
      Fl.a[k] = F[k][l];
      Rl.a[k] = ROTATED ? R[k][l] : 0.0;
    }
    const Mat Pl = lane_stress(Fl, J[l], Rl, mu, lmbda);
    for (int k = 0; k < D * D; ++k) P[k][l] = Pl.a[k];
  }
}

#if ROTATED
/* R of F = R U by X <- (g X + X^-T / g) / 2, g = det(X)^(-1/d), from X = F, until no entry
   changes by more than POLAR_STOP (solvers/polar.py _polar_newton); 0 if it fails */
static int polar(const double* restrict F, double* restrict R)
{
  double X[D * D], C[D * D];
  for (int k = 0; k < D * D; ++k) X[k] = F[k];
  cofactor(X, C);
  double det = determinant(X);
  if (!(det > 0.0) || !isfinite(det)) return 0;
  for (int it = 0; it < POLAR_MAX; ++it) {
#if D == 2
    double scale = 1.0 / sqrt(det); /* det^(-1/D), as pow would give it, to round-off */
#else
    double scale = inv_cbrt(det);
#endif
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

/* f += f_int of n cells in batches of W (dofs [batch][a][lane], geo [batch][q][k][lane],
   centre and R [batch][k][lane]; the last batch padded with copies of real cells, which are
   not scattered). Rotated models: R of each cell by polar() unless given_R; a cell where it
   fails gets F at its centre in R, its index in failed[] and no force; returns how many.
   *min_det: the smallest det F; *nonfinite: whether some det F is not finite. */
int32_t forces(int32_t n, const int32_t* restrict dofs, const double* restrict geo,
               const double* restrict centre, const double* restrict u, double* restrict f,
               double mu, double lmbda, double* restrict R, int32_t given_R,
               int32_t* restrict failed, double* restrict min_det, int32_t* restrict nonfinite)
{
  int32_t nfailed = 0, bad = 0;
  double smallest = INFINITY;
  const int32_t nb = (n + W - 1) / W;
  for (int32_t m = 0; m < nb; ++m) {
    const int32_t* restrict cd = dofs + (int64_t)m * NN * W;
    const double* restrict g = geo + (int64_t)m * NQ * GS * W;
    double ue[NN][D][W], fe[NN][D][W];
    int skip[W];
    for (int l = 0; l < W; ++l) skip[l] = (int64_t)m * W + l >= n;
    for (int a = 0; a < NN; ++a)
      for (int i = 0; i < D; ++i)
        for (int l = 0; l < W; ++l) {
          ue[a][i][l] = u[(int64_t)cd[a * W + l] * D + i];
          fe[a][i][l] = 0.0;
        }
#if ROTATED
    double(*Rb)[W] = (double(*)[W])(R + (int64_t)m * D * D * W);
    if (!given_R) {
      double Fc[D * D][W];
      deformation(ue, DNC, centre + (int64_t)m * D * D * W, Fc);
      for (int l = 0; l < W; ++l) {
        double Fl[D * D], Rl[D * D];
        for (int k = 0; k < D * D; ++k) Fl[k] = Fc[k][l];
        const int ok = polar(Fl, Rl);
        for (int k = 0; k < D * D; ++k) Rb[k][l] = ok ? Rl[k] : Fl[k];
        if (!ok && !skip[l]) {
          failed[nfailed++] = m * W + l;
          skip[l] = 1;
        }
      }
    }
    double Rloc[D * D][W]; /* a local copy: the stress loop then vectorises */
    for (int k = 0; k < D * D; ++k)
      for (int l = 0; l < W; ++l) Rloc[k][l] = Rb[k][l];
    const double(*Rc)[W] = (const double(*)[W])Rloc;
#else
    const double(*Rc)[W] = NULL;
#endif
    double F[NQ][D * D][W], J[NQ][W];
    for (int q = 0; q < NQ; ++q) {
      deformation(ue, DN[q], g + q * GS * W, F[q]);
      for (int l = 0; l < W; ++l) {
        double Fl[D * D];
        for (int k = 0; k < D * D; ++k) Fl[k] = F[q][k][l];
        const double j = determinant(Fl);
        J[q][l] = j;
        bad |= !(j - j == 0.0); /* NaN or infinite */
        smallest = j < smallest ? j : smallest;
      }
    }
#if FBAR
    double Jbar[W];
    for (int l = 0; l < W; ++l) {
      double volume = 0.0, integral = 0.0;
      for (int q = 0; q < NQ; ++q) {
        volume += g[(q * GS + D * D) * W + l];
        integral += g[(q * GS + D * D) * W + l] * J[q][l];
      }
      Jbar[l] = integral / volume;
    }
#endif
    for (int q = 0; q < NQ; ++q) {
      double P[D * D][W], scale[W];
      const double* restrict wdetJ = g + (q * GS + D * D) * W;
#if FBAR
      double Fb[D * D][W], s[W];
      for (int l = 0; l < W; ++l) {
#if D == 2
        s[l] = sqrt(Jbar[l] / J[q][l]);
#else
        s[l] = inv_cbrt(J[q][l] / Jbar[l]);
#endif
        scale[l] = s[l] * wdetJ[l];
      }
      for (int k = 0; k < D * D; ++k)
        for (int l = 0; l < W; ++l) Fb[k][l] = s[l] * F[q][k][l];
      stresses((const double(*)[W])Fb, Jbar, Rc, mu, lmbda, P); /* det F_bar = J_bar */
#else
      for (int l = 0; l < W; ++l) scale[l] = wdetJ[l];
      stresses((const double(*)[W])F[q], J[q], Rc, mu, lmbda, P);
#endif
      scatter((const double(*)[W])P, scale, DN[q], g + q * GS * W, fe);
    }
    for (int l = 0; l < W; ++l) {
      if (skip[l]) continue;
      for (int a = 0; a < NN; ++a)
        for (int i = 0; i < D; ++i) f[(int64_t)cd[a * W + l] * D + i] += fe[a][i][l];
    }
  }
  *min_det = smallest;
  *nonfinite = bad;
  return nfailed;
}

/* the explicit-lumped step's update (solvers/nonlinear.py ExplicitLumpedModel) over the
   owned dofs, with u = ubar of this step: vt = v + gv a (v's predictor),
   a = inv_s (f - fint - alpha_ml vt), v = vt + gh a, and the next step's predictor
   u_next = u + (h v + hh a), each array read and written once */
void explicit_update(int64_t n, const double* restrict f, const double* restrict fint,
                     const double* restrict inv_s, const double* restrict alpha_ml,
                     double* restrict v, double* restrict a, const double* restrict u,
                     double* restrict u_next, double gv, double gh, double h, double hh)
{
  for (int64_t d = 0; d < n; ++d) {
    const double vt = v[d] + gv * a[d];
    const double an = inv_s[d] * ((f[d] - fint[d]) - alpha_ml[d] * vt);
    const double vn = vt + gh * an;
    a[d] = an;
    v[d] = vn;
    u_next[d] = u[d] + (h * vn + hh * an);
  }
}
"""

DECLARATIONS = """
int32_t forces(int32_t, const int32_t*, const double*, const double*, const double*, double*,
               double, double, double*, int32_t, int32_t*, double*, int32_t*);
void explicit_update(int64_t, const double*, const double*, const double*, const double*,
                     double*, double*, const double*, double*, double, double, double, double);
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
    # basix annotates its arrays as ArrayLike
    points, _ = cast(tuple[np.ndarray, ...], basix.make_quadrature(cell_type, QUADRATURE_DEGREE))
    element = basix.create_element(basix.ElementFamily.P, cell_type, 1)
    tdim = points.shape[1]
    if tdim != gdim:
        raise ValueError(f"{cell} cells in {gdim} dimensions: only tdim = gdim is compiled")
    dN = cast(np.ndarray, element.tabulate(1, points))[1 : 1 + tdim, :, :, 0].transpose(1, 2, 0)
    centre = basix.geometry(cell_type).mean(axis=0)[None, :]
    dNc = cast(np.ndarray, element.tabulate(1, centre))[1 : 1 + tdim, 0, :, 0].T  # (a, k)
    nq, nn = dN.shape[:2]
    head = (
        f"#define W {LANES}\n#define D {gdim}\n#define NN {nn}\n#define NQ {nq}\n"
        f"#define ROTATED {int(model.rotated)}\n#define FBAR {int(fbar)}\n"
        f"#define POLAR_STOP {polar.POLAR_STOP!r}\n"
        f"#define POLAR_MAX {polar.POLAR_MAX_ITERATIONS}\n"
    )
    tables = _c_array("DN", dN) + _c_array("DNC", dNc)
    return head + PREAMBLE.replace("STRESS_BODY", model.c_stress) + tables + KERNEL


def batched(x: np.ndarray) -> np.ndarray:
    """Per-cell data x (shape (n, ...)) in the loop's layout (nb, ..., LANES): LANES cells side
    by side, the last batch padded with copies of the first cell (at least one batch)."""
    n = len(x)
    nb = max(1, -(-n // LANES))
    padded = np.zeros((nb * LANES,) + x.shape[1:], dtype=x.dtype)
    padded[:n] = x
    if n:
        padded[n:] = x[0]
    return np.ascontiguousarray(np.moveaxis(padded.reshape((nb, LANES) + x.shape[1:]), 1, -1))


def unbatched(x: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """The data of `cells` (shape (len(cells), ...)) from a batched array."""
    return x[cells // LANES, ..., cells % LANES]  # advanced indices first: (cells, ...)


class CompiledForces:
    """f_int(u) and the smallest det F of `model` on the vector P1/Q1 space V (block size gdim),
    Lamé constants mu and lmbda (Pa), by the compiled element loop; F-bar if `fbar`.

    `evaluate(u)` takes the owned dof values of u (m) and returns f_int (N) on the owned dofs
    (a view of an internal array, valid until the next call; `evaluate_vector(x)` the same at
    a ghosted vector's owned values, without a copy); `min_det` is then the smallest
    det F at a quadrature point of this rank's cells (-inf if one is not finite).

    Memory: per owned cell, (D^2 + 1) doubles per quadrature point (640 bytes on a Q1
    hexahedron, 160 on a quadrilateral), its dofs, and for a rotated model 2 D^2 doubles."""

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
        dofs = V.dofmap.list[:n_cells].astype(np.int32)
        # the geometry of each owned cell: its nodes in the same local order as V's dofs
        # (both P1/Q1 on the same reference cell)
        x = mesh.geometry.x[:, :gdim]
        nodes = x[mesh.geometry.dofmaps[0][:n_cells]]  # (cell, a, i)
        cell_type = getattr(basix.CellType, cell)
        points, weights = cast(  # basix annotates its arrays as ArrayLike
            tuple[np.ndarray, ...], basix.make_quadrature(cell_type, QUADRATURE_DEGREE)
        )
        element = basix.create_element(basix.ElementFamily.P, cell_type, 1)
        nq = len(weights)
        geo = np.empty((n_cells, nq, gdim * gdim + 1))
        for q in range(nq):
            dN = cast(np.ndarray, element.tabulate(1, points[q : q + 1]))[1 : 1 + tdim, 0, :, 0]
            Je = np.einsum("cai,ka->cik", nodes, dN)  # dx_i / dxi_k
            geo[:, q, : gdim * gdim] = np.linalg.inv(Je).reshape(n_cells, -1)
            geo[:, q, -1] = weights[q] * np.abs(np.linalg.det(Je))
        self.dofs, self.geo = batched(dofs), batched(geo)
        del geo
        self.centre = self.R = np.zeros((1, gdim * gdim, LANES))
        if model.rotated:
            centre = basix.geometry(cell_type).mean(axis=0)[None, :]
            dN = cast(np.ndarray, element.tabulate(1, centre))[1 : 1 + tdim, 0, :, 0]
            inverse = np.linalg.inv(np.einsum("cai,ka->cik", nodes, dN))
            self.centre = batched(inverse.reshape(n_cells, -1))
            self.R = np.zeros_like(self.centre)
        self._failed = np.zeros(max(n_cells, 1), dtype=np.int32)
        self._u = dolfinx.la.vector(V.dofmap.index_map, gdim)
        self._f = dolfinx.la.vector(V.dofmap.index_map, gdim)
        self.n_owned = V.dofmap.index_map.size_local * gdim
        self.module = compile_module(
            "_tissuebench_forces",
            source(model, cell, gdim, fbar),
            DECLARATIONS,
            mesh.comm,
            SIMD_FLAGS,
        )
        ffi = self.module.ffi
        self._min, self._bad = ffi.new("double*"), ffi.new("int32_t*")
        self.min_det = np.inf
        self.u = self._u.array  # the last evaluation's u, owned and ghost dofs (m)
        self.fallbacks = 0  # evaluations in which some cell's R came from the Python path

    def _forces(
        self, n: int, dofs: np.ndarray, geo: np.ndarray, R: np.ndarray, given_R: bool
    ) -> tuple[int, float]:
        """The loop over n cells of batched data at self.u: (cells whose R failed, smallest
        det F)."""
        ffi, lib = self.module.ffi, self.module.lib
        n_failed = lib.forces(
            n,
            ffi.from_buffer("int32_t[]", dofs),
            ffi.from_buffer("double[]", geo),
            ffi.from_buffer("double[]", self.centre),
            ffi.from_buffer("double[]", self.u),
            ffi.from_buffer("double[]", self._f.array),
            self.mu,
            self.lmbda,
            ffi.from_buffer("double[]", R),
            int(given_R),
            ffi.from_buffer("int32_t[]", self._failed),
            self._min,
            self._bad,
        )
        return n_failed, (-np.inf if self._bad[0] else self._min[0])

    def vector(self) -> dolfinx.la.Vector:
        """A new vector over V's dofs (the owned, then the ghosts), for evaluate_vector."""
        import dolfinx.la

        return dolfinx.la.vector(self._u.index_map, self.gdim)

    def evaluate(self, u: np.ndarray) -> np.ndarray:
        """f_int(u) (N) on the owned dofs for the owned dof values u (m): a view of an internal
        array, overwritten by the next call. Collective (ghost updates)."""
        self._u.array[: self.n_owned] = u
        return self.evaluate_vector(self._u)

    def evaluate_vector(self, x: dolfinx.la.Vector) -> np.ndarray:
        """f_int (N) on the owned dofs at the owned values of x (m; a vector of self.vector(),
        whose ghosts are scattered here, and which self.u then views): as evaluate(), without
        copying u. Collective (ghost updates)."""
        from dolfinx.la import InsertMode

        x.scatter_forward()
        self.u = x.array
        self._f.array[:] = 0.0
        n_failed, self.min_det = self._forces(self.n_cells, self.dofs, self.geo, self.R, False)
        if n_failed:  # R by the Python path (the SVD where Newton fails) for those cells
            self.fallbacks += 1
            cells = self._failed[:n_failed].copy()
            d = self.gdim
            F = unbatched(self.R, cells).reshape(-1, d, d)
            R = polar.rotations(F).reshape(n_failed, d * d)
            self._forces(
                n_failed,
                batched(unbatched(self.dofs, cells)),
                batched(unbatched(self.geo, cells)),
                batched(R),
                True,
            )
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
        u: np.ndarray,
        u_next: np.ndarray,
        gamma: float,
        h: float,
    ) -> None:
        """One explicit-lumped update over the owned dofs (arrays of equal length), each read
        and written once: v = v + (1 - gamma) h a, a = inv_s (f - fint - alpha_ml v), v +=
        gamma h a, then the next step's predictor u_next = u + h v + h^2/2 a (another array
        than u). Units: f, fint in N, inv_s in 1/kg, alpha_ml in kg/s, u in m, v in m/s, a in
        m/s^2, h in s."""
        ffi = self.module.ffi
        self.module.lib.explicit_update(
            len(a),
            ffi.from_buffer("double[]", f),
            ffi.from_buffer("double[]", fint),
            ffi.from_buffer("double[]", inv_s),
            ffi.from_buffer("double[]", alpha_ml),
            ffi.from_buffer("double[]", v),
            ffi.from_buffer("double[]", a),
            ffi.from_buffer("double[]", u),
            ffi.from_buffer("double[]", u_next),
            (1 - gamma) * h,
            gamma * h,
            h,
            h * h / 2,
        )
