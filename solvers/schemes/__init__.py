"""The discretisation schemes of SPEC section 11, beside the plain Q1/P1 element: remedies
against volumetric locking for nearly incompressible tissue.

A scheme is one file here with a `SCHEME` entry (solvers/schemes/scheme.py: its stiffness
K_0 and the cells it takes), registered below. The System assembles K with it; every algorithm
and the stability analysis then take it as they take Q1.
"""

from tissuebench.solvers.schemes import anp, hourglass, mean_dilatation, penalty, standard
from tissuebench.solvers.schemes.scheme import Scheme, SchemeError, label, parse

SCHEMES: dict[str, Scheme] = {
    "standard": standard.SCHEME,
    "mean-dilatation": mean_dilatation.SCHEME,
    "hourglass": hourglass.SCHEME,
    "anp": anp.SCHEME,
    "penalty": penalty.SCHEME,
}

STANDARD = "standard"

__all__ = ["SCHEMES", "STANDARD", "Scheme", "SchemeError", "parse_scheme", "scheme_label"]


def parse_scheme(text: str) -> tuple[str, dict[str, float]]:
    """(name, parameters) of NAME or NAME:key=value,... (SchemeError if bad)."""
    return parse(text, SCHEMES)


def scheme_label(text: str) -> str:
    """The canonical text of a scheme (every parameter spelt out)."""
    return label(*parse_scheme(text), SCHEMES)


def check_cells(text: str, cell: str) -> None:
    """Refuse a scheme on cells it does not take (SchemeError)."""
    name, _ = parse_scheme(text)
    cells = SCHEMES[name].cells
    if cell not in cells:
        raise SchemeError(f"scheme {name} takes {' or '.join(cells)} cells, not {cell} (--cell)")
