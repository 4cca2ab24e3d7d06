"""The internal force f_int(u) = ∫ P(F) : ∇w dX of an elastic model and its tangent, assembled
from UFL forms compiled once (SPEC section 8), on one System's function space.

The integrators hold owned-dof PETSc Vecs (solvers/system.py); this class takes and returns
those. Units: u in m, f_int in N, the tangent in N/m.
"""

from __future__ import annotations

from typing import cast

from mpi4py import MPI
from petsc4py import PETSc

import basix
import dolfinx.fem.petsc
import dolfinx.la
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.solvers import contact as penalty
from tissuebench.solvers.models.model import QUADRATURE_DEGREE, Model
from tissuebench.solvers.polar import rotations
from tissuebench.solvers.system import System, epsilon, sigma

# The point evaluations (det F at the quadrature points, F at the cell centres) run once per
# step of an explicit scheme: compiled with -O3 instead of DOLFINx's default -O2 they take
# about 1/1.7 of the time on a Q1 hex, with the same values (the forms gain nothing from it).
EXPRESSION_JIT = {"cffi_extra_compile_args": ["-O3", "-g0"]}


class ElasticForces:
    """f_int(u), the tangent c_T K_T(u) + c_K K_0 + c_M M, and the smallest J = det F at the
    quadrature points, for `model` on `system`.

    The Lamé constants are the system's (plane strain in 2D: SPEC 8 refuses plane stress for
    a nonlinear model). For a rotated model (corotational), R is updated from u at the cell
    centres before every evaluation.

    With `compiled` (the explicit schemes), f_int and the smallest det F come from one
    compiled element loop (solvers/compiled_forces.py) where the model has a C stress and
    the cells are P1/Q1; `self.compiled` is then that loop (None otherwise: the UFL form). The
    tangent is always the UFL form's."""

    _J: PETSc.Mat | None
    _d: PETSc.Vec | None

    def __init__(self, system: System, model: Model, compiled: bool = False):
        self.system, self.model = system, model
        mesh, V, gdim = system.mesh, system.V, system.gdim
        self.u = fem.Function(V, name="displacement")
        du, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        F = ufl.Identity(gdim) + ufl.grad(self.u)
        self.R: fem.Function | None = None
        if model.rotated:
            T = fem.functionspace(mesh, ("DG", 0, (gdim, gdim)))
            self.R = fem.Function(T, name="rotation")
            self.R.x.array[:] = np.tile(np.eye(gdim).ravel(), len(self.R.x.array) // gdim**2)
            centre = basix.geometry(mesh.basix_cell()).mean(axis=0)[None, :]
            self._F_centre = fem.Expression(F, centre, jit_options=EXPRESSION_JIT)
            tdim = mesh.topology.dim
            cmap = mesh.topology.index_map(tdim)
            self._cells = np.arange(cmap.size_local + cmap.num_ghosts, dtype=np.int32)
            self._R_dofs = T.dofmap.list[self._cells, 0]
        dx = ufl.dx(metadata={"quadrature_degree": QUADRATURE_DEGREE})
        self.Jbar: fem.Function | None = None
        from tissuebench.solvers.schemes import scheme_of

        fbar = scheme_of(system).fbar
        self.compiled = None
        from tissuebench.solvers import compiled_forces

        # a rigid tool's contact (SPEC 12) where the system's benchmark has one (tests hand some
        # models a bare namespace with the spaces and constants only)
        self.contact = contact = getattr(getattr(system, "benchmark", None), "contact", None)
        if compiled and compiled_forces.available(model, mesh.topology.cell_name()):
            self.compiled = compiled_forces.CompiledForces(
                V, model, float(system.mu.value), float(system.lmbda.value), fbar
            )
        self._stale = False  # R and J_bar (UFL coefficients) lag behind self.u
        # the compiled loop's smallest det F (this rank) at self.u
        self._min_det: float | None = None
        if fbar:
            P = self._f_bar(F, model, dx)
        else:
            P = model.first_piola(F, system.mu, system.lmbda, self.R)
        f_int = ufl.inner(P, ufl.grad(w)) * dx
        # SPEC 12: a rigid tool's penalty contact, its force beside f_int (and so its tangent
        # in K_T), the tool placed at its centre of the time set_time gave
        self.needle: fem.Constant | None = None
        if contact is not None:
            self.needle = fem.Constant(mesh, np.asarray(contact.centre(0.0), dtype=float))
            ds = penalty.edge_measure(mesh, contact.facets)
            k = penalty.penalty_stiffness(system)
            energy = penalty.energy(self.u, self.needle, contact.tool, k, ds)
            f_int = f_int + ufl.derivative(energy, self.u, w)
        self.f_form = fem.form(f_int)
        # the explicit schemes' fast path with contact: f_int from the compiled loop (or K u for
        # the linear model) and the penalty's force facet by facet (solvers/edge_penalty.py)
        self.edge = None
        self._t = 0.0  # s, the time of set_time
        self.linear_k = compiled and model.linear  # f_int = K u (the linear model, with contact)
        if contact is not None and compiled and (self.compiled is not None or self.linear_k):
            from tissuebench.solvers.edge_penalty import EdgePenalty, FacetPenalty

            self.edge = EdgePenalty(system) if system.gdim == 2 else FacetPenalty(system)
        # the Jacobian of a step: c_T K_T(u) + c_K K_0 (+ c_M M, consistent mass)
        self.c_T = fem.Constant(mesh, PETSc.ScalarType(1.0))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        self.c_K = fem.Constant(mesh, PETSc.ScalarType(0.0))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        self.c_M = fem.Constant(mesh, PETSc.ScalarType(0.0))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        K_T = ufl.derivative(f_int, self.u, du)
        K_0 = ufl.inner(sigma(du, system.mu, system.lmbda), epsilon(w)) * dx
        M = system.rho * ufl.inner(du, w) * dx
        self.j_form = fem.form(self.c_T * K_T + self.c_K * K_0 + self.c_M * M)
        # J = det F at the quadrature points, to find inverted elements
        points, _ = cast(  # basix annotates its arrays as ArrayLike
            tuple[np.ndarray, ...], basix.make_quadrature(mesh.basix_cell(), QUADRATURE_DEGREE)
        )
        self._det = fem.Expression(ufl.det(F), points, jit_options=EXPRESSION_JIT)
        tdim = mesh.topology.dim
        self._owned = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self._b = dolfinx.fem.petsc.create_vector(V)
        # the constrained rows and columns of the Jacobian become the identity
        zero = np.zeros(gdim, dtype=PETSc.ScalarType)
        self.bcs = [fem.dirichletbc(zero, system.constrained_nodes, V)]
        self._J, self._d = None, None

    def _f_bar(self, F: ufl.core.expr.Expr, model: Model, dx: ufl.Measure) -> ufl.core.expr.Expr:
        """SPEC 11's mean-dilatation with a nonlinear model, F-bar (de Souza Neto et al.): the
        stress of F_bar = (J_bar / J)^(1/d) F, J_bar the cell's mean J, taken in the virtual
        work with the element's own gradient, P = (J_bar / J)^(1/d) P(F_bar) (the Kirchhoff
        stress of F_bar pulled back with F). J_bar is a cell-wise constant updated with u, not
        differentiated: the force is exact, a tangent from it is not (explicit schemes only)."""
        system = self.system
        if model.rotated:
            raise ValueError(f"mean-dilatation (F-bar) takes no rotated model, not {model.name}")
        Q = fem.functionspace(system.mesh, ("DG", 0))
        self.Jbar = fem.Function(Q, name="mean_J")
        self.Jbar.x.array[:] = 1.0
        q = ufl.TestFunction(Q)
        J = ufl.det(F)
        self._J_form = fem.form(J * q * dx)
        volumes = dolfinx.fem.petsc.assemble_vector(fem.form(q * dx))
        self._n_cells = Q.dofmap.index_map.size_local
        self._inverse_volume = 1.0 / volumes.array_r[: self._n_cells].copy()
        volumes.destroy()
        scale = (self.Jbar / J) ** (1.0 / system.gdim)
        return scale * model.first_piola(scale * F, system.mu, system.lmbda, None)

    def set_time(self, t: float) -> None:
        """Place the contact tool (if any) where it is at time t (s)."""
        contact = self.contact
        self._t = t
        if self.needle is not None and contact is not None:
            self.needle.value[:] = contact.centre(t)

    def set_u(self, u: PETSc.Vec) -> None:
        """Take the owned values of u (m), update the ghosts and, for a rotated model, R; for
        F-bar, each cell's mean J."""
        n = u.getLocalSize()
        self.u.x.array[:n] = u.array_r
        self.u.x.scatter_forward()
        self._min_det = None
        self._update_coefficients()

    def _update_coefficients(self) -> None:
        """R and J_bar from self.u (where the model and scheme have them)."""
        self._stale = False
        if self.R is not None:
            self._update_rotation()
        if self.Jbar is not None:
            b = dolfinx.fem.petsc.assemble_vector(self._J_form)  # ∫_e J dx, owned cells
            self.Jbar.x.array[: self._n_cells] = b.array_r[: self._n_cells] * self._inverse_volume
            self.Jbar.x.scatter_forward()
            b.destroy()

    def _update_rotation(self) -> None:
        """R = the rotation of the polar decomposition of F at every cell centre (rotations)."""
        gdim = self.system.gdim
        F = self._F_centre.eval(self.system.mesh, self._cells).reshape(-1, gdim, gdim)
        R = rotations(F)
        assert self.R is not None  # a rotated model's
        bs = gdim * gdim
        values = self.R.x.array.reshape(-1, bs)
        values[self._R_dofs] = R.reshape(-1, bs)

    def _take_compiled_u(self) -> None:
        """self.u, R and J_bar at the u of the last compiled internal_force (ghosts included)."""
        assert self.compiled is not None  # only the compiled loop leaves self.u stale
        self.u.x.array[:] = self.compiled.u
        self._update_coefficients()

    def compiled_internal_force(self, u: PETSc.Vec | dolfinx.la.Vector) -> np.ndarray:
        """f_int(u) (N) on the owned dofs by the compiled loop (self.compiled): a view of its
        array, valid until the next evaluation; min_det() is then that loop's own. u (m) is a
        Vec over the owned dofs, or a vector of self.compiled.vector() (its owned values set:
        read in place, its ghosts scattered)."""
        assert self.compiled is not None  # for a model and cells with a compiled loop
        if isinstance(u, PETSc.Vec):
            f = self.compiled.evaluate(u.array_r)
        else:
            f = self.compiled.evaluate_vector(u)
        self._min_det = self.compiled.min_det
        self._stale = True  # self.u is the loop's u, copied only if a UFL form needs it
        return f

    def internal_force(self, u: PETSc.Vec, out: PETSc.Vec) -> PETSc.Vec:
        """out = f_int(u) (N) on the owned dofs (with contact, its penalty's force too)."""
        if self.compiled is not None or (self.linear_k and self.edge is not None):
            if self.compiled is not None:
                out.array[:] = self.compiled_internal_force(u)
            else:
                self.system.K_csr.mult(u, out)
            if self.edge is not None:
                self.edge.add_to(out.array, u.array_r, self._t)
            return out
        self.set_u(u)
        b = self._b
        with b.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(b, self.f_form)  # type: ignore[arg-type]  # dolfinx's stubs: its (Vec, form) singledispatch variant
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
        out.array[:] = b.array_r[: out.getLocalSize()]
        return out

    def jacobian(
        self, c_T: float, c_K: float, c_M: float, lumped: PETSc.Vec | None = None
    ) -> PETSc.Mat:
        """c_T K_T(u) + c_K K_0 + c_M M at the u last set (set_u or internal_force), with the
        constrained rows and columns replaced by the identity. With `lumped` (M_L, zero on
        the constrained dofs) c_M M_L goes on the diagonal instead of c_M M. Reuses one
        matrix, which it returns."""
        self.c_T.value, self.c_K.value = c_T, c_K  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        self.c_M.value = 0.0 if lumped is not None else c_M  # type: ignore[assignment]  # dolfinx annotates a Constant's value as an array, takes a float
        if self._stale:
            self._take_compiled_u()
        if self._J is None:
            self._J = dolfinx.fem.petsc.create_matrix(self.j_form)
        J = self._J
        J.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(J, self.j_form, bcs=self.bcs)  # type: ignore[arg-type, misc]  # dolfinx's stubs: its (Mat, form) singledispatch variant
        if lumped is not None:
            J.assemble(PETSc.Mat.AssemblyType.FLUSH)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
            if self._d is None:
                self._d = lumped.duplicate()
            lumped.copy(self._d)
            self._d.scale(c_M)
            J.setDiagonal(self._d, addv=PETSc.InsertMode.ADD_VALUES)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
        J.assemble()
        return J

    def min_det(self, u: PETSc.Vec | None = None) -> float:
        """The smallest J = det F at a quadrature point over all ranks (after set_u(u)); at the
        u of the last internal_force, that loop's own (compiled: no extra pass)."""
        if u is not None:
            self.set_u(u)
        if self._min_det is not None:
            return self.system.comm.allreduce(self._min_det, op=MPI.MIN)
        if self._stale:
            self._take_compiled_u()
        det = self._det.eval(self.system.mesh, self._owned)
        local = float(det.min()) if det.size else np.inf
        if not np.isfinite(det).all():
            local = -np.inf
        return self.system.comm.allreduce(local, op=MPI.MIN)

    def destroy(self) -> None:
        for x in (self._b, self._J, self._d):
            if x is not None:
                x.destroy()
