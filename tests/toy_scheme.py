"""A toy discretisation scheme, defined here alone (issue 41: plug-ins state their capabilities):
`stiffened`, the standard element's stiffness K_0 multiplied by its own parameter `factor`
(default 1, so that at its defaults it is the standard element under another name), on every
cell shape the standard element takes. It states no colour (figures give it a spare one) and
no nonlinear form (the linear model only): everything the commands know of it is in its
SCHEME.

`registered()` adds it to solvers.schemes.SCHEMES for as long as the context lasts."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from mpi4py import MPI  # noqa: F401 (loads libmpi before PETSc does)
from petsc4py import PETSc

from tissuebench.solvers.schemes import SCHEMES, standard
from tissuebench.solvers.schemes.scheme import Parameter, Scheme

NAME = "stiffened"


def stiffness(V, mu: float, lmbda: float, parameters: dict[str, float]) -> PETSc.Mat:
    """factor x the standard element's K_0 (N/m)."""
    K = standard.stiffness(V, mu, lmbda, {})
    K.scale(parameters["factor"])
    return K


SCHEME = Scheme(
    NAME,
    stiffness,
    cells=standard.SCHEME.cells,
    parameters={"factor": Parameter(1.0, 0.5, 4.0, "the standard element's stiffness times")},
    description="a toy: the standard element's stiffness scaled",
)


@contextlib.contextmanager
def registered() -> Iterator[Scheme]:
    """SCHEMES with the toy in it, for as long as the context lasts."""
    assert NAME not in SCHEMES
    SCHEMES[NAME] = SCHEME
    try:
        yield SCHEME
    finally:
        del SCHEMES[NAME]
