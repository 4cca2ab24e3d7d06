"""No import loop inside any folder (issue 57): within each package of the code folders, the
modules import one another in one direction, so that each can be read, tested and moved from
the bottom up. Every import counts, at the top of a module, inside a function and under
TYPE_CHECKING alike (parsed with ast, nothing is imported); a package's __init__.py belongs to
its own folder, beside its modules. The graph is the one the package installs as
(tissuebench.FOLDER...)."""

import ast

import pytest
from test_import_graph import ORDER, PACKAGE, package_modules

pytestmark = pytest.mark.serial  # reads the source tree only


def module_name(path: str) -> str:
    """The installed name of a module's file: meshes/tools/tool.py -> tissuebench.meshes.tools.tool
    (a package's __init__.py: the package's name)."""
    parts = path[: -len(".py")].split("/")
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join([PACKAGE, *parts])


def folder(path: str) -> str:
    """The package a module's file sits in (its own for an __init__.py)."""
    name = module_name(path)
    return name if path.endswith("__init__.py") else name.rsplit(".", 1)[0]


def edges(modules: dict[str, str]) -> dict[str, set[str]]:
    """{module: the modules of its own folder that it imports}: `from pkg import name` counts
    as importing pkg.name where that is a module, else as importing pkg (its __init__.py, where
    the name is defined)."""
    names = {module_name(p): p for p in modules}
    graph: dict[str, set[str]] = {}
    for path, source in modules.items():
        me, mine = module_name(path), folder(path)
        found = set()
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.Import):
                found |= {alias.name for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                for alias in node.names:
                    sub = f"{node.module}.{alias.name}"
                    found.add(sub if sub in names else node.module)
        graph[me] = {m for m in found if m in names and m != me and folder(names[m]) == mine}
    return graph


def loops(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_folder_has_an_import_loop():
    modules = package_modules()
    assert {p.split("/")[0] for p in modules} == set(ORDER)
    assert loops(edges(modules)) == []


def test_a_planted_loop_is_found():
    """A loop through a function's import, one through a package's __init__.py and one of
    three modules are found; imports across folders and one-way imports are not loops."""
    modules = {
        "solvers/a.py": "from tissuebench.solvers import b\n",
        "solvers/b.py": "def f():\n    from tissuebench.solvers.a import X\n",
        "meshes/__init__.py": "from tissuebench.meshes import rod\n",
        "meshes/rod.py": "from tissuebench.meshes import BENCHMARKS\n",
        "metrics/x.py": "import tissuebench.metrics.y\n",
        "metrics/y.py": "from tissuebench.metrics.z import Z\n",
        "metrics/z.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
        "    from tissuebench.metrics import x\n",
        "workflows/one.py": "from tissuebench.workflows.two import T\n",
        "workflows/two.py": "from tissuebench.metrics.x import X\n",
        "workflows/sub/__init__.py": "",
        "workflows/sub/three.py": "from tissuebench.workflows.one import O\n",
    }
    found = loops(edges(modules))
    assert sorted(found) == [
        ["tissuebench.meshes", "tissuebench.meshes.rod"],
        ["tissuebench.metrics.x", "tissuebench.metrics.y", "tissuebench.metrics.z"],
        ["tissuebench.solvers.a", "tissuebench.solvers.b"],
    ]
