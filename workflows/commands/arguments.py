"""Command-line options that several commands share (their checks, shared with the Python API,
are workflows/run/checks.py). Commands import these; no command imports another command, and
nothing but the commands imports this."""

from __future__ import annotations

import argparse

from tissuebench.core.errors import UserError
from tissuebench.meshes.benchmark import CELLS, MESHES, Entry
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.linear import SOLVERS
from tissuebench.solvers.models import LINEAR


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


def mesh_size_help(benchmarks: dict[str, Entry]) -> str:
    """--mesh-size's help: on each benchmark what its size gives (the grid's cells, their
    size in m, its default), and the simplices' meshes."""
    said = []
    for name, e in benchmarks.items():
        letter = e.size_name
        if e.grid is None:
            words = e.size_words or "its mesh size"
            said.append(f"{name}: {words} (default {letter} = {e.mesh_size})")
            continue
        counts, cells, rule = e.grid
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


def schemes_described() -> str:
    """Every registered scheme in words, from its Scheme: its parameters (default, meaning,
    range), its cells and its description."""
    from tissuebench.solvers.schemes import SCHEMES

    def parameters(s):
        said = [
            f"{k}={p.default:g}: {p.meaning}, {p.range_text(k)}" for k, p in s.parameters.items()
        ]
        return "; ".join(said) or "no parameters"

    return "; ".join(
        f"{name} ({parameters(s)}, {'/'.join(s.cells)}): {s.description}"
        for name, s in SCHEMES.items()
    )


def add_scheme_options(p: argparse.ArgumentParser) -> None:
    """--scheme and --substeps (SPEC 11): the element's remedy against locking, and the
    explicit schemes' sub-steps."""
    from tissuebench.solvers.schemes import SCHEMES, STANDARD

    described = schemes_described()
    also = "".join(
        f", and {name} also with a nonlinear model under the {' and '.join(s.nonlinear)} "
        f"algorithms{', as F-bar' if s.fbar else ''}"
        for name, s in SCHEMES.items()
        if name != STANDARD and s.nonlinear
    )
    p.add_argument(
        "--scheme",
        default=STANDARD,
        metavar="NAME[:KEY=VALUE,...]",
        help=f"the element's stiffness (SPEC 11; with the linear model{also}): {described}",
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
    and the algorithms (UserError): a scheme runs a nonlinear model with the kinds of algorithm
    its Scheme.nonlinear states (F-bar, mean-dilatation's nonlinear form, with the explicit
    ones only, beside a linear implicit reference)."""
    from tissuebench.solvers.schemes import SCHEMES, check_cells, nonlinear_forms, parse_scheme
    from tissuebench.solvers.substeps import parse_substeps

    scheme = args.scheme.strip()
    name = parse_scheme(scheme)[0]
    check_cells(name, options.get("cell", CELLS[gdim][0]))
    entry = SCHEMES[name]
    nonlinear = [m for m in models if not MODELS[m].linear]
    if nonlinear and not entry.nonlinear:
        raise UserError(
            f"--scheme {name} runs the linear model only, not {', '.join(nonlinear)} "
            f"({nonlinear_forms()})"
        )
    if nonlinear:
        takes = [a for a in ALGORITHMS if entry.takes_nonlinear(ALGORITHMS[a].explicit)]
        refused = [a for a in algorithms or [] if a not in takes]
        # without a nonlinear implicit form, the implicit reference runs the linear model
        reference = not entry.takes_nonlinear(explicit=False)
        if refused or (reference and LINEAR not in models):
            form = "F-bar" if entry.fbar else f"{name}'s nonlinear form"
            why = (
                " (its cell-mean J is not differentiated: Newton would have no exact tangent)"
                if entry.fbar
                else ""
            )
            keep = " and keep linear among --models for the implicit reference" if reference else ""
            raise UserError(
                f"--scheme {name} with {', '.join(nonlinear)}: {form} runs with the "
                f"{' and '.join(entry.nonlinear)} algorithms only{why}; give --algorithms "
                f"{' or '.join(takes)}{keep}"
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
