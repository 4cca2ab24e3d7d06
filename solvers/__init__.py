"""tissuebench.solvers: materials, the assembled system, and the five integrators.

An algorithm is one file here with an `ALGORITHM` entry (solvers/algorithm.py: its mass,
damping and Newmark parameters, and how to build its Integrator), registered below; the
stability analysis and the command-line choices derive from this table.
"""

from tissuebench.solvers import explicit, explicit_lumped, implicit, implicit_lumped, quasi_static
from tissuebench.solvers.algorithm import Algorithm, Integrator

ALGORITHMS: dict[str, Algorithm] = {
    "implicit": implicit.ALGORITHM,
    "implicit-lumped": implicit_lumped.ALGORITHM,
    "explicit": explicit.ALGORITHM,
    "explicit-lumped": explicit_lumped.ALGORITHM,
    "quasi-static": quasi_static.ALGORITHM,
}

REFERENCE = "implicit"


def get_integrator(name: str, system, h: float, solver: str = "direct") -> Integrator:
    """The integrator `name` (see ALGORITHMS) for `system` with time step h (s)."""
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}: use one of {', '.join(ALGORITHMS)}")
    if not (isinstance(h, (int, float)) and h > 0):
        raise ValueError(f"time step h must be > 0 s, got {h!r}")
    return ALGORITHMS[name].build(system, h, solver=solver)
