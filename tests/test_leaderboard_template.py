"""The leaderboard page as a view model and a Jinja2 template (issue 41): the template, its
parts, stylesheet and script are package data that an installed tissuebench finds (with
importlib.resources, as page.py reads them) and that pyproject ships in a built install; the
page escapes every text it read, the plots alone going in as markup. And a row's kind (ours,
a simulator's, a user's, the frontier's) is set once where the row is made or read: a user's
row from a user folder is a user's whatever its label says, and a recorded row keeps the kind
its recorded source says, whatever its label."""

import fnmatch
import html
import json
import tomllib
from importlib import resources
from pathlib import Path

import pytest
from test_newcomer_leaderboard import compare_summary

from tissuebench.workflows.io.output import seal
from tissuebench.workflows.leaderboard import document, page
from tissuebench.workflows.leaderboard.figures import unit_of
from tissuebench.workflows.leaderboard.record import row_of, row_record
from tissuebench.workflows.leaderboard.row import Kind, kind_of
from tissuebench.workflows.leaderboard.rows import BOARDS, Board, Row, error_keys, user_rows

ROOT = Path(__file__).resolve().parents[1]
FILES = ("page.html.j2", "parts.html.j2", "page.css", "page.js")
HOSTILE = 'it\'s "<script>alert(1)</script>" & more'

pytestmark = pytest.mark.serial  # user folders in tmp_path, which mpiexec's ranks share


def test_the_templates_are_found_in_the_installed_package():
    found = resources.files("tissuebench.workflows.leaderboard").joinpath("templates")
    for name in FILES:
        assert found.joinpath(name).is_file(), name
        assert found.joinpath(name).read_text(encoding="utf-8") == page.asset(name)
    # a built (not editable) install carries every file of the folder: pyproject lists the
    # folder as a package and its files as package data
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert "tissuebench.workflows.leaderboard.templates" in config["packages"]
    globs = config["package-data"]["tissuebench.workflows.leaderboard.templates"]
    folder = ROOT / "workflows" / "leaderboard" / "templates"
    # every file but the package's own module (a package's .py files install without a glob)
    names = sorted(p.name for p in folder.iterdir() if p.is_file() and p.suffix != ".py")
    assert set(FILES) <= set(names)
    assert [n for n in names if not any(fnmatch.fnmatch(n, g) for g in globs)] == []


def row(label: str, source: str, cost: float, error: float, **kw) -> Row:
    errors = dict.fromkeys(error_keys(), error)
    return Row("rod-MP3", label, source, "a run", kw.pop("mesh", "reference"), 336, "ok", None,
               errors, cost * 10, 10.0, "this session", **kw)  # fmt: skip


def test_the_page_escapes_what_it_read_and_inlines_its_own():
    board = Board("rod-MP3", "rod", "MP3", "linear", description=HOSTILE, truth_note=HOSTILE,
                  session=HOSTILE, machine=HOSTILE)  # fmt: skip
    rows = [
        row("implicit", "tissuebench", 0.01, 0.0, reference=True),
        row(HOSTILE, "CalculiX 2.20", 0.3, 2e-4, mesh=HOSTILE),
        row("x" + HOSTILE, "user", 0.5, 5e-5, mesh="hexahedra: 54 cells, 112 nodes"),
    ]
    text = page.render([board], {board.name: rows}, {board.name: [HOSTILE]}, "now", unit_of)
    assert "<script>alert" not in text and HOSTILE not in text
    assert text.count("<script>") == 1  # the page's own script, inlined
    assert page.asset("page.js") in text and page.asset("page.css") in text
    assert text.count('<svg class="plot"') == 1  # the plot: markup, not text
    escaped = html.escape(HOSTILE, quote=True)
    assert f"<li>{escaped}</li>" in text  # the note
    assert f'<h2>rod-MP3</h2>\n<p class="note">{escaped} Timed {escaped} on {escaped}.' in text
    assert text.endswith("</script></body></html>\n")


def test_a_rows_kind_is_set_once_from_where_it_came(tmp_path):
    board = next(b for b in BOARDS if b.name == "rod-MP3")
    cases = tmp_path / "leaderboard" / board.name / "user"
    labels = ["tissuebench", "CalculiX 2.20", "SPEC 11 frontier", "ours"]
    for k, label in enumerate(labels):
        sub = cases / f"u{k}"
        sub.mkdir(parents=True)
        mine = sub / "mine.xdmf"
        mine.write_text("<Xdmf/>\n")
        (sub / "summary.json").write_text(json.dumps(compare_summary(board, label, mine)))
        seal(sub)
    found, skipped = user_rows(board, cases)
    assert skipped == [] and sorted(r.label for r in found) == sorted(labels)
    assert all(r.kind is Kind.USER for r in found)  # whatever the label says
    for r in found:
        assert page.source_of(r) == "users"
        assert "kind" not in row_record(r)  # the record keeps the source, which says it
        assert row_of(row_record(r)).kind is Kind.USER
        r.status, r.errors, r.truth, r.wall_time_s = (
            "ok",
            dict.fromkeys(error_keys(), 1e-4),
            {},
            1.0,
        )
    best = document.best_per_source(found, truth=False)
    assert sorted(key for key, _ in best) == sorted(f"user {label}" for label in labels)
    # recorded rows: the kind is the recorded source's, never the label's
    ours = row("user x", "tissuebench", 0.01, 0.0)
    simulator = row("user", "Newton 1.8.0", 0.01, 1e-3)
    assert ours.kind is Kind.OURS and simulator.kind is Kind.SIMULATOR
    assert row_of(row_record(ours)).kind is Kind.OURS
    assert row_of({**row_record(simulator), "kind": "user"}).kind is Kind.SIMULATOR
    assert [kind_of(s) for s in ("tissuebench", "user", "SPEC 11 frontier", "users")] == [
        Kind.OURS,
        Kind.USER,
        Kind.FRONTIER,
        Kind.SIMULATOR,
    ]
    text = page.render([board], {board.name: found + [ours]}, {}, "now", unit_of)
    assert text.count('class="pt f user"') == len(labels)
