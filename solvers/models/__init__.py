"""The elastic models of SPEC section 8, the second axis beside the algorithms.

A model is one file here with a `MODEL` entry (solvers/models/model.py: its first Piola
stress P(F) as a UFL expression, and the same P(F) as a C snippet for the explicit schemes'
compiled element loop, solvers/compiled_forces.py), registered below. Every algorithm runs
with every model; `linear` keeps the assembled K of sections 1-7.
"""

from tissuebench.solvers.models import corotational, linear, neo_hookean, neo_hookean_barrier, svk
from tissuebench.solvers.models.model import Model

MODELS: dict[str, Model] = {
    "linear": linear.MODEL,
    "svk": svk.MODEL,
    "neo-hookean": neo_hookean.MODEL,
    "neo-hookean-barrier": neo_hookean_barrier.MODEL,
    "corotational": corotational.MODEL,
}

LINEAR = "linear"
# SPEC 8: the reference model at the paper's loads (the large cases take neo-hookean-barrier)
REFERENCE_MODEL = "neo-hookean"


def run_label(algorithm: str, model: str) -> str:
    """A run's name (SPEC section 8): the algorithm for the linear model, ALGORITHM+MODEL else."""
    return algorithm if model == LINEAR else f"{algorithm}+{model}"


def split_label(label: str) -> tuple[str, str]:
    """(algorithm, model) of a run's name."""
    algorithm, _, model = label.partition("+")
    return algorithm, model or LINEAR


def get_model(name: str) -> Model:
    if name not in MODELS:
        raise ValueError(f"unknown model {name!r}: use one of {', '.join(MODELS)}")
    return MODELS[name]
