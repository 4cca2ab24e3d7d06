"""tissuebench.solvers: materials, the assembled system, and the five integrators.

An algorithm is one file here with `integrator(system, h, solver="direct")`, registered below.
"""

from tissuebench.solvers import explicit, explicit_lumped, implicit, implicit_lumped, quasi_static

ALGORITHMS = {
    "implicit": implicit.integrator,
    "implicit-lumped": implicit_lumped.integrator,
    "explicit": explicit.integrator,
    "explicit-lumped": explicit_lumped.integrator,
    "quasi-static": quasi_static.integrator,
}

REFERENCE = "implicit"


def get_integrator(name, system, h, solver="direct"):
    """The integrator `name` (see ALGORITHMS) for `system` with time step h (s)."""
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}: use one of {', '.join(ALGORITHMS)}")
    if not (isinstance(h, (int, float)) and h > 0):
        raise ValueError(f"time step must be > 0 s, got {h!r}")
    return ALGORITHMS[name](system, h, solver=solver)
