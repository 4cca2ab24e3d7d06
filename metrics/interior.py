"""The interior error (SPEC 6.3), E_i = |Ω_0|^(−1/d) ∫_{Ω_0} ‖u′ − u‖ dX, by Gauss quadrature of
the finite-element displacements, and the paper's nodal form
|Ω_0|^(−1/d) Σ_n w_n ‖u′_n − u_n‖ with w_n = ∫_{Ω_0} φ_n dX."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np
import ufl
from dolfinx import fem, la


class InteriorMetric:
    """E_i and its nodal variant on the vector Q1 (or P1, on simplices) space V, forms compiled
    once.

    `points` Gauss points per direction in each cell: the quadrature degree 2 points - 1 is
    the highest that basix's Gauss-Jacobi rule with that many points integrates exactly (on
    triangles and tetrahedra: basix's default rule of that degree, 7 and 15 points for 3).
    """

    def __init__(self, V: fem.FunctionSpace, points: int = 3):
        mesh = V.mesh
        self.comm = mesh.comm
        self.dim = mesh.geometry.dim
        self.owned = V.dofmap.index_map.size_local * V.dofmap.index_map_bs
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": 2 * points - 1})

        self.e = e = fem.Function(V)  # e = u' - u
        self.integral = fem.form(ufl.sqrt(ufl.inner(e, e)) * dx)
        one = fem.Constant(mesh, np.float64(1.0))
        self.volume = self.comm.allreduce(fem.assemble_scalar(fem.form(one * dx)), op=MPI.SUM)
        # w_n = ∫ φ_n dX, read from the first component of ∫ v_0 dX over the vector space;
        # exact with this rule on (tri)linear cells.
        w = fem.assemble_vector(fem.form(ufl.TestFunction(V)[0] * dx))
        w.scatter_reverse(la.InsertMode.add)
        self.weights = w.array[: self.owned].reshape(-1, self.dim)[:, 0].copy()
        self.scale = self.volume ** (-1 / self.dim)

    def quadrature(self, u_ref: np.ndarray, u_cand: np.ndarray) -> float:
        """E_i by quadrature."""
        self.e.x.array[: self.owned] = np.asarray(u_cand) - np.asarray(u_ref)
        self.e.x.scatter_forward()
        local = fem.assemble_scalar(self.integral)
        return self.scale * self.comm.allreduce(local, op=MPI.SUM)

    def nodal(self, u_ref: np.ndarray, u_cand: np.ndarray) -> float:
        """E_i's nodal variant."""
        e = (np.asarray(u_cand) - np.asarray(u_ref)).reshape(-1, self.dim)
        local = self.weights @ np.linalg.norm(e, axis=1)
        return self.scale * self.comm.allreduce(float(local), op=MPI.SUM)
