"""What a discretisation scheme is (SPEC section 11): the element's stiffness K_0 of the linear
model, beside the plain Q1/P1 one, and the pieces its remedies against volumetric locking are
made of.

Every scheme is a linear stiffness matrix, so every algorithm (its mass, damping C = alpha M +
beta K_0 with the scheme's own K_0, its step matrix, the compiled explicit loop of
solvers/blockcsr.py) and the stability analysis take it as they take Q1's.

Units: the Lamé constants and moduli in Pa, K in N/m (N/m per m of depth in 2D).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from petsc4py import PETSc

import dolfinx.fem.petsc
import numpy as np
import ufl
from dolfinx import fem

from tissuebench.core.errors import UserError


class SchemeError(UserError):
    """A scheme that does not exist, does not fit the mesh's cells, or has a bad parameter."""


@dataclass(frozen=True)
class Parameter:
    """A scheme's number: its default, its range (low to high, each end taken unless `open`
    says it is left out) and its meaning, stated once here for --help, the parser and its
    refusals. The ranges keep the stiffness, the step matrices and the stability analysis's
    eigenvalues finite in float64 for every material that solvers/materials.py takes."""

    default: float
    low: float
    high: float
    meaning: str
    open: tuple[bool, bool] = (False, False)  # (low left out, high left out)

    def holds(self, value: float) -> bool:
        above = value > self.low if self.open[0] else value >= self.low
        below = value < self.high if self.open[1] else value <= self.high
        return above and below

    def range_text(self, name: str) -> str:
        """The range in words: "0 <= c_hg <= 100"."""
        low, high = ("<" if o else "<=" for o in self.open)
        return f"{self.low:g} {low} {name} {high} {self.high:g}"


EXPLICIT, IMPLICIT = "explicit", "implicit"  # the kinds of algorithm (Algorithm.explicit)


@dataclass(frozen=True)
class Scheme:
    """stiffness(V, mu, lmbda, parameters) -> K (an assembled PETSc matrix on the vector
    space V, no boundary conditions). `cells`: the cell shapes it takes; `parameters`: {name:
    Parameter}, numbers; `description`: one line for --help and reports.

    With a nonlinear model (SPEC 8): `nonlinear`, the kinds of algorithm (EXPLICIT, IMPLICIT)
    that run the scheme with one, () for the linear model only; `fbar`, whether its nonlinear
    form takes the cell's mean J (F-bar) instead of the plain deformation gradient.

    In figures: `colour`, a matplotlib colour, or one per cell shape; None: one of the
    figures' spare colours (schemes.colour_of)."""

    name: str
    stiffness: Callable[..., PETSc.Mat]
    cells: tuple[str, ...]
    parameters: dict[str, Parameter] = field(default_factory=dict)
    description: str = ""
    check: Callable[[dict], None] | None = None  # refuses values that do not go together
    nonlinear: tuple[str, ...] = ()
    fbar: bool = False
    colour: str | dict[str, str] | None = None

    def takes_nonlinear(self, explicit: bool) -> bool:
        """Whether an explicit (or implicit) algorithm runs the scheme with a nonlinear model."""
        return (EXPLICIT if explicit else IMPLICIT) in self.nonlinear


