"""The base install (`pip install tissuebench[dolfinx]`, no test extra) carries every module that
the package's code imports: `tissuebench export rod` once ended in "No module named 'scipy'"
(core/speed.py), which only the test extra had installed.

Every import of the code folders (at the top of a file or inside a function alike, found with
`ast`) must be the standard library's, the package's own, a base dependency's (pyproject's
[project] dependencies), one that the `dolfinx` extra's wheel provides, or one of the few
optional simulators and bench peers named in OPTIONAL with the extra that installs it.
"""

import ast
import functools
import importlib.metadata
import re
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("core", "meshes", "solvers", "metrics", "workflows")
WHEEL = "dolfinx-solver-real"  # the `dolfinx` extra: DOLFINx with PETSc, SLEPc and MPI

# import name -> the extra of pyproject.toml that installs it; the code imports these only in
# the command that needs them (`tissuebench external`, `tissuebench bench`)
OPTIONAL = {
    "mujoco": "mujoco",
    "pydrake": "drake",
    "newton": "newton",
    "warp": "newton",  # warp-lang, which newton requires
    "sfepy": "sfepy",
    "KratosMultiphysics": "kratos",
    "skfem": "bench",
    "pyamg": "bench",
    "pypardiso": "bench",
}


def pyproject() -> dict:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def normalized(name: str) -> str:
    """A distribution's name as PEP 503 compares names."""
    return re.sub(r"[-_.]+", "-", name).lower()


def requirement_name(requirement: str) -> str:
    """The distribution named by a requirement string ("shapely>=2", "x[y]; marker")."""
    found = re.match(r"\s*([A-Za-z0-9][A-Za-z0-9._-]*)", requirement)
    assert found, requirement
    return normalized(found.group(1))


def imports_of(source: str) -> set[str]:
    """The top-level names of the absolute imports in Python source, in functions too."""
    names = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module.split(".")[0])
    return names


def third_party_imports() -> dict[str, list[str]]:
    """Import name -> the files (relative to the repository) importing it, for every import
    of the code folders that is neither the standard library's nor the package's own."""
    found: dict[str, list[str]] = {}
    for folder in FOLDERS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            for name in imports_of(path.read_text()):
                if name in sys.stdlib_module_names or name == "tissuebench":
                    continue
                found.setdefault(name, []).append(str(path.relative_to(ROOT)))
    return found


@functools.cache
def installed() -> dict[str, list[str]]:
    """Import name -> the installed distributions providing it (a few seconds: cached)."""
    return importlib.metadata.packages_distributions()


def provided_by(distributions: set[str]) -> set[str]:
    """The import names that the installed distributions (normalized names) provide."""
    return {
        module
        for module, owners in installed().items()
        if any(normalized(owner) in distributions for owner in owners)
    }


def wheel_modules() -> set[str]:
    """The import names of the `dolfinx` extra's wheel: its own (dolfinx, petsc4py, slepc4py)
    and those of the distributions it requires (basix, ffcx, ufl, mpi4py, cffi, numpy)."""
    try:
        wheel = importlib.metadata.distribution(WHEEL)
    except importlib.metadata.PackageNotFoundError:
        pytest.skip(f"{WHEEL} is not installed (DOLFINx from conda or Docker)")
    required = {requirement_name(r) for r in wheel.requires or [] if "extra ==" not in r}
    return provided_by({normalized(WHEEL)} | required)


def test_the_imports_are_found():
    """The scan sees imports inside functions (core/speed.py's scipy, figures.py's PIL)."""
    assert imports_of("import a.b\nfrom c.d import e\nfrom . import f\ndef g():\n import h\n") == {
        "a",
        "c",
        "h",
    }
    found = third_party_imports()
    assert "dolfinx" in found and "numpy" in found and "PIL" in found, sorted(found)


def test_every_import_comes_with_the_base_install():
    project = pyproject()
    base = {requirement_name(r) for r in project["project"]["dependencies"]}
    extras = project["project"]["optional-dependencies"]
    assert extras["dolfinx"] == [WHEEL]
    allowed = provided_by(base) | wheel_modules()
    missing = {
        name: files
        for name, files in third_party_imports().items()
        if name not in allowed and name not in OPTIONAL
    }
    assert not missing, (
        "imported by the code but neither a base dependency (pyproject.toml's [project] "
        f"dependencies) nor the {WHEEL} wheel's: {missing}"
    )


def test_the_optional_imports_are_exact():
    """Each optional import is imported by the code, is not in the base install (else it
    would not need to be listed) and names an extra of pyproject.toml."""
    project = pyproject()
    extras = project["project"]["optional-dependencies"]
    base = {requirement_name(r) for r in project["project"]["dependencies"]}
    found = third_party_imports()
    assert sorted(name for name in OPTIONAL if name not in found) == []
    assert sorted(name for name in OPTIONAL if OPTIONAL[name] not in extras) == []
    assert sorted(name for name in OPTIONAL if name in provided_by(base)) == []
