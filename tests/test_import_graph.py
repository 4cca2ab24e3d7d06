"""The folders depend in one direction (README, Layout): core -> meshes -> solvers -> metrics ->
workflows. A module may import its own folder and the folders before it, never one after it;
every import counts, at the top of a module and inside a function alike (parsed with ast,
nothing is imported)."""

import ast
from pathlib import Path

import pytest

pytestmark = pytest.mark.serial  # reads the source tree only

ROOT = Path(__file__).resolve().parents[1]
ORDER = ("core", "meshes", "solvers", "metrics", "workflows")  # bottom first
PACKAGE = "tissuebench"


def imported(source: str) -> list[tuple[int, str]]:
    """(line, module) of every import of `source`, wherever it stands: `import a.b` and
    `from a.b import c` give a.b, `from tissuebench import f` gives tissuebench.f; a relative
    import (the package uses none) is reported as '.'."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                found.append((node.lineno, "."))
                continue
            found.append((node.lineno, node.module))
            if node.module == PACKAGE:  # from tissuebench import FOLDER
                found += [(node.lineno, f"{PACKAGE}.{alias.name}") for alias in node.names]
    return found


def folder_of(module: str) -> str | None:
    """The folder of ORDER that a module name belongs to (tissuebench.FOLDER...), or None."""
    parts = module.split(".")
    if len(parts) > 1 and parts[0] == PACKAGE and parts[1] in ORDER:
        return parts[1]
    return None


def upward(modules: dict[str, str], known: set = frozenset()) -> list[str]:
    """'path:line imports module (folder after folder)' for every import in `modules` ({path
    relative to the repository: source}) of a folder later in ORDER than the importer's, and
    for every relative import; the (path, module) pairs of `known` are left out."""
    bad = []
    for path, source in sorted(modules.items()):
        mine = path.split("/")[0]
        for line, module in imported(source):
            if module == ".":
                bad.append(f"{path}:{line}: a relative import (name the folder: tissuebench.*)")
                continue
            theirs = folder_of(module)
            if theirs is None or (path, module) in known:
                continue
            if ORDER.index(theirs) > ORDER.index(mine):
                bad.append(f"{path}:{line} imports {module} ({mine} below {theirs})")
    return bad


def package_modules() -> dict[str, str]:
    """{path: source} of every module of the package's folders."""
    return {
        p.relative_to(ROOT).as_posix(): p.read_text()
        for folder in ORDER
        for p in sorted((ROOT / folder).rglob("*.py"))
    }


def test_every_folder_is_listed_in_the_order():
    """Each code folder that installs as tissuebench.* (pyproject.toml) is in ORDER, so that
    none escapes the check; the package tissuebench itself (its __init__.py, the Python API's
    names) is a folder inside one of them, checked with it."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    folders = config["tool"]["setuptools"]["package-dir"]
    assert {d for name, d in folders.items() if name != PACKAGE} == set(ORDER)
    assert folders[PACKAGE].split("/")[0] in ORDER


def test_every_package_is_installed():
    """Every folder with an __init__.py below the code folders is a package of pyproject.toml
    (a wheel holds only those listed: solvers/schemes/ was missing from it)."""
    import tomllib

    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    listed = set(config["tool"]["setuptools"]["packages"])
    mapped = {d: name for name, d in config["tool"]["setuptools"]["package-dir"].items()}

    def package(folder: Path) -> str:
        """The package name setuptools gives a folder: that of the longest package-dir folder
        it is in, with the folders below that."""
        parts = folder.relative_to(ROOT).parts
        k = max(k for k in range(1, len(parts) + 1) if "/".join(parts[:k]) in mapped)
        return ".".join([mapped["/".join(parts[:k])], *parts[k:]])

    found = {
        package(init.parent) for folder in ORDER for init in (ROOT / folder).rglob("__init__.py")
    }
    assert found == listed


def test_no_folder_imports_one_above_it():
    modules = package_modules()
    assert len(modules) > 100  # the package was found
    assert upward(modules, set()) == []


def test_a_planted_upward_import_fails():
    """A synthetic package: each kind of upward edge is found, downward and sideways ones are
    not."""
    modules = {
        "core/ok.py": "import json\n",
        "meshes/ok.py": "from tissuebench.core.errors import UserError\n",
        "solvers/ok.py": "from tissuebench.meshes import get_benchmark\nimport tissuebench.core\n",
        "metrics/ok.py": "from tissuebench.solvers.truth.samples import TruthSamples\n",
        "workflows/ok.py": "from tissuebench.metrics import METRICS\nfrom tissuebench import core",
        "core/top.py": "from tissuebench.workflows.io.output import SUMMARY\n",
        "meshes/inner.py": "def f():\n    from tissuebench.solvers.materials import LARGEST\n",
        "solvers/plain.py": "import tissuebench.metrics.table\n",
        "metrics/named.py": "from tissuebench import workflows\n",
        "metrics/relative.py": "from . import table\n",
    }
    bad = upward(modules)
    assert len(bad) == 5, bad
    for path in ("core/top.py:1", "meshes/inner.py:2", "solvers/plain.py:1", "metrics/named.py:1"):
        assert any(b.startswith(f"{path} imports") for b in bad), (path, bad)
    assert any(b.startswith("metrics/relative.py:1: a relative import") for b in bad)
    assert upward(modules, {("meshes/inner.py", "tissuebench.solvers.materials")}) == [
        b for b in bad if not b.startswith("meshes/inner.py")
    ]
