"""Issue 33: `neo-hookean-barrier` (SPEC 8) against independent physics. Its first Piola
stress as our solver assembles it equals a numpy evaluation of the closed form at a random F
(2D plane strain and 3D); it agrees with `neo-hookean` to second order in J - 1 (the energies
differ by O((J - 1)^3), the stresses by O((J - 1)^2), with the leading coefficients of the
Taylor series of the two volumetric energies); and its energy grows without bound as J -> 0
while neo-Hookean's stays below kappa/2 per unit volume."""

from types import SimpleNamespace

from mpi4py import MPI

import dolfinx.mesh
import numpy as np
import pytest
import ufl
from dolfinx import fem
from dolfinx.mesh import CellType

from tissuebench.solvers.elastic import QUADRATURE_DEGREE, ElasticForces
from tissuebench.solvers.models import MODELS, neo_hookean, neo_hookean_barrier

MU, LMBDA = 1000.0, 3000.0  # Pa
KAPPA = LMBDA + 2 * MU / 3  # Pa
comm = MPI.COMM_SELF  # one cell: every rank evaluates its own


def numpy_piola(F: np.ndarray) -> np.ndarray:
    """P (Pa) of psi = (mu/2)(J^(-2/3) I1 - 3) + (kappa/4)(J^2 - 1 - 2 ln J), derived by
    hand: P = mu J^(-2/3) (F - (I1/3) F^-T) + (kappa/2)(J^2 - 1) F^-T; a 2D F is the
    upper-left block of the 3D F with F33 = 1 (plane strain), and so is its P."""
    d = F.shape[0]
    F3 = np.eye(3)
    F3[:d, :d] = F
    J, I1 = np.linalg.det(F3), np.trace(F3.T @ F3)
    Finv_T = np.linalg.inv(F3).T
    P = MU * J ** (-2 / 3) * (F3 - I1 / 3 * Finv_T) + KAPPA / 2 * (J**2 - 1) * Finv_T
    return P[:d, :d]


def unit_cell(d: int) -> SimpleNamespace:
    """The unit square (cube) as one Q1 cell, with what ElasticForces reads of a System."""
    if d == 2:
        mesh = dolfinx.mesh.create_unit_square(comm, 1, 1, CellType.quadrilateral)
    else:
        mesh = dolfinx.mesh.create_unit_cube(comm, 1, 1, 1, CellType.hexahedron)
    V = fem.functionspace(mesh, ("Lagrange", 1, (d,)))
    return SimpleNamespace(
        mesh=mesh, V=V, gdim=d, mu=MU, lmbda=LMBDA, rho=1000.0, comm=comm,
        constrained_nodes=np.array([], dtype=np.int32),
    )  # fmt: skip


def solver_piola(cell: SimpleNamespace, model: str, F: np.ndarray) -> np.ndarray:
    """P (Pa) as our solver assembles it: f_int of the affine u = (F - I) X on the unit cell,
    whose node a gets P g_a with g_a = integral of grad N_a = (2 X_a - 1) / 2^(d - 1) (Q1:
    each other direction's hat integrates to 1/2), solved for P by least squares."""
    d = cell.gdim
    X = cell.V.tabulate_dof_coordinates()[:, :d]
    forces = ElasticForces(cell, MODELS[model])
    u = forces._b.duplicate()
    u.array[:] = (X @ (F - np.eye(d)).T).ravel()
    f = forces._b.duplicate()
    forces.internal_force(u, f)
    forces.destroy()
    G = (2 * X - 1) / 2 ** (d - 1)
    Pt, *_ = np.linalg.lstsq(G, f.array.reshape(-1, d), rcond=None)
    return Pt.T


def energies(cell: SimpleNamespace, F: np.ndarray) -> tuple[float, float]:
    """(psi of neo-hookean, psi of neo-hookean-barrier) in J/m^3 at F, as our models define
    them: their strain energies integrated over the unit cell at u = (F - I) X."""
    d = cell.gdim
    u = fem.Function(cell.V)
    u.interpolate(lambda x: (F - np.eye(d)) @ x[:d])
    Fu = ufl.Identity(d) + ufl.grad(u)
    dx = ufl.dx(metadata={"quadrature_degree": QUADRATURE_DEGREE})
    return tuple(
        fem.assemble_scalar(fem.form(m.strain_energy(Fu, MU, LMBDA) * dx))
        for m in (neo_hookean, neo_hookean_barrier)
    )