def deviator(eps: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """dev(eps) = eps - tr(eps)/d I in the mesh's d dimensions."""
    d = ufl.shape(eps)[0]
    return eps - ufl.tr(eps) / d * ufl.Identity(d)


def bulk_modulus(mu: float, lmbda: float, d: int) -> float:
    """lambda + 2 mu / d (Pa): the modulus of the volumetric energy when the deviator is taken
    in d dimensions (3D: the bulk modulus; 2D plane strain: lambda + mu)."""
    return lmbda + 2.0 * mu / d


def assemble(form: ufl.Form) -> PETSc.Mat:
    """The assembled PETSc matrix of a bilinear form."""
    A = dolfinx.fem.petsc.assemble_matrix(fem.form(form))
    A.assemble()
    return A


def _diagonal(form: ufl.Form) -> PETSc.Vec:
    """The owned entries of an assembled linear form (ghost contributions added)."""
    b = dolfinx.fem.petsc.assemble_vector(fem.form(form))
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
    out = PETSc.Vec().createMPI(
        (b.getLocalSize(), b.getSize()), bsize=b.getBlockSize(), comm=b.getComm()
    )
    out.array[:] = b.array_r[: b.getLocalSize()]
    b.destroy()
    return out


def projected_product(
    V: fem.FunctionSpace,
    Q: fem.FunctionSpace,
    op: Callable[[ufl.core.expr.Expr], ufl.core.expr.Expr],
    A: ufl.Form | None = None,
) -> PETSc.Mat:
    """P^T A P with P = D^-1 B the projection of op(u) onto Q by Q's lumped mass:
    B_qj = ∫ q : op(phi_j) dx, D_q = ∫ q : 1 dx (the cell's volume for a piecewise-constant Q,
    the node's share of the volume for P1), and A a bilinear form on Q (None: D, so that the
    product is B^T D^-1 B, the integral of (P u) : (P w)).

    On a piecewise-constant Q, P u is the cell's mean of op(u): its mean dilatation, or its mean
    gradient (Flanagan and Belytschko's uniform gradient, the gradient at the centre of a
    parallelogram or parallelepiped cell)."""
    u = ufl.TrialFunction(V)
    q = ufl.TestFunction(Q)
    B = assemble(ufl.inner(q, op(u)) * ufl.dx)
    ones = ufl.as_tensor(np.ones(Q.value_shape)) if Q.value_shape else 1.0
    D = _diagonal(ufl.inner(ones, q) * ufl.dx)
    D.reciprocal()
    if A is None:
        P = B.copy()
        P.diagonalScale(L=D)  # D^-1 B
        K = B.transposeMatMult(P)  # B^T D^-1 B
        P.destroy()
    else:
        B.diagonalScale(L=D)  # P = D^-1 B
        A_mat = assemble(A)
        K = A_mat.PtAP(B)
        A_mat.destroy()
    B.destroy()
    D.destroy()
    return K


def split_stiffness(
    V: fem.FunctionSpace, mu: float, lmbda: float, Q: fem.FunctionSpace
) -> PETSc.Mat:
    """∫ 2 mu dev eps(u) : dev eps(w) dx + kappa_d ∫ (P div u)(P div w) dx: the deviatoric part
    fully integrated, the volumetric part with the dilatation projected onto Q by its lumped
    mass (projected_product): each cell's mean on a piecewise-constant Q, each node's
    volume-weighted mean on P1. kappa_d = lambda + 2 mu / d."""
    d = V.mesh.geometry.dim
    u, w = ufl.TrialFunction(V), ufl.TestFunction(V)
    dev_u, dev_w = deviator(ufl.sym(ufl.grad(u))), deviator(ufl.sym(ufl.grad(w)))
    K_dev = assemble(2 * mu * ufl.inner(dev_u, dev_w) * ufl.dx)
    return add(K_dev, projected_product(V, Q, ufl.div), bulk_modulus(mu, lmbda, d))


def add(K: PETSc.Mat, other: PETSc.Mat, scale: float = 1.0) -> PETSc.Mat:
    """K += scale other in place, with the union of both patterns; frees other, returns K."""
    K.axpy(scale, other, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
    other.destroy()
    return K


def parse(text: str, schemes: dict[str, Scheme]) -> tuple[str, dict[str, float]]:
    """(name, parameters) of a scheme given as NAME or NAME:key=value,key=value; parameters
    not given take their defaults. Refuses (SchemeError) an unknown name, key, or a value
    outside its parameter's range (Parameter)."""
    name, _, rest = text.strip().partition(":")
    if name not in schemes:
        raise SchemeError(f"unknown scheme {name!r}: use one of {', '.join(schemes)}")
    scheme = schemes[name]
    values = {key: p.default for key, p in scheme.parameters.items()}
    for item in filter(None, (s.strip() for s in rest.split(","))):
        key, eq, value = item.partition("=")
        key = key.strip()
        if key not in scheme.parameters or not eq:
            known = ", ".join(scheme.parameters) or "none"
            raise SchemeError(f"scheme {name}: {item!r} is not KEY=VALUE with a key of {known}")
        try:
            number = float(value)
        except ValueError:
            number = float("nan")
        parameter = scheme.parameters[key]
        if not (np.isfinite(number) and parameter.holds(number)):
            raise SchemeError(
                f"scheme {name}: {key} ({parameter.meaning}) must be a number with "
                f"{parameter.range_text(key)}, got {value.strip()!r}"
            )
        values[key] = number
    if scheme.check is not None:
        scheme.check(values)
    return name, values


def label(name: str, parameters: dict[str, float], schemes: dict[str, Scheme]) -> str:
    """The canonical text of a scheme: NAME, with every parameter (key=value, in the scheme's
    order) where it has any."""
    keys = schemes[name].parameters
    if not keys:
        return name
    return name + ":" + ",".join(f"{k}={parameters[k]:g}" for k in keys)
