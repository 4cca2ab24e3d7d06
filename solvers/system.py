"""The assembled system of SPEC section 2: K, M, M_L and f in PETSc, and the constrained
degrees of freedom with their prescribed motion.

Units: K in N/m, M and M_L in kg, f in N (SI throughout).
"""

from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING

from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.meshes.benchmark import Benchmark
from tissuebench.solvers.materials import Material, get_material
from tissuebench.solvers.models.model import small_strain_stress

if TYPE_CHECKING:
    from tissuebench.solvers.blockcsr import BlockCSR


def epsilon(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """Small strain, sym(grad u)."""
    return ufl.sym(ufl.grad(u))


def sigma(
    u: ufl.core.expr.Expr, mu: fem.Constant | float, lmbda: fem.Constant | float
) -> ufl.core.expr.Expr:
    """Linear isotropic stress of u, 2 mu eps + lambda tr(eps) I with eps = epsilon(u)."""
    return small_strain_stress(epsilon(u), mu, lmbda)


class System:
    """K, M, M_L and f of one benchmark and material, with the constrained dofs.

    `scheme` (SPEC 11, solvers/schemes/): the element's stiffness, NAME or
    NAME:key=value,...; `standard` is the plain Q1/P1 element of SPEC section 2.

    K and M are PETSc matrices of `matrix_type` (None, the default: DOLFINx's AIJ, which the
    factorisations and preconditioners take; "baij" for gdim x gdim blocks). The products in
    the time loops use the compiled block-CSR copies K_csr and M_csr. Vectors are PETSc Vecs
    over the owned dofs of V (vector Q1, block size gdim); a dof's local index in a Vec is its
    local index in V. `constrained` holds the local indices of
    the owned constrained dofs and `component` their displacement component.
    """

    def __init__(
        self,
        benchmark: Benchmark,
        material: Material | str | None = None,
        plane: str = "strain",
        matrix_type: str | None = None,
        scheme: str = "standard",
    ):
        from tissuebench.solvers.schemes import SCHEMES, STANDARD, check_cells, parse_scheme

        self.benchmark = benchmark
        self.material = get_material(material or benchmark.material)
        self.mesh = mesh = benchmark.mesh
        self.comm = mesh.comm
        self.gdim = gdim = mesh.geometry.dim
        self.plane = plane
        mu, lmbda = (
            self.material.lame(plane) if gdim == 2 else (self.material.mu, self.material.lmbda)
        )
        self.V = V = fem.functionspace(mesh, ("Lagrange", 1, (gdim,)))

        # Material data as Constants: one compiled form serves every material.
        self.mu = fem.Constant(mesh, PETSc.ScalarType(mu))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        self.lmbda = fem.Constant(mesh, PETSc.ScalarType(lmbda))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        self.rho = fem.Constant(mesh, PETSc.ScalarType(self.material.rho))  # type: ignore[operator]  # petsc4py's stubs: ScalarType is the scalar class, not a dtype
        self.g = fem.Constant(mesh, np.asarray(benchmark.gravity, dtype=PETSc.ScalarType))
        u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
        self.k_form = fem.form(ufl.inner(sigma(u, self.mu, self.lmbda), epsilon(w)) * ufl.dx)
        self.m_form = fem.form(self.rho * ufl.inner(u, w) * ufl.dx)
        self.f_form = fem.form(self.rho * ufl.inner(self.g, w) * ufl.dx)

        # SPEC 11: a scheme other than the plain Q1/P1 element assembles its own K_0
        name, parameters = parse_scheme(scheme)
        check_cells(name, mesh.topology.cell_name())
        self.scheme = scheme
        if name == STANDARD:
            self.K = dolfinx.fem.petsc.assemble_matrix(self.k_form, kind=matrix_type)
            self.K.assemble()
        else:
            self.K = SCHEMES[name].stiffness(V, mu, lmbda, parameters)
            if matrix_type is not None:
                self.K = self.K.convert(matrix_type)
        self.M = dolfinx.fem.petsc.assemble_matrix(self.m_form, kind=matrix_type)
        self.M.assemble()
        f = dolfinx.fem.petsc.assemble_vector(self.f_form)
        f.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
        self.f = self.owned_copy(f)
        # Lumped mass: row sums of M on the diagonal, M_L = M 1.
        self.ML = self.K.createVecLeft()
        ones = self.K.createVecRight()
        ones.set(1.0)
        self.M.mult(ones, self.ML)
        self._constrain(benchmark.constraints)

    @cached_property
    def K_csr(self) -> BlockCSR:
        """K for the products in the time loops (solvers/blockcsr.py), built on first use."""
        from tissuebench.solvers.blockcsr import BlockCSR

        return BlockCSR(self.K, self.V)

    @cached_property
    def M_csr(self) -> BlockCSR:
        """M for the products in the time loops (solvers/blockcsr.py), built on first use."""
        from tissuebench.solvers.blockcsr import BlockCSR

        return BlockCSR(self.M, self.V)

    @cached_property
    def rigid_body_modes(self) -> PETSc.NullSpace:
        """The rigid-body motions of the mesh (gdim translations, 1 or 3 rotations) as a PETSc
        near null space, for algebraic multigrid (PETSc's MatNullSpaceCreateRigidBody)."""
        n = self.V.dofmap.index_map.size_local
        coords = self.K.createVecLeft()
        coords.setBlockSize(self.gdim)
        coords.array[:] = self.V.tabulate_dof_coordinates()[:n, : self.gdim].ravel()
        return PETSc.NullSpace().createRigidBody(coords)

    def owned_copy(self, x: PETSc.Vec) -> PETSc.Vec:
        """A plain (unghosted) Vec holding the owned entries of x."""
        y = self.K.createVecLeft()
        y.array[:] = x.array_r[: y.getLocalSize()]
        return y

    def _constrain(self, constraints):
        V, bs = self.V, self.gdim
        n_owned = V.dofmap.index_map.size_local
        owner, every = {}, []
        for k, c in enumerate(constraints):
            self.mesh.topology.create_connectivity(c.dim, self.mesh.topology.dim)
            nodes = fem.locate_dofs_topological(V, c.dim, c.entities)
            every.append(nodes)
            for node in nodes[nodes < n_owned]:
                owner[int(node)] = k  # a later constraint wins on a shared node
        # owned and ghost nodes, for forms assembled with the constraints as Dirichlet rows
        self.constrained_nodes = np.unique(np.concatenate(every)).astype(np.int32)
        nodes = np.array(sorted(owner), dtype=np.int64)
        which = np.array([owner[n] for n in nodes], dtype=np.int64)
        self.constrained = (bs * nodes[:, None] + np.arange(bs)).ravel().astype(np.int32)
        self.component = np.tile(np.arange(bs), len(nodes))
        self._which = np.repeat(which, bs)
        self._motions = [c.motion for c in constraints]
        offset = V.dofmap.index_map.local_range[0] * bs
        self.constrained_global = (self.constrained + offset).astype(PETSc.IntType)
        self.free = np.setdiff1d(np.arange(n_owned * bs, dtype=np.int32), self.constrained)

    def prescribed(self, t: float) -> np.ndarray:
        """(u, v, a), the rows of one array, of the constrained dofs at time t (s), aligned
        with self.constrained."""
        values = np.zeros((3, len(self.constrained)))
        for k, motion in enumerate(self._motions):
            sel = self._which == k
            if sel.any():
                for j, x in enumerate(motion(t)):
                    values[j, sel] = np.asarray(x)[self.component[sel]]
        return values

    def num_dofs(self) -> int:
        return self.V.dofmap.index_map.size_global * self.gdim

    def function(
        self, values: np.ndarray | None = None, name: str = "displacement"
    ) -> fem.Function:
        """A Function on V holding the owned values `values` (ghosts updated)."""
        fn = fem.Function(self.V, name=name)
        if values is not None:
            fn.x.array[: len(values)] = values
            fn.x.scatter_forward()
        return fn


def gather_by_coordinates(
    V: fem.FunctionSpace, values: np.ndarray, comm: MPI.Comm | None = None
) -> tuple[np.ndarray, np.ndarray] | None:
    """On rank 0: (coordinates, values) of all nodes of V in one order fixed by the node
    coordinates, whatever the partition; None on other ranks. `values` are owned dof values."""
    comm = comm or V.mesh.comm
    bs = V.dofmap.bs
    n = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    parts = comm.gather((x, np.asarray(values).reshape(n, bs)), root=0)
    if comm.rank != 0:
        return None
    assert parts is not None  # gathered on rank 0
    x = np.concatenate([p[0] for p in parts])
    vals = np.concatenate([p[1] for p in parts])
    order = np.lexsort(np.round(x, 10).T[::-1])
    return x[order], vals[order]


def probe(V: fem.FunctionSpace, values: np.ndarray, point: tuple[float, ...]) -> np.ndarray:
    """The finite-element field with owned dof values `values`, evaluated at `point` (m).
    Collective; every rank returns the same vector."""
    import dolfinx.geometry

    mesh = V.mesh
    fn = fem.Function(V)
    fn.x.array[: len(values)] = values
    fn.x.scatter_forward()
    p = np.zeros((1, 3))
    p[0, : len(point)] = point
    tree = dolfinx.geometry.bb_tree(mesh, mesh.topology.dim)
    candidates = dolfinx.geometry.compute_collisions_points(tree, p)
    cells = dolfinx.geometry.compute_colliding_cells(mesh, candidates, p).links(0)
    n_owned_cells = mesh.topology.index_map(mesh.topology.dim).size_local
    cells = cells[cells < n_owned_cells]
    found = len(cells) > 0
    value = fn.eval(p, cells[:1]) if found else np.zeros(V.dofmap.bs)
    # a point on a partition boundary may be found on several ranks: take the lowest rank's
    owner = mesh.comm.allreduce(mesh.comm.rank if found else mesh.comm.size, op=MPI.MIN)
    if owner == mesh.comm.size:
        raise ValueError(f"point {point} is outside the mesh")
    return mesh.comm.bcast(np.asarray(value), root=owner)
