"""Command-line options that several commands share, and their checks (bad values raise
UserError). Commands import these; no command imports another command."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, NamedTuple

from tissuebench.core.errors import UserError
from tissuebench.meshes.benchmark import CELLS, MESHES, Entry, shape_options
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.linear import SOLVERS
from tissuebench.solvers.models import LINEAR
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


def truth_case(text: str, all_too: bool = False) -> str:
    """A SPEC 10 truth case named on the command line (or "all" where `all_too`), checked as
    the arguments are parsed: a name the command would refuse is refused there, in one line."""
    from tissuebench.solvers.truth.store import check_case

    if all_too and text == "all":
        return text
    try:
        check_case(text)
    except UserError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return text


def add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--solver", default="direct", help=f"linear solver: {', '.join(SOLVERS)} (default direct)"
    )
    p.add_argument(
        "--petsc",
        default="",
        metavar="OPTIONS",
        help=(
            'PETSc options, prefixed per integrator, e.g. "-implicit_ksp_type cg '
            '-implicit_pc_type gamg"'
        ),
    )
    p.add_argument(
        "--force",
        action="store_true",
        help=(
            "rerun and replace results that tissuebench wrote, even complete ones or ones of "
            "other inputs"
        ),
    )


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


def add_shape_options(p: argparse.ArgumentParser) -> None:
    """--cell and --mesh (SPEC 9): the element shape and the kind of mesh."""
    p.add_argument(
        "--cell",
        choices=sorted({c for cells in CELLS.values() for c in cells}),
        help="element shape: quadrilateral (default) or triangle in 2D, hexahedron (default) "
        "or tetrahedron in 3D; P1 elements on simplices (SPEC 9)",
    )
    p.add_argument(
        "--mesh",
        choices=list(MESHES),
        help="structured: the grid, simplices splitting its cells (default); unstructured: "
        "gmsh's Frontal-Delaunay simplices at the grid's spacing",
    )


# what --mesh-size is on each benchmark: its letter, the grid's cells per axis as multiples of
# it, and what else it must be (the meshes' own docstrings; mesh_size_help)
GRIDS = {
    "block": ("N", (1, 1), "quadrilaterals", "N even: the needle's end on a node"),
    "rod": ("n", (2, 1, 1), "hexahedra", ""),
    "contact": ("N", (1, 1), "quadrilaterals", "N even"),
}


def mesh_size_help(benchmarks: dict[str, Entry]) -> str:
    """--mesh-size's help: on each benchmark what its size gives (the grid's cells, their
    size in m, its default), and the simplices' meshes."""
    said = []
    for name, e in benchmarks.items():
        if name not in GRIDS:
            said.append(f"{name}: {e.mesh_size} by default")
            continue
        letter, counts, cells, rule = GRIDS[name]
        grid = " x ".join(f"{k if k > 1 else ''}{letter}" for k in counts)
        size = f"{e.cell_size(1):g}/{letter} m"
        said.append(
            f"{name}: {grid} {cells} of {size}{'; ' + rule if rule else ''} "
            f"(default {letter} = {e.mesh_size})"
        )
    return (
        f"the mesh's size, per benchmark: {'; '.join(said)}. With --cell triangle or "
        "tetrahedron each cell is split into simplices (--mesh structured) or gmsh meshes the "
        "body at that spacing (unstructured)"
    )


def add_benchmark_options(p: argparse.ArgumentParser, benchmarks: dict[str, Entry]) -> None:
    """--mesh-size, --cell, --mesh, and every benchmark's own options (numbers) as --name,
    from the registry."""
    p.add_argument("--mesh-size", type=int, help=mesh_size_help(benchmarks))
    add_shape_options(p)
    takers: dict[str, list[str]] = {}
    helps: dict[str, str] = {}
    for name, entry in benchmarks.items():
        for option, text in entry.options.items():
            takers.setdefault(option, []).append(name)
            helps[option] = text
    for option, names in takers.items():
        p.add_argument(
            f"--{option.replace('_', '-')}",
            type=float,
            dest=option,
            help=f"{' and '.join(names)} only: {helps[option]}",
        )


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


