"""tissuebench.solvers: materials, the assembled system, and the five integrators.

An algorithm is one file here with an `ALGORITHM` entry (solvers/algorithm.py: its mass,
damping and Newmark parameters, and how to build its Integrator), registered below; the
stability analysis and the command-line choices derive from this table.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mpi4py import MPI  # noqa: F401 (loads libmpi before PETSc and DOLFINx do)

from tissuebench.solvers import explicit, explicit_lumped, implicit, implicit_lumped, quasi_static
from tissuebench.solvers.algorithm import Algorithm, Integrator
from tissuebench.solvers.models import MODELS, get_model

if TYPE_CHECKING:
    from tissuebench.solvers.system import System

ALGORITHMS: dict[str, Algorithm] = {
    "implicit": implicit.ALGORITHM,
    "implicit-lumped": implicit_lumped.ALGORITHM,
    "explicit": explicit.ALGORITHM,
    "explicit-lumped": explicit_lumped.ALGORITHM,
    "quasi-static": quasi_static.ALGORITHM,
}

REFERENCE = "implicit"

__all__ = ["ALGORITHMS", "MODELS", "REFERENCE", "get_integrator"]


def get_integrator(
    name: str, system: System, h: float, solver: str = "direct", model: str = "linear"
) -> Integrator:
    """The integrator `name` (see ALGORITHMS) for `system` with time step h (s) and the
    elastic model `model` (see MODELS; `linear` is the assembled K of SPEC sections 1-7). A
    benchmark with contact (SPEC 12) runs every model, linear included, through the nonlinear
    integrators, with the penalty's force beside f_int."""
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}: use one of {', '.join(ALGORITHMS)}")
    if not (isinstance(h, (int, float)) and h > 0):
        raise ValueError(f"time step h must be > 0 s, got {h!r}")
    elastic = get_model(model)
    contact = system.benchmark.contact is not None
    if elastic.linear and not contact:
        return ALGORITHMS[name].build(system, h, solver=solver)
    from tissuebench.solvers.schemes import STANDARD, SchemeError, nonlinear_forms, scheme_of

    scheme = scheme_of(system)
    if contact and scheme.name != STANDARD:
        raise SchemeError(f"scheme {scheme.name} with contact: contact takes the standard element")
    if not scheme.takes_nonlinear(ALGORITHMS[name].explicit):
        raise SchemeError(
            f"scheme {scheme.name} with the model {model!r} and {name}: only "
            f"{nonlinear_forms()} (F-bar's J_bar is not differentiated, so Newton would have no "
            "exact tangent)"
        )
    if system.gdim == 2 and system.plane != "strain":
        raise ValueError(f"model {model!r} is plane strain only in 2D (SPEC 8), not plane stress")
    from tissuebench.solvers import nonlinear

    prefix = name.replace("-", "_") + "_"
    return nonlinear.integrator(ALGORITHMS[name], system, h, elastic, prefix, solver)
