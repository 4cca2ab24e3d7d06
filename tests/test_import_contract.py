"""The import contract of `make imports` (pyproject.toml's [tool.importlinter], checked by
import-linter's `lint-imports`) can fail: on a copy of the package's sources in a temporary
folder, laid out as tissuebench.* installs them, it holds as the sources are, and breaks once a
forbidden import is planted (an upward one between the folders, at the top of a module or inside
a function; one of the commands from outside the command line). The real tree is only read."""

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
from test_import_graph import ORDER

pytestmark = pytest.mark.serial  # reads the source tree only, runs no MPI

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "pyproject.toml"
LINT_IMPORTS = Path(sys.executable).with_name("lint-imports")  # the test extra installs it
LAYERS = "The folders depend in one direction"
COMMANDS = "Nothing imports the commands"
FEATURES = "The features of workflows/ depend in one direction"
BENCHMARK_MODULES = "Nothing outside meshes/ imports a benchmark's own module"


def contracts() -> list[dict]:
    return tomllib.loads(CONFIG.read_text())["tool"]["importlinter"]["contracts"]


def copy_package(into: Path) -> Path:
    """The package's modules (every .py of the code folders) copied into `into`/tissuebench/ as
    they install (pyproject.toml's package-dir); the folder to put on PYTHONPATH."""
    dirs = tomllib.loads(CONFIG.read_text())["tool"]["setuptools"]["package-dir"]
    package = into / "tissuebench"
    for name, folder in dirs.items():
        source = ROOT / folder
        if name == "tissuebench":  # the package itself: its __init__.py only
            package.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source / "__init__.py", package / "__init__.py")
            continue
        target = into.joinpath(*name.split("."))
        for path in source.rglob("*.py"):
            copied = target / path.relative_to(source)
            copied.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, copied)
    return into


def lint(path: Path) -> subprocess.CompletedProcess:
    """lint-imports with the repository's contracts on the package under `path`."""
    env = {**os.environ, "PYTHONPATH": str(path)}
    return subprocess.run(
        [str(LINT_IMPORTS), str(CONFIG), "--no-cache", "--no-logo"],
        cwd=path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def plant(path: Path, module: str, line: str) -> None:
    """Append `line` to the copied module (a dotted name of the package)."""
    file = path.joinpath(*module.split(".")).with_suffix(".py")
    assert file.is_file(), file
    assert path in file.parents and ROOT not in file.parents  # never the real tree
    file.write_text(file.read_text() + "\n" + line + "\n")


def contract(name: str) -> dict:
    (found,) = [c for c in contracts() if c["name"].startswith(name)]
    return found


def test_the_layers_are_the_import_graphs_order():
    """The folders' layers contract names the folders in test_import_graph.py's ORDER, top
    first, so that the two checks agree."""
    assert contract(LAYERS)["layers"] == [f"tissuebench.{f}" for f in reversed(ORDER)]


def test_every_feature_folder_is_a_layer():
    """Each folder and module of workflows/ is in the features' contract (the entry points in
    its top layer), so that a new feature folder cannot stand outside it."""
    features = contract(FEATURES)
    assert features["containers"] == ["tissuebench.workflows"]
    named = {n.strip() for layer in features["layers"] for n in layer.split(":")}
    workflows = ROOT / "workflows"
    folders = {p.name for p in workflows.iterdir() if (p / "__init__.py").is_file()}
    modules = {p.stem for p in workflows.glob("*.py") if p.stem != "__init__"}
    assert folders - {"package"} | modules == named  # package/: the tissuebench package itself


def test_every_benchmark_module_is_forbidden():
    """The benchmark modules' contract lists the module of every registered benchmark (the
    module its entry's build function comes from), so that a new benchmark is covered."""
    from tissuebench.meshes import BENCHMARKS

    modules = {entry.build.__module__ for entry in BENCHMARKS.values()}
    assert modules == set(contract(BENCHMARK_MODULES)["forbidden_modules"])


def test_the_contract_holds_on_the_sources(tmp_path):
    result = lint(copy_package(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout
    assert result.stdout.count(" KEPT") == len(contracts())


@pytest.mark.parametrize(
    "module, line, contract",
    [
        # an upward import at the top of a module
        ("tissuebench.solvers.materials", "import tissuebench.workflows", LAYERS),
        # one inside a function, from the bottom folder
        (
            "tissuebench.core.errors",
            "def planted():\n    from tissuebench.metrics.table import METRICS\n    return METRICS",
            LAYERS,
        ),
        # a loop between two features: the truth's report using the paper's study
        (
            "tissuebench.workflows.truth.sweep",
            "from tissuebench.workflows.study.common import METRICS",
            FEATURES,
        ),
        # a file format (io/) using a run's case, inside a function
        (
            "tissuebench.workflows.io.summary",
            "def planted():\n    from tissuebench.workflows.run import case\n    return case",
            FEATURES,
        ),
        # a benchmark's module from outside meshes/: its needle's radius, in a workflow
        (
            "tissuebench.workflows.contact.hertz",
            "from tissuebench.meshes.contact import RADIUS",
            BENCHMARK_MODULES,
        ),
        # and inside a function, from metrics/
        (
            "tissuebench.metrics.relative",
            "def planted():\n    from tissuebench.meshes import rod\n    return rod.SIZE",
            BENCHMARK_MODULES,
        ),
        # the commands' shared options, imported from outside the commands (by the Python API,
        # beside them in the features' top layer: only the commands' own contract breaks)
        (
            "tissuebench.workflows.api",
            "from tissuebench.workflows.commands.arguments import add_common",
            COMMANDS,
        ),
    ],
)
def test_a_planted_import_breaks_the_contract(tmp_path, module, line, contract):
    path = copy_package(tmp_path)
    plant(path, module, line)
    result = lint(path)
    out = " ".join(result.stdout.split())  # import-linter wraps its lines
    assert result.returncode != 0, out
    assert "1 broken" in out, out
    assert f"{contract}" in out and "BROKEN" in out.split(contract, 1)[1].split("KEPT")[0], out
    assert module in out, out