def add_posed_options(p: argparse.ArgumentParser, benchmarks: dict[str, Entry]) -> None:
    """The options that pose a benchmark as `run` does, with one elastic model."""
    p.add_argument("--material", help="MP1, MP2, MP3 or a .toml file (default: the benchmark's)")
    p.add_argument("--dt", type=str, help="time step h in s (default 1/30)")
    p.add_argument("--end-time", type=str, help="end time T in s (default 10)")
    p.add_argument("--models", default="linear", help="one elastic model (default linear)")
    add_benchmark_options(p, benchmarks)
    p.add_argument(
        "--plane",
        choices=["strain", "stress"],
        help="2D benchmarks only: plane strain (default) or stress",
    )


def posed(args: argparse.Namespace, benchmarks: dict[str, Entry]) -> Posed:
    """The benchmark that add_posed_options' options pose; bad values raise UserError."""
    from tissuebench.meshes import get_entry
    from tissuebench.meshes.gmshio import check_positive_int
    from tissuebench.solvers.materials import get_material
    from tissuebench.workflows.limits import step_count

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


def add_scheme_options(p: argparse.ArgumentParser) -> None:
    """--scheme and --substeps (SPEC 11): the element's remedy against locking, and the
    explicit schemes' sub-steps."""
    from tissuebench.solvers.schemes import SCHEMES

    def parameters(s):
        said = [
            f"{k}={p.default:g}: {p.meaning}, {p.range_text(k)}" for k, p in s.parameters.items()
        ]
        return "; ".join(said) or "no parameters"

    described = "; ".join(
        f"{name} ({parameters(s)}, {'/'.join(s.cells)}): {s.description}"
        for name, s in SCHEMES.items()
    )
    p.add_argument(
        "--scheme",
        default="standard",
        metavar="NAME[:KEY=VALUE,...]",
        help=f"the element's stiffness (SPEC 11; with the linear model, and mean-dilatation also "
        f"with a nonlinear model under the explicit algorithms, as F-bar): {described}",
    )
    p.add_argument(
        "--substeps",
        default="1",
        metavar="K|auto",
        help="explicit schemes take K sub-steps of h/K per step h, or the fewest with h/K <= "
        "0.9 x their measured critical step (auto); reported at every h, the cost counts every "
        "sub-step (default 1); refused when --algorithms names no explicit scheme (an implicit "
        "step takes no sub-steps)",
    )


def scheme_options(
    args: argparse.Namespace,
    gdim: int,
    options: dict,
    models: list[str],
    algorithms: list[str] | None = None,
) -> tuple[str, int | str]:
    """(scheme, substeps) from --scheme and --substeps, checked against the cells, the models
    and the algorithms (UserError): F-bar, mean-dilatation's nonlinear form, runs with the
    explicit algorithms only, beside a linear implicit reference."""
    from tissuebench.solvers.schemes import STANDARD, check_cells, parse_scheme
    from tissuebench.solvers.substeps import parse_substeps

    scheme = args.scheme.strip()
    check_cells(scheme, options.get("cell", CELLS[gdim][0]))
    nonlinear = [m for m in models if not MODELS[m].linear]
    name = parse_scheme(scheme)[0]
    if name not in (STANDARD, "mean-dilatation") and nonlinear:
        raise UserError(
            f"--scheme {name} runs the linear model only, not {', '.join(nonlinear)} "
            "(mean-dilatation has a nonlinear form, F-bar, for the explicit algorithms)"
        )
    if name != STANDARD and nonlinear:
        implicit = [a for a in algorithms or [] if not ALGORITHMS[a].explicit]
        if implicit or LINEAR not in models:
            raise UserError(
                f"--scheme {name} with {', '.join(nonlinear)}: F-bar runs with the explicit "
                "algorithms only (its cell-mean J is not differentiated: Newton would have no "
                "exact tangent); give --algorithms explicit or explicit-lumped and keep linear "
                "among --models for the implicit reference"
            )
    try:
        substeps = parse_substeps(args.substeps)
    except ValueError as err:
        raise UserError(str(err)) from None
    explicit = [a for a in ALGORITHMS if ALGORITHMS[a].explicit]
    if substeps != 1 and algorithms is not None and not set(algorithms) & set(explicit):
        raise UserError(
            f"--substeps {args.substeps.strip()} applies to the explicit schemes only "
            f"({', '.join(explicit)}), and --algorithms names none ({', '.join(algorithms)}): "
            "add one, or leave --substeps out"
        )
    return scheme, substeps
