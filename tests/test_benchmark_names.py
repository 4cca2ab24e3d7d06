"""Nothing outside meshes/ and the truth's case table branches on a benchmark's name (issue 57):
code that needs what a benchmark is asks its registry entry (meshes.get_entry: its tool, body,
grid, posing), so that a new benchmark is one file and one registry line. Case tables may name
the benchmark a case poses; what is checked here is a comparison with a registered benchmark's
name (`== "rod"`, `in ("block", "rod")`, `match`) and a table keyed by one ({"rod": ...}),
parsed with ast."""

import ast

import pytest
from test_import_graph import package_modules

from tissuebench.meshes import BENCHMARKS

pytestmark = pytest.mark.serial  # reads the source tree only

ALLOWED = ("meshes/", "solvers/truth/cases.py")  # the registry and the truth's case table
# comparisons with a word that is also a benchmark's name but means something else
HOMONYMS = {
    ("workflows/commands/bench.py", "contact"): "`bench --only contact` names a bench part",
}


def branching(source: str, names: set[str]) -> list[tuple[int, str]]:
    """(line, name) of every comparison with, match on, or table keyed by `names` (a dict with
    two or more of them as keys: one alone is a word such as a JSON key or a truth case that
    happens to be a name)."""
    found = []

    def constants(node: ast.AST) -> list[ast.Constant]:
        if isinstance(node, ast.Constant):
            return [node]
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return [e for e in node.elts if isinstance(e, ast.Constant)]
        return []

    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Compare):
            for side in (node.left, *node.comparators):
                found += [(node.lineno, c.value) for c in constants(side) if c.value in names]
        elif isinstance(node, ast.MatchValue):
            found += [(node.lineno, c.value) for c in constants(node.value) if c.value in names]
        elif isinstance(node, ast.Dict):
            keyed = [k.value for k in node.keys if isinstance(k, ast.Constant) and k.value in names]
            if len(keyed) >= 2:
                found += [(node.lineno, name) for name in keyed]
    return found


def test_no_code_outside_the_registry_branches_on_a_benchmark_name():
    names = set(BENCHMARKS)
    bad = [
        f"{path}:{line}: {name!r}"
        for path, source in package_modules().items()
        if not path.startswith(ALLOWED)
        for line, name in branching(source, names)
        if (path, name) not in HOMONYMS
    ]
    assert bad == []


def test_a_planted_branch_is_found():
    source = (
        'if benchmark == "rod":\n    pass\n'
        'ok = name in ("block", "other")\n'
        'GRIDS = {"contact": 1, "rod": 2}\n'
        'row = {"contact": grades}\n'  # one key that is a name: a JSON key, not a table
        'match b:\n    case "cylinder":\n        pass\n'
        'case = Case("rod-MP3", "rod")\n'  # a case table naming its benchmark: allowed
        'key = summary["contact"]\n'  # a key that happens to be a name: not a comparison
    )
    assert branching(source, {"block", "rod", "contact", "cylinder"}) == [
        (1, "rod"),
        (3, "block"),
        (4, "contact"),
        (4, "rod"),
        (7, "cylinder"),
    ]
