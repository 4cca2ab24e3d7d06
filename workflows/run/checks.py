"""The checks of the values that pose a run (bad values raise UserError): the numbers, the
algorithms and models named, the common options' solver and PETSc options, a benchmark's own
options, and a benchmark posed as `export` and `external` pose it (Posed). The commands
(workflows/commands/) and the Python API (workflows/api.py) both check with these; the
options themselves are added by commands/arguments.py, which nothing but the commands
imports."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, NamedTuple

from tissuebench.core.errors import UserError
from tissuebench.meshes.benchmark import Entry, shape_options
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.linear import SOLVERS
from tissuebench.solvers.options import check_petsc_options

if TYPE_CHECKING:
    from tissuebench.solvers.materials import Material


def positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise UserError(f"expected a positive number of seconds, got {text!r}")
    return value


def parse_algorithms(text: str) -> list[str]:
    names = [a.strip() for a in text.split(",") if a.strip()]
    unknown = [a for a in names if a not in ALGORITHMS]
    if unknown or not names:
        raise UserError(
            f"unknown algorithm(s) {', '.join(unknown) or '(none given)'}: use "
            f"{', '.join(ALGORITHMS)}"
        )
    return names


def parse_models(text: str) -> list[str]:
    names = list(dict.fromkeys(m.strip() for m in text.split(",") if m.strip()))
    unknown = [m for m in names if m not in MODELS]
    if unknown or not names:
        raise UserError(
            f"unknown model(s) {', '.join(unknown) or '(none given)'}: use {', '.join(MODELS)}"
        )
    return names


def check_models_plane(models: list[str], plane: str | None, gdim: int) -> None:
    """SPEC section 8: in 2D the nonlinear models are plane strain only."""
    nonlinear = [m for m in models if not MODELS[m].linear]
    if gdim == 2 and plane == "stress" and nonlinear:
        raise UserError(
            f"--plane stress applies to the linear model only; {', '.join(nonlinear)} "
            "are plane strain in 2D (SPEC 8)"
        )


def check_common(args: argparse.Namespace) -> None:
    if args.solver not in SOLVERS:
        raise UserError(f"unknown solver {args.solver!r}: use one of {', '.join(SOLVERS)}")
    # argparse takes "--petsc=--" for its end-of-options marker and leaves a list
    petsc = args.petsc if isinstance(args.petsc, str) else "--"
    args.petsc = petsc
    if petsc.strip():
        check_petsc_options(petsc, args.solver)


def benchmark_options(
    args: argparse.Namespace, benchmark: str, benchmarks: dict[str, Entry]
) -> dict:
    """The benchmark's own options given on the command line, with --cell and --mesh when
    they are not the defaults; refuse those it does not take, and --plane for a benchmark
    that is not 2D."""
    entry = benchmarks[benchmark]
    every = {option for e in benchmarks.values() for option in e.options}
    options = shape_options(entry.gdim, getattr(args, "cell", None), getattr(args, "mesh", None))
    for option in sorted(every):
        value = getattr(args, option, None)
        if value is None:
            continue
        if option not in entry.options:
            raise UserError(f"--{option.replace('_', '-')} does not apply to {benchmark}")
        options[option] = value
    if getattr(args, "plane", None) is not None and entry.gdim != 2:
        raise UserError(f"--plane applies to 2D benchmarks only, not to {benchmark}")
    return options


class Posed(NamedTuple):
    """A benchmark posed by the command line (export, external): what an export holds."""

    benchmark: str
    mesh_size: int
    options: dict
    material: Material
    model: str
    h: float  # s
    end_time: float  # s
    steps: int
    plane: str


def posed(args: argparse.Namespace, benchmarks: dict[str, Entry]) -> Posed:
    """The benchmark that add_posed_options' options pose; bad values raise UserError."""
    from tissuebench.meshes import get_entry
    from tissuebench.meshes.gmshio import check_positive_int
    from tissuebench.solvers.materials import get_material
    from tissuebench.workflows.io.limits import step_count

    entry = get_entry(args.benchmark)
    options = benchmark_options(args, args.benchmark, benchmarks)
    if "cell" in options or "mesh" in options:
        raise UserError(
            "--cell and --mesh do not apply here: an export, and the outside simulators' input, "
            "is our structured grid of quadrilaterals or hexahedra (grade a run on other cells "
            "with `tissuebench compare`)"
        )
    models = parse_models(args.models)
    if len(models) != 1:
        raise UserError(f"--models: one model at a time here, got {', '.join(models)}")
    check_models_plane(models, args.plane, entry.gdim)
    mesh_size = entry.mesh_size if args.mesh_size is None else args.mesh_size
    check_positive_int("mesh size", mesh_size)
    h = positive(args.dt) if args.dt is not None else entry.dt
    end_time = positive(args.end_time) if args.end_time is not None else entry.end_time
    return Posed(
        args.benchmark,
        mesh_size,
        options,
        get_material(args.material or entry.material),
        models[0],
        h,
        end_time,
        step_count(h, end_time),
        args.plane or "strain",
    )
