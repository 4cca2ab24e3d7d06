"""`penalty` (Picinbono et al.): P1 with the Lamé constants of a lowered Poisson ratio nu_p and
the material's E, plus per cell the energy (k/2) (V - V_0)^2 / V_0 against compression, whose
nodal forces point along the normals of the opposite faces (the gradient of the cell's volume).

Linearised (this is the linear model), V - V_0 = V_0 div u, so the penalty adds
(k/2) V_0 (div u)^2 per cell: the element is P1 with mu_p and lambda_p + k. k is given in units
of the material's bulk modulus kappa_d = lambda + 2 mu / d; k_restore = (kappa_d - kappa_p)/kappa_d
gives back the material's bulk modulus (and its locking), k = 0 the lowered ratio alone."""

from __future__ import annotations

from tissuebench.solvers.schemes import standard
from tissuebench.solvers.schemes.scheme import Parameter, Scheme, bulk_modulus

NU_P = 0.3  # the lowered Poisson ratio (Picinbono et al.)
K_PENALTY = 0.1  # default k, in units of the material's bulk modulus
K_MAX = 100.0  # k at most: a hundred times the material's own volumetric stiffness


def lowered(mu: float, lmbda: float, nu_p: float) -> tuple[float, float]:
    """(mu_p, lambda_p) in Pa: the Lamé constants of Young's modulus E = mu (3 lambda + 2 mu) /
    (lambda + mu) (that of (mu, lambda)) with Poisson ratio nu_p."""
    E = mu * (3 * lmbda + 2 * mu) / (lmbda + mu)
    return E / (2 * (1 + nu_p)), E * nu_p / ((1 + nu_p) * (1 - 2 * nu_p))


def restoring_k(mu: float, lmbda: float, nu_p: float, d: int) -> float:
    """The k (in units of the material's bulk modulus) that gives back its bulk modulus."""
    mu_p, lmbda_p = lowered(mu, lmbda, nu_p)
    kappa = bulk_modulus(mu, lmbda, d)
    return (kappa - bulk_modulus(mu_p, lmbda_p, d)) / kappa


def lame(mu: float, lmbda: float, parameters: dict, d: int) -> tuple[float, float]:
    """(mu, lambda) in Pa of the penalised element."""
    mu_p, lmbda_p = lowered(mu, lmbda, parameters["nu_p"])
    return mu_p, lmbda_p + parameters["k"] * bulk_modulus(mu, lmbda, d)


def stiffness(V, mu, lmbda, parameters):
    mu_k, lmbda_k = lame(mu, lmbda, parameters, V.mesh.geometry.dim)
    return standard.stiffness(V, mu_k, lmbda_k, {})


SCHEME = Scheme(
    "penalty",
    stiffness,
    cells=("triangle", "tetrahedron"),
    parameters={
        "nu_p": Parameter(NU_P, -1.0, 0.5, "the lowered Poisson ratio", open=(True, True)),
        "k": Parameter(
            K_PENALTY, 0.0, K_MAX, "volume penalty in units of the material's bulk modulus"
        ),
    },
    description="P1 with a lowered Poisson ratio and a volume penalty (Picinbono)",
    colour="tab:purple",
)
