"""The internal force f_int(u) = ∫ P(F) : ∇w dX of an elastic model and its tangent, assembled
from UFL forms compiled once (SPEC section 8), on one System's function space.

The integrators hold owned-dof PETSc Vecs (solvers/system.py); this class takes and returns
those. Units: u in m, f_int in N, the tangent in N/m.
"""

from __future__ import annotations

from mpi4py import MPI
from petsc4py import PETSc

import basix
import dolfinx.fem.petsc
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.solvers.models.model import Model
from tissuebench.solvers.system import System, epsilon, sigma

QUADRATURE_DEGREE = 2  # 2 Gauss points per direction: full integration of Q1, as K uses


class ElasticForces:
    """f_int(u), the tangent c_T K_T(u) + c_K K_0 + c_M M, and the smallest J = det F at the
    quadrature points, for `model` on `system`.

    The Lamé constants are the system's (plane strain in 2D: SPEC 8 refuses plane stress for
    a nonlinear model). For a rotated model (corotational), R is updated from u at the cell
    centres before every evaluation."""

    def __init__(self, system: System, model: Model):
        self.system, self.model = system, model
        mesh, V, gdim = system.mesh, system.V, system.gdim
        self.u = fem.Function(V, name="displacement")
        du, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        F = ufl.Identity(gdim) + ufl.grad(self.u)
        self.R = None
        if model.rotated:
            T = fem.functionspace(mesh, ("DG", 0, (gdim, gdim)))
            self.R = fem.Function(T, name="rotation")
            self.R.x.array[:] = np.tile(np.eye(gdim).ravel(), len(self.R.x.array) // gdim**2)
            centre = basix.geometry(mesh.basix_cell()).mean(axis=0)[None, :]
            self._F_centre = fem.Expression(F, centre)
            tdim = mesh.topology.dim
            cmap = mesh.topology.index_map(tdim)
            self._cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
            self._R_dofs = T.dofmap.list[self._cells, 0]
        P = model.first_piola(F, system.mu, system.lmbda, self.R)
        dx = ufl.dx(metadata={"quadrature_degree": QUADRATURE_DEGREE})
        f_int = ufl.inner(P, ufl.grad(w)) * dx
        self.f_form = fem.form(f_int)
        # the Jacobian of a step: c_T K_T(u) + c_K K_0 (+ c_M M, consistent mass)
        self.c_T = fem.Constant(mesh, PETSc.ScalarType(1.0))
        self.c_K = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.c_M = fem.Constant(mesh, PETSc.ScalarType(0.0))
        K_T = ufl.derivative(f_int, self.u, du)
        K_0 = ufl.inner(sigma(du, system.mu, system.lmbda), epsilon(w)) * dx
        M = system.rho * ufl.inner(du, w) * dx
        self.j_form = fem.form(self.c_T * K_T + self.c_K * K_0 + self.c_M * M)
        # J = det F at the quadrature points, to find inverted elements
        points, _ = basix.make_quadrature(mesh.basix_cell(), QUADRATURE_DEGREE)
        self._det = fem.Expression(ufl.det(F), points)
        tdim = mesh.topology.dim
        self._owned = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self._b = dolfinx.fem.petsc.create_vector(V)
        self.bcs = [self._constrained_bc()]
        self._J = None

    def _constrained_bc(self) -> fem.DirichletBC:
        """The constrained nodes (owned and ghost) as a DirichletBC, for the Jacobian's rows
        and columns (set to the identity)."""
        s = self.system
        nodes = []
        for c in s.benchmark.constraints:
            s.mesh.topology.create_connectivity(c.dim, s.mesh.topology.dim)
            nodes.append(fem.locate_dofs_topological(s.V, c.dim, c.entities))
        nodes = np.unique(np.concatenate(nodes)).astype(np.int32)
        return fem.dirichletbc(np.zeros(s.gdim, dtype=PETSc.ScalarType), nodes, s.V)

    def set_u(self, u: PETSc.Vec) -> None:
        """Take the owned values of u (m), update the ghosts and, for a rotated model, R."""
        n = u.getLocalSize()
        self.u.x.array[:n] = u.array_r
        self.u.x.scatter_forward()
        if self.R is not None:
            self._update_rotation()

    def _update_rotation(self) -> None:
        """R = U V^T from the SVD F = U S V^T at every cell centre (det R = +1)."""
        gdim = self.system.gdim
        F = self._F_centre.eval(self.system.mesh, self._cells).reshape(-1, gdim, gdim)
        U, _, Vt = np.linalg.svd(F)
        sign = np.sign(np.linalg.det(U @ Vt))
        sign[sign == 0] = 1.0
        U[:, :, -1] *= sign[:, None]
        R = U @ Vt
        bs = gdim * gdim
        values = self.R.x.array.reshape(-1, bs)
        values[self._R_dofs] = R.reshape(-1, bs)

    def internal_force(self, u: PETSc.Vec, out: PETSc.Vec) -> PETSc.Vec:
        """out = f_int(u) (N) on the owned dofs."""
        self.set_u(u)
        b = self._b
        with b.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self.f_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        out.array[:] = b.array_r[: out.getLocalSize()]
        return out

    def jacobian(self, c_T: float, c_K: float, c_M: float, lumped: PETSc.Vec | None = None):
        """c_T K_T(u) + c_K K_0 + c_M M at the u last set (set_u or internal_force), with the
        constrained rows and columns replaced by the identity. With `lumped` (M_L, zero on
        the constrained dofs) c_M M_L goes on the diagonal instead of c_M M. Reuses one
        matrix, which it returns."""
        self.c_T.value, self.c_K.value = c_T, c_K
        self.c_M.value = 0.0 if lumped is not None else c_M
        if self._J is None:
            self._J = dolfinx.fem.petsc.create_matrix(self.j_form)
        J = self._J
        J.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(J, self.j_form, bcs=self.bcs)
        if lumped is not None:
            J.assemble(PETSc.Mat.AssemblyType.FLUSH)
            d = lumped.copy()
            d.scale(c_M)
            J.setDiagonal(d, addv=PETSc.InsertMode.ADD_VALUES)
        J.assemble()
        return J

    def min_det(self, u: PETSc.Vec | None = None) -> float:
        """The smallest J = det F at a quadrature point over all ranks (after set_u(u))."""
        if u is not None:
            self.set_u(u)
        det = self._det.eval(self.system.mesh, self._owned)
        local = float(det.min()) if det.size else np.inf
        if not np.isfinite(det).all():
            local = -np.inf
        return self.system.comm.allreduce(local, op=MPI.MIN)

    def destroy(self) -> None:
        self._b.destroy()
        if self._J is not None:
            self._J.destroy()
