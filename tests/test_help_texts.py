"""The help says what each number means (issue 44, item 4), and what it says is what the code
does: --mesh-size's grid per benchmark is the one the mesh has (its nodes and cell size from
the registry), --scheme's parameters' ranges are the ones the parser takes and refuses, its
words on nonlinear models are the rule scheme_options applies, and --substeps names its
refusal (tests/test_inputs.py runs the refusal itself)."""

import argparse
import math
import re

import pytest

from tissuebench.core.errors import UserError
from tissuebench.meshes import BENCHMARKS
from tissuebench.solvers.schemes import SCHEMES, parse_scheme
from tissuebench.workflows.cli import parser
from tissuebench.workflows.commands.arguments import scheme_options


def help_of(command: str) -> str:
    """`tissuebench COMMAND --help` as one line of words."""
    sub = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction))
    return " ".join(sub.choices[command].format_help().split())


def test_mesh_size_says_the_grid_each_benchmark_has():
    for name, entry in BENCHMARKS.items():  # a benchmark added is described too
        assert entry.grid is not None or entry.size_words, name
    for command in ("run", "export", "mesh", "stability"):
        text = help_of(command)
        for name, entry in BENCHMARKS.items():
            letter = entry.size_name
            if entry.grid is None:
                said = f"{name}: {entry.size_words} (default {letter} = {entry.mesh_size})"
                assert said in text, (command, said)
                continue
            counts, cells, _ = entry.grid
            grid = " x ".join(f"{k if k > 1 else ''}{letter}" for k in counts)
            said = f"{name}: {grid} {cells} of {entry.cell_size(1):g}/{letter} m"
            assert said in text, (command, said)
            assert f"(default {letter} = {entry.mesh_size})" in text
            for n in (2, 4, 6):  # the grid said is the mesh's: its nodes and spacing
                assert entry.nodes(n) == math.prod(k * n + 1 for k in counts), (name, n)
                assert entry.cell_size(n) == pytest.approx(entry.cell_size(1) / n)


def test_scheme_parameters_are_said_with_the_ranges_the_parser_takes():
    text = help_of("run")
    for name, scheme in SCHEMES.items():
        for key, p in scheme.parameters.items():
            said = re.search(rf"{key}={p.default:g}: ([^,;]+), ([^,;]+)", text)
            assert said and said.group(1) == p.meaning, (name, key)
            low, high = re.fullmatch(
                rf"(\S+) (?:<=|<) {key} (?:<=|<) (\S+)", said.group(2)
            ).groups()  # the range as the help states it
            assert (float(low), float(high)) == (p.low, p.high), (name, key)
            for value, inside in ((p.low, not p.open[0]), (p.high, not p.open[1])):
                ok = f"{name}:{key}={value:g}"
                if inside:
                    assert parse_scheme(ok)[1][key] == value
                else:
                    with pytest.raises(ValueError):
                        parse_scheme(ok)
            for beyond in (p.low - 1, p.high + 1):
                with pytest.raises(ValueError):
                    parse_scheme(f"{name}:{key}={beyond:g}")


def test_scheme_help_on_nonlinear_models_is_the_rule_applied():
    text = help_of("run")
    assert "mean-dilatation also with a nonlinear model under the explicit algorithms" in text
    assert "linear model only" not in text

    def options(scheme: str, models: list[str], algorithms: list[str]):
        args = argparse.Namespace(scheme=scheme, substeps="1")
        cell = SCHEMES[scheme].cells[-1]  # hexahedron or tetrahedron: one it takes
        return scheme_options(args, 3, {"cell": cell}, models, algorithms)

    nh = ["linear", "neo-hookean"]
    assert options("mean-dilatation", nh, ["explicit-lumped"]) is not None
    with pytest.raises(UserError, match="explicit algorithms only"):
        options("mean-dilatation", nh, ["implicit", "explicit-lumped"])  # Newton: no tangent
    with pytest.raises(UserError, match="explicit algorithms only"):
        options("mean-dilatation", ["neo-hookean"], ["explicit-lumped"])  # no linear reference
    for scheme in ("hourglass", "anp", "penalty"):
        with pytest.raises(UserError, match="linear model only"):
            options(scheme, nh, ["explicit-lumped"])


def test_substeps_says_it_needs_an_explicit_algorithm():
    text = help_of("run")
    assert "refused when --algorithms names no explicit scheme" in text
    args = argparse.Namespace(scheme="standard", substeps="auto")
    with pytest.raises(UserError, match="--substeps auto applies to the explicit schemes only"):
        scheme_options(args, 3, {}, ["linear"], ["implicit"])
    assert scheme_options(args, 3, {}, ["linear"], ["implicit", "explicit"])[1] == "auto"
