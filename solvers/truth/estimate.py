"""The truth's own error (SPEC 10): E_i between levels and time steps, and the estimate from
a hierarchy."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem

from tissuebench.solvers.truth.solver import TruthRun


def interior_difference(
    coarse: TruthRun, fine: TruthRun, time_ratio: int = 1, batch: int = 64
) -> np.ndarray:
    """E_i (SPEC 6: |Omega|^(-1/d) int ||u_f - u_c|| dX; m^3 in 3D, m^2 in 2D; for runs on a
    meridian, of the revolved body: dX = 2 pi r dr dz, d = 3, m^3) between two truth runs at
    the coarse run's kept steps, the coarse one interpolated into the fine space (exact for
    nested uniform refinements; none when both share one space); `time_ratio` pairs coarse
    step k with fine step time_ratio k. The interpolation handles `batch` steps at once, as
    the components of one wide Lagrange function. Collective."""
    Vf, Vc = fine.V, coarse.V
    mesh = Vf.mesh
    gdim = mesh.geometry.dim
    d = fem.Function(Vf)
    if fine.axisymmetric:  # SPEC 13: the revolved body's E_i (m^3), dV = 2 pi r dr dz
        r = ufl.SpatialCoordinate(mesh)[0]
        dx = ufl.dx(domain=mesh, metadata={"quadrature_degree": 6})
        form = fem.form(ufl.sqrt(ufl.inner(d, d)) * 2 * np.pi * r * dx)
        volume = mesh.comm.allreduce(fem.assemble_scalar(fem.form(2 * np.pi * r * dx)))
        gdim_e = 3
    else:
        form = fem.form(ufl.sqrt(ufl.inner(d, d)) * ufl.dx(metadata={"quadrature_degree": 6}))
        volume = mesh.comm.allreduce(
            fem.assemble_scalar(fem.form(1.0 * ufl.dx(domain=mesh))), op=MPI.SUM
        )
        gdim_e = gdim
    # the ignores below: fine.u and coarse.u are runs' kept steps (TruthRun.u, None for a run
    # that kept none); no assert states it, as the truth's cache key hashes this code
    n_fine = fine.u.shape[1]  # type: ignore[union-attr]
    steps = len(coarse.u)  # type: ignore[arg-type]
    same = Vc is Vf
    if not same:
        cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
        degree = Vc.ufl_element().embedded_superdegree
        K = min(batch, steps)
        wide_c = fem.functionspace(Vc.mesh, ("Lagrange", degree, (gdim * K,)))
        wide_f = fem.functionspace(mesh, ("Lagrange", degree, (gdim * K,)))
        # the wide spaces number the nodes in their own order (V may be collapsed from a
        # mixed space): node maps through the cells' local dofs, the same element layout
        perm = []
        for V, W in ((Vc, wide_c), (Vf, wide_f)):
            index = np.empty(len(V.tabulate_dof_coordinates()), dtype=np.int64)
            index[V.dofmap.list.ravel()] = W.dofmap.list.ravel()
            perm.append(index)
        data = fem.create_interpolation_data(wide_f, wide_c, cells)
        uc, uf, one = fem.Function(wide_c), fem.Function(wide_f), fem.Function(Vc)
        nc = coarse.u.shape[1]  # type: ignore[union-attr]
        owned_f = perm[1][: n_fine // gdim]
    out = []
    for first in range(0, steps, batch):
        ks = range(first, min(first + batch, steps))
        if not same:
            block = uc.x.array.reshape(-1, K, gdim)
            block[:] = 0.0
            for j, k in enumerate(ks):
                one.x.array[:nc] = coarse.u[k]  # type: ignore[index]
                one.x.scatter_forward()  # every local node, ghosts too
                block[perm[0], j] = one.x.array.reshape(-1, gdim)
            uf.interpolate_nonmatching(uc, cells, data)
            interpolated = uf.x.array.reshape(-1, K, gdim)[owned_f]
        for j, k in enumerate(ks):
            d.x.array[:n_fine] = fine.u[time_ratio * k]  # type: ignore[index]
            if same:
                d.x.array[:n_fine] -= coarse.u[k]  # type: ignore[index]
            else:
                d.x.array[:n_fine] -= interpolated[:, j].reshape(-1)
            d.x.scatter_forward()
            local = fem.assemble_scalar(form)
            out.append(mesh.comm.allreduce(local, op=MPI.SUM) * volume ** (-1 / gdim_e))
    return np.array(out)


@dataclass
class ErrorEstimate:
    """The truth's own error (SPEC 10), in the units of the differences given: observed order
    p in space, the space error of the finest level, the time error of step h, their sum."""

    order: np.ndarray | float
    space: np.ndarray | float
    time: np.ndarray | float
    total: np.ndarray | float


def estimate_error(
    level_differences: Sequence,
    time_difference: float | np.ndarray | None = None,
    time_order: float = 2.0,
) -> ErrorEstimate:
    """The own error from a hierarchy: level_differences = [E(l1, l0), E(l2, l1)] (the last
    two differences of consecutive uniformly refined levels, scalars or arrays over steps, any
    quantity that scales as h^p); p = log2(d1 / d2) and E(finest) ~= d2 / (2^p - 1).
    time_difference = E(h, h/2) on the finest level gives the time error of step h,
    d_t 2^q / (2^q - 1) with q the trapezoidal rule's order 2. Where the levels do not
    converge (d2 >= d1) the order and the space error are NaN."""
    d1, d2 = (np.abs(np.asarray(d, dtype=float)) for d in level_differences[-2:])
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where((d2 > 0) & (d1 > d2), np.log2(d1 / d2), np.nan)
        space = np.where(d2 == 0, 0.0, d2 / (2.0**p - 1))
    q = 2.0**time_order
    tdiff = 0.0 if time_difference is None else np.abs(np.asarray(time_difference, dtype=float))
    terr = tdiff * q / (q - 1)
    scalar = np.ndim(p) == 0
    fix = (lambda a: float(a)) if scalar and np.ndim(terr) == 0 else (lambda a: a)
    return ErrorEstimate(fix(p), fix(space), fix(terr), fix(space + terr))
