"""Kratos's nonlinear models for kratos.py: the rod (a 3D dynamic export of hexahedra) with the
neo-hookean or svk model of SPEC section 8, as a Kratos user poses large deformation.

- Elements: `TotalLagrangianElement3D8N` on our hexahedra (hex8) or `TotalLagrangianElement3D4N`
  on six tetrahedra per hexahedron (tet4), in place of the small-displacement ones.
- Laws (ConstitutiveLawsApplication), YOUNG_MODULUS and POISSON_RATIO the export's E, nu, so
  Kratos's lambda and mu are the SPEC's:
  - `svk`: `KirchhoffSaintVenant3DLaw`, S = lambda tr(E) I + 2 mu E: the SPEC's svk exactly.
  - `neo-hookean`: `HyperElastic3DLaw` (HyperElasticIsotropicNeoHookean3D), whose PK2 stress
    is S = lambda ln(J) C^-1 + mu (I - C^-1), the compressible ln J form
    psi = mu/2 (I1 - 3) - mu ln J + lambda/2 (ln J)^2. NOT the SPEC's
    psi = mu/2 (J^(-2/3) I1 - 3) + kappa/2 (J - 1)^2 (kappa = lambda + 2 mu/3): both equal the
    linear model to first order in the strain and have the same tangent at F = I; they
    differ from the third order on (Kratos's shear term is not isochoric, its volumetric
    energy is lambda/2 (ln J)^2, which grows without bound as J -> 0).
- Solve: `analysis_type` "non_linear" (ResidualBasedNewtonRaphsonStrategy, a fresh tangent
  and SparseLU factorisation every iteration, no line search), `residual_criterion` to
  NEWTON_RTOL of the step's first residual (the SPEC's 1e-10) or below our implicit's
  absolute floor (solvers/nonlinear.py ATOL_SCALE x the largest diagonal entry of K_0 x the
  extent, `newton_floor`), at most NEWTON_MAX_IT iterations; a step that does not converge
  stops the run (SPEC 8: a divergence).
- Damping: Kratos's `rayleigh_beta` multiplies the element's current tangent stiffness, not
  the SPEC's K_0 (SPEC 8: beta K_0 v for every model); left as Kratos does it.
- The TL elements read F from the current nodal coordinates: `move_mesh_flag` true.

Measured on the rod n = 2, s = 1.5, 150 steps, hex8-newmark against our implicit with the same
model (the tip's largest difference over its largest displacement;
tests/test_external_kratos_nonlinear.py): svk without stiffness damping 5e-11 (the posing is
exact); svk 0.053 (the damping of the current tangent alone); neo-hookean 0.012 without
stiffness damping (the ln J law alone), 0.041 with it; Kratos's linear run 0.156. The rod
n = 3, s = 1.5, T = 10 s (`tissuebench external kratos rod --models neo-hookean --load-scale
1.5`), E_n against implicit+neo-hookean: hex8 newmark and bossak 0.044 in 12-13 s, tet4 0.187
in 7 s (P1's stiffness); at s = 3, hex8-newmark 0.11 in 10 s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import given

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

# model -> (Kratos law in ConstitutiveLawsApplication, one line of how the SPEC's law maps)
LAWS = {
    "neo-hookean": (
        "HyperElastic3DLaw",
        "HyperElastic3DLaw, the ln J neo-Hookean psi = mu/2 (I1 - 3) - mu ln J + "
        "lambda/2 (ln J)^2 with the SPEC's lambda, mu: NOT the SPEC's mu/2 (J^(-2/3) I1 - 3) "
        "+ kappa/2 (J - 1)^2, equal to it to second order in the strain",
    ),
    "svk": (
        "KirchhoffSaintVenant3DLaw",
        "KirchhoffSaintVenant3DLaw, S = lambda tr(E) I + 2 mu E: the SPEC's svk exactly",
    ),
}
ELEMENTS = {"hex8": "TotalLagrangianElement3D8N", "tet4": "TotalLagrangianElement3D4N"}
NEWTON_RTOL = 1e-10  # SPEC 8
NEWTON_MAX_IT = 25


def variants(data: Exported, linear: dict[str, tuple]) -> dict[str, str]:
    """The variants of a 3D hexahedral dynamic export of a model in LAWS: kratos.py's
    consistent-mass hex8 and tet4 variants (`linear`: its VARIANTS) with the total Lagrangian
    element and the model's law, ending with the export's E and nu."""
    law = LAWS[data.model][1]
    solve = (
        f"Newton to {NEWTON_RTOL:g} x the step's first residual; Rayleigh beta times Kratos's "
        "current tangent, not K_0"
    )
    out = {}
    for name, (element, _, _, lumped, said) in linear.items():
        if element in ELEMENTS and not lumped:
            said = said.replace("SmallDisplacementElement", "TotalLagrangianElement")
            said = said.replace(": our implicit", "")
            out[name] = f"{said}; {solve}; {law}; YOUNG_MODULUS, POISSON_RATIO: the export's " + (
                given(data.material)
            )
    return out


def skipped(data: Exported, linear: dict[str, tuple]) -> dict[str, str]:
    """Why a variant of kratos.py does not pose an export of a model in LAWS."""
    from importlib import metadata

    try:
        metadata.version("KratosConstitutiveLawsApplication")
    except metadata.PackageNotFoundError:
        return {"all": f"Kratos's {data.model} law needs KratosConstitutiveLawsApplication: "
                "pip install 'tissuebench[kratos]'"}  # fmt: skip
    if data.cell_type != "hexahedron":
        return {"all": f"Kratos's {data.model} is posed on the rod's hexahedra only"}
    return {
        name: "lumped mass not posed with a nonlinear model here"
        for name, spec in linear.items()
        if spec[0] in ELEMENTS and spec[3]
    }


def newton_floor(nodes: np.ndarray, cells: np.ndarray, E: float, nu: float) -> float:
    """Our implicit's absolute Newton tolerance (N): solvers/nonlinear.py's ATOL_SCALE x the
    largest diagonal entry of the linear stiffness K_0 x the domain's extent (m), K_0's
    diagonal assembled here for Q1 hexahedra (2x2x2 Gauss) or P1 tetrahedra (nodes in m,
    E in Pa): K_aa,ii = integral of (lambda + mu) (dN_a/dx_i)^2 + mu |grad N_a|^2."""
    from tissuebench.solvers.nonlinear import ATOL_SCALE

    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    if cells.shape[1] == 8:  # VTK hexahedron corners on the reference cube [-1, 1]^3
        ref = np.array(
            [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
             [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float
        )  # fmt: skip
        g = 1 / np.sqrt(3)
        points = np.array([[a, b, c] for a in (-g, g) for b in (-g, g) for c in (-g, g)])
        weights = np.ones(8)
        # dN_a/dxi_k at each point: (points, 8, 3)
        grads = np.empty((8, 8, 3))
        for k in range(3):
            factors = [1 + ref[None, :, j] * points[:, j, None] for j in range(3)]
            factors[k] = ref[None, :, k] * np.ones((8, 1))
            grads[:, :, k] = factors[0] * factors[1] * factors[2] / 8
    else:  # P1 tetrahedra
        points, weights = np.zeros((1, 3)), np.array([1 / 6])
        grads = np.array([[[-1, -1, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]]], dtype=float)
    diagonal = np.zeros(nodes.shape)
    for q in range(len(points)):
        X = nodes[cells]  # (cells, corners, 3)
        jac = np.einsum("cai,ak->cik", X, grads[q])  # dx_i/dxi_k
        dN = np.einsum("ak,cki->cai", grads[q], np.linalg.inv(jac))  # dN_a/dx_i
        w = weights[q] * np.abs(np.linalg.det(jac))[:, None, None]
        entry = w * ((lam + mu) * dN**2 + mu * np.sum(dN**2, axis=2, keepdims=True))
        np.add.at(diagonal, cells, entry)
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))
    return ATOL_SCALE * float(diagonal.max()) * extent
