"""SfePy's nonlinear models for sfepy.py: the rod (a 3D dynamic export) with the neo-hookean
or svk model of SPEC section 8, by SfePy's implicit steppers only (ts.newmark,
ts.generalized_alpha, ts.bathe; an explicit stepper is not posed with them here).

SfePy's total Lagrangian hyperelastic terms in place of `dw_lin_elastic`, each the SPEC's
energy exactly (`NONLINEAR`): `neo-hookean` as `dw_tl_he_neohook` (mu) plus
`dw_tl_bulk_penalty` (K = kappa = lambda + 2 mu / 3), that is
psi = mu/2 (J^(-2/3) I1 - 3) + K/2 (J - 1)^2; `svk` as `dw_tl_he_svk` with the isotropic D of
lambda and mu. Stiffness damping stays beta K_0 v (`dw_lin_elastic` of beta D, SPEC 8). Each
step is solved by SfePy's Newton (backtracking line search, a fresh tangent and SuperLU
factorisation every iteration) to 1e-10 times the step's first residual, the SPEC's
tolerance, or below our implicit's absolute floor (`newton_floor`; without it a step whose
first residual is small stalls above 1e-10 of it: measured, the rod n = 3 at t = 7.8 s). A
step whose Newton does not converge stops the run (SPEC 8), and so does an inverted element
(SfePy's TL terms refuse J < 0, "warp violation": its line search backs off from such an
iterate; a step that cannot avoid it fails the run, NaN there). Measured on the rod n = 2,
s = 1.5, 150 steps: ts.newmark is our implicit+neo-hookean to Newton tolerance (tip 3e-13 of its
largest displacement; svk 1e-13), ts.bathe 4e-5, ts.generalized_alpha 5e-5, and SfePy's
linear run departs by 0.16 (tests/test_external_sfepy_nonlinear.py). The rod n = 3, s = 1.5,
T = 10 s (`tissuebench external sfepy rod --models neo-hookean --load-scale 1.5`): newmark
E_n 1.7e-13 against implicit+neo-hookean in 14 s (28 s on a loaded machine), generalized-alpha
0.012 in 20 s, bathe (two Newton solves a step) 0.011 in 73 s, both on the loaded machine.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tissuebench.workflows.simulators import given

if TYPE_CHECKING:
    from tissuebench.workflows.io.exported import Exported

# nonlinear model -> (SfePy's elastic terms, one line of how the SPEC's law maps onto them)
NONLINEAR: dict[str, tuple[tuple[str, ...], str]] = {
    "neo-hookean": (
        ("dw_tl_he_neohook(solid.mu, v, u)", "dw_tl_bulk_penalty(solid.K, v, u)"),
        "total Lagrangian dw_tl_he_neohook (mu) + dw_tl_bulk_penalty (K = lambda + 2 mu/3): "
        "psi = mu/2 (J^(-2/3) I1 - 3) + K/2 (J - 1)^2, the SPEC's neo-hookean exactly",
    ),
    "svk": (
        ("dw_tl_he_svk(solid.D, v, u)",),
        "total Lagrangian dw_tl_he_svk, S = D E with D the isotropic stiffness of lambda, mu: "
        "the SPEC's svk exactly",
    ),
}
# the steppers posed with a nonlinear model: SfePy's implicit ones
IMPLICIT = ("newmark", "generalized-alpha", "bathe")
NEWTON_RTOL = 1e-10  # SPEC 8: Newton to a relative residual of 1e-10
NEWTON_MAX_IT = 25


def variants(data: Exported, steppers: dict[str, str]) -> dict[str, str]:
    """The nonlinear variants of a 3D dynamic export of a model in NONLINEAR: each implicit
    stepper (name -> its line in `steppers`, sfepy.py's VARIANTS) with the Newton loop, the
    damping and the law's mapping, ending with the export's E and nu as lambda and mu."""
    law = NONLINEAR[data.model][1]
    solve = (
        f"Newton to {NEWTON_RTOL:g} x the step's first residual; stiffness damping "
        "beta K_0 v, K_0 the linear stiffness (SPEC 8)"
    )
    elastic = f"{law}; lambda, mu of the export's {given(data.material)}"
    return {name: f"{steppers[name]}; {solve}; {elastic}" for name in IMPLICIT}


def skipped(data: Exported, steppers: list[str]) -> dict[str, str]:
    """What a dynamic export of a model in NONLINEAR leaves out: a 2D mesh altogether, else
    the explicit steppers."""
    if data.dim != 3:
        return {"all": f"SfePy's {data.model} is posed on 3D meshes only (not plane strain)"}
    why = f"an explicit SfePy stepper is not posed with the {data.model} model here"
    return {name: why for name in steppers if name not in IMPLICIT}


def newton_floor(problem, integral) -> float:
    """The residual (N) below which round-off, not Newton, decides: our implicit's absolute
    tolerance (solvers/nonlinear.py, ATOL_SCALE x the largest diagonal entry of the linear
    stiffness K_0 x the domain's extent), K_0 assembled by SfePy on the free dofs."""
    from sfepy.discrete import Integrals

    from tissuebench.solvers.nonlinear import ATOL_SCALE

    K0 = problem.evaluate(
        "dw_lin_elastic.i.Omega(solid.D, v, u)",
        mode="weak",
        dw_mode="matrix",
        copy_materials=False,
        integrals=Integrals([integral]),
    )
    nodes = problem.domain.mesh.coors
    extent = float(np.max(nodes.max(axis=0) - nodes.min(axis=0)))  # m
    return ATOL_SCALE * float(K0.diagonal().max()) * extent


def newton_options(problem, integral) -> dict:
    """SfePy Newton's options: to NEWTON_RTOL x the step's first residual or below
    newton_floor (eps_mode "or"), at most NEWTON_MAX_IT iterations."""
    return {
        "i_max": NEWTON_MAX_IT,
        "eps_a": newton_floor(problem, integral),
        "eps_r": NEWTON_RTOL,
        "eps_mode": "or",
    }