@pytest.mark.parametrize("d", [2, 3])
def test_solver_stress_equals_the_closed_form(d):
    """At a random F (det F > 0; stretch, shear and rotation all present) the solver's P
    equals the numpy closed form to 1e-10 relative."""
    rng = np.random.default_rng(33)
    F = np.eye(d) + 0.3 * rng.standard_normal((d, d))
    assert np.linalg.det(F) > 0.2
    expected = numpy_piola(F)
    got = solver_piola(unit_cell(d), "neo-hookean-barrier", F)
    assert np.linalg.norm(got - expected) <= 1e-10 * np.linalg.norm(expected)


@pytest.mark.parametrize("d", [2, 3])
def test_agrees_with_neo_hookean_to_second_order_in_J_minus_1(d):
    """F = I + e A (A fixed, tr A != 0, so J - 1 ~ e tr A) at e = 1e-2, 5e-3, 2.5e-3: the
    isochoric parts are the same, and the volumetric energies differ by
    kappa [(J^2 - 1 - 2 ln J)/4 - (J - 1)^2/2] = -kappa (J - 1)^3 / 6 + O((J - 1)^4), their
    stresses by -kappa (J - 1)^2 / 2 J F^-T. Observed orders: 3 for psi, 2 for P (within
    0.1), and the leading coefficients within 5 %."""
    A = np.array([[0.8, 0.3, -0.2], [0.1, 0.5, 0.4], [-0.3, 0.2, 0.6]])[:d, :d]
    cell = unit_cell(d)
    dpsi, dP, x = [], [], []
    for e in (1e-2, 5e-3, 2.5e-3):
        F = np.eye(d) + e * A
        psi_nh, psi_b = energies(cell, F)
        P_nh = solver_piola(cell, "neo-hookean", F)
        P_b = solver_piola(cell, "neo-hookean-barrier", F)
        dpsi.append(abs(psi_b - psi_nh))
        dP.append(np.linalg.norm(P_b - P_nh))
        x.append(np.linalg.det(F) - 1)
        J_F_T = np.linalg.det(F) * np.linalg.inv(F).T
        assert psi_b - psi_nh == pytest.approx(-KAPPA * x[-1] ** 3 / 6, rel=0.05)
        assert dP[-1] == pytest.approx(KAPPA * x[-1] ** 2 / 2 * np.linalg.norm(J_F_T), rel=0.05)
    for values, order in ((dpsi, 3), (dP, 2)):
        observed = np.log2(np.array(values[:-1]) / np.array(values[1:]))
        assert np.all(np.abs(observed - order) < 0.1), (order, observed)


def test_barrier_energy_grows_without_bound_as_J_goes_to_0():
    """Pure dilation F = J^(1/3) I (no isochoric energy): neo-Hookean's psi is
    (kappa/2)(J - 1)^2 < kappa/2 for every J in (0, 1], the barrier's (kappa/4)(J^2 - 1 -
    2 ln J), which gains (kappa/2) ln 10 per decade of J: both as our models compute them,
    to 1e-10 relative."""
    cell = unit_cell(3)
    barrier = []
    for J in (1e-1, 1e-3, 1e-6, 1e-9):
        psi_nh, psi_b = energies(cell, J ** (1 / 3) * np.eye(3))
        assert psi_nh == pytest.approx(KAPPA / 2 * (J - 1) ** 2, rel=1e-10)
        assert psi_nh < KAPPA / 2
        assert psi_b == pytest.approx(KAPPA / 4 * (J**2 - 1 - 2 * np.log(J)), rel=1e-10)
        barrier.append(psi_b)
    assert barrier[-1] > 10 * KAPPA  # 20 times neo-Hookean's bound at J = 1e-9
    per_decade = np.diff(barrier)[1:] / 3  # 1e-3 -> 1e-6 -> 1e-9: three decades each
    assert per_decade == pytest.approx(KAPPA / 2 * np.log(10), rel=1e-6)


def test_the_export_states_the_law_and_the_calculix_deck_refuses_the_barrier():
    """Every model's law is in the export (`model_law`); the barrier's names its volumetric
    energy and that CalculiX's NEO HOOKE is the other law, and a CalculiX deck of it is
    refused in one line that says what to export instead."""
    from tissuebench.workflows.io.calculix import check_inp_model
    from tissuebench.workflows.io.exported import MODEL_LAWS, ExportError, model_law

    assert set(MODEL_LAWS) == set(MODELS)
    law = model_law("neo-hookean-barrier")
    assert "(kappa/4)(J^2 - 1 - 2 ln J)" in law and "Not CalculiX's NEO HOOKE" in law
    assert "(kappa/2)(J - 1)^2" in model_law("neo-hookean")
    with pytest.raises(ExportError) as refused:
        check_inp_model("neo-hookean-barrier")
    assert "\n" not in str(refused.value) and "--models neo-hookean" in str(refused.value)
    check_inp_model("neo-hookean")  # NEO HOOKE: written
