"""A leaderboard case (a Board of workflows/leaderboard/boards.py) as a run of it is: its dimension,
nodes, h, steps and end time (board_case); its benchmark options compared (same_options) and said in
words; the `tissuebench export` arguments that pose it, and the case that an export's inputs pose
(posed_board)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from tissuebench.meshes import get_entry
from tissuebench.workflows.io.limits import step_count
from tissuebench.workflows.leaderboard.boards import BOARDS, Board
from tissuebench.workflows.leaderboard.row import one_line, real

if TYPE_CHECKING:
    from tissuebench.solvers.materials import Material

TOLERANCE = 1e-5  # relative, on h and T: compare's time stamps match to six printed digits


def board_case(board: Board) -> dict:
    """What a run of the board's case is, before anything runs: the reference's dimension
    and nodes, h (s), steps and end time (s)."""
    entry = get_entry(board.benchmark)
    end_time = board.end_time if board.end_time is not None else entry.end_time
    steps = step_count(entry.dt, end_time)
    return {
        "gdim": entry.gdim,
        "nodes": entry.nodes(board.mesh_size or entry.mesh_size),
        "h": entry.dt,
        "steps": steps,
        "end_time": steps * entry.dt,
    }


# an option not given is this (kappa: the contact benchmark's penalty, SPEC 12)
DEFAULT_OPTIONS = {"load_scale": 1.0, "needle_width": 0.0, "kappa": 10.0}


def same_options(a: dict, b: dict) -> bool:
    """Whether two benchmark option sets pose the same case (an option not given is its
    default, DEFAULT_OPTIONS; numbers compared to TOLERANCE)."""
    for key in {*a, *b} | set(DEFAULT_OPTIONS):
        x, y = a.get(key, DEFAULT_OPTIONS.get(key)), b.get(key, DEFAULT_OPTIONS.get(key))
        if real(x) and real(y):
            if not math.isclose(x, y, rel_tol=TOLERANCE, abs_tol=1e-12):
                return False
        elif x != y:
            return False
    return True


OPTION_WORDS = {"load_scale": ("load scale s", ""), "needle_width": ("needle width w", " m")}


def options_words(options: dict) -> str:
    """A case's benchmark options in words ("load scale s = 3"; "default options" when every
    one is its default, DEFAULT_OPTIONS)."""
    words = []
    for key, value in sorted(options.items()):
        if real(value) and real(DEFAULT_OPTIONS.get(key)) and value == DEFAULT_OPTIONS[key]:
            continue
        name, unit = OPTION_WORDS.get(key, (key.replace("_", " "), ""))
        words.append(f"{name} = {value:g}{unit}" if real(value) else f"{name} = {value}")
    return one_line(", ".join(words) or "default options")


def export_options(board: Board) -> str:
    """The `tissuebench export` arguments that pose a case's benchmark (the file and format
    left out): `rod --material MP3 --mesh-size 6`."""
    words = [board.benchmark, "--material", board.material]
    if board.model != "linear":
        words += ["--models", board.model]
    if board.mesh_size is not None:
        words += ["--mesh-size", str(board.mesh_size)]
    if board.end_time is not None:
        words += ["--end-time", f"{board.end_time:g}"]
    for key, value in sorted(board.options.items()):
        if value != DEFAULT_OPTIONS.get(key):
            words += [f"--{key.replace('_', '-')}", f"{value:g}"]
    return " ".join(words)


def posed_board(
    benchmark: str,
    material: Material,
    model: str,
    options: dict,
    mesh_size: int,
    h: float,
    steps: int,
    plane: str = "strain",
    boards: list[Board] | None = None,
) -> Board | None:
    """The leaderboard case (of `boards`, default BOARDS) that a benchmark posed with these
    inputs is (an export's: its material's values, model, options, mesh size, h in s and
    steps; plane strain in 2D), or None."""
    from tissuebench.solvers.materials import get_material

    for b in BOARDS if boards is None else boards:
        case, mine = board_case(b), get_material(b.material)
        if not (
            b.benchmark == benchmark
            and b.model == model
            and (b.mesh_size or get_entry(benchmark).mesh_size) == mesh_size
            and same_options(options, b.options)
            and math.isclose(h, case["h"], rel_tol=TOLERANCE)
            and steps == case["steps"]
            and plane == "strain"
        ):
            continue
        values = ("E", "nu", "rho", "alpha", "beta")
        if all(math.isclose(getattr(material, k), getattr(mine, k)) for k in values):
            return b
    return None
