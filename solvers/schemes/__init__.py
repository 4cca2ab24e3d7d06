"""The discretisation schemes of SPEC section 11, beside the plain Q1/P1 element: remedies
against volumetric locking for nearly incompressible tissue.

A scheme is one file here with a `SCHEME` entry (solvers/schemes/scheme.py: its stiffness
K_0, the cells it takes, its parameters, the algorithms that run it with a nonlinear model and
its colour in figures), registered below. The System assembles K with it; every algorithm
and the stability analysis then take it as they take Q1.
"""

from tissuebench.solvers.schemes import anp, hourglass, mean_dilatation, penalty, standard
from tissuebench.solvers.schemes.scheme import EXPLICIT, IMPLICIT, Scheme, SchemeError, label, parse

SCHEMES: dict[str, Scheme] = {
    "standard": standard.SCHEME,
    "mean-dilatation": mean_dilatation.SCHEME,
    "hourglass": hourglass.SCHEME,
    "anp": anp.SCHEME,
    "penalty": penalty.SCHEME,
}

STANDARD = "standard"
# the colours of the schemes that state none (Scheme.colour), in their order in SCHEMES
SPARE_COLOURS = ("tab:brown", "tab:pink", "tab:cyan", "tab:gray")

__all__ = [
    "EXPLICIT",
    "IMPLICIT",
    "SCHEMES",
    "STANDARD",
    "Scheme",
    "SchemeError",
    "colour_of",
    "nonlinear_forms",
    "parse_scheme",
    "scheme_label",
    "scheme_of",
]


def parse_scheme(text: str) -> tuple[str, dict[str, float]]:
    """(name, parameters) of NAME or NAME:key=value,... (SchemeError if bad)."""
    return parse(text, SCHEMES)


def scheme_label(text: str) -> str:
    """The canonical text of a scheme (every parameter spelt out)."""
    return label(*parse_scheme(text), SCHEMES)


def check_cells(name: str, cell: str) -> None:
    """Refuse a scheme (its name, as parse_scheme gives it) on cells it does not take
    (SchemeError)."""
    cells = SCHEMES[name].cells
    if cell not in cells:
        raise SchemeError(f"scheme {name} takes {' or '.join(cells)} cells, not {cell} (--cell)")


def scheme_of(system: object) -> Scheme:
    """The Scheme of a System (its `scheme` text; the standard element where it has none, as
    the bare namespaces some tests hand the models)."""
    text = getattr(system, "scheme", STANDARD)
    return SCHEMES[text.partition(":")[0].strip()]


def nonlinear_forms() -> str:
    """The schemes beside the standard element that run a nonlinear model, in words: "mean-
    dilatation has a nonlinear form, F-bar, for the explicit algorithms"."""
    said = [
        f"{name} has a nonlinear form{', F-bar,' if s.fbar else ''} for the "
        f"{' and '.join(s.nonlinear)} algorithms"
        for name, s in SCHEMES.items()
        if name != STANDARD and s.nonlinear
    ]
    return "; ".join(said) or "the standard element has a nonlinear form"


def colour_of(name: str, cell: str) -> str:
    """The matplotlib colour figures draw a scheme with on a cell shape: its own (Scheme.colour),
    else a spare one (SPARE_COLOURS, by its place among the schemes that state none; the last
    for a name not registered)."""
    scheme = SCHEMES.get(name)
    colour = scheme.colour if scheme is not None else None
    if isinstance(colour, dict):
        colour = colour.get(cell)
    if colour:
        return colour
    bare = [n for n, s in SCHEMES.items() if not s.colour]
    place = bare.index(name) if name in bare else len(SPARE_COLOURS) - 1
    return SPARE_COLOURS[place % len(SPARE_COLOURS)]
