"""The README's "grade your own simulator" recipe, run as written (issue 26, item 5).

The lines are parsed out of README.md's code block under that heading and run verbatim in a
fresh folder outside the clone (a user's `mywork/`, issue 44), with one substitution only:
`python my_solver.py` becomes this Python running tests/recipe_solver.py (a small simulator of
our own that reads only the exported JSON, with numpy and scipy, on its own tetrahedra), so
that the README cannot go stale without this test failing. The folder has no results/ of its
own: the leaderboard renders the clone's committed record (found from the installed package's
source tree) into the folder's results/, and the clone's results/ are left as they were. It
ends with the user's row on the leaderboard: in leaderboard.md and leaderboard.csv, and on the
page (leaderboard/index.html) by its label, within a minute of the last line's start.
"""

import argparse
import csv
import hashlib
import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from helpers import job

pytestmark = pytest.mark.slow  # a minute or more in all: make test starts it first

ROOT = Path(__file__).resolve().parents[1]
HEADING = "### Grade your own simulator"
SOLVER = Path(__file__).with_name("recipe_solver.py")


def recipe() -> list[list[str]]:
    """The commands of the README's recipe, each as its argv: the first ```sh block after the
    heading, continuation lines joined, comments dropped."""
    text = (ROOT / "README.md").read_text()
    assert HEADING in text, f"README.md has no section {HEADING!r}"
    section = text[text.index(HEADING) :]
    start = section.index("```sh\n") + len("```sh\n")
    block = section[start : section.index("```", start)]
    return [shlex.split(line, comments=True) for line in block.replace("\\\n", " ").splitlines()]


def hashes(folder: Path) -> dict[str, str]:
    """The SHA-256 of every file in folder (not in its subfolders): {name: hash}."""
    return {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.glob("*"))
        if p.is_file()
    }


def committed_results(to: Path) -> None:
    """Copy the files of results/ that git tracks (a clone's results/) to `to`."""
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z", "results"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split("\0")
    for name in filter(None, listed):
        target = to / Path(name).relative_to("results")
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target)


def tiny_record(results: Path) -> None:
    """When the committed results/ hold no leaderboard record yet: record the rod-MP3 case with
    our algorithms on its hexahedra only (no simplices, no outside simulator), as
    `tissuebench leaderboard --rerun` does, so that the recipe's last line renders from a
    record as it would in a clone. A few seconds instead of the full board's many minutes."""
    from tissuebench.workflows.leaderboard import build as leaderboard
    from tissuebench.workflows.leaderboard import runs
    from tissuebench.workflows.leaderboard.rows import Board

    board = Board("rod-MP3", "rod", "MP3", "linear", simulators=(), description="rod-MP3, ours")
    args = argparse.Namespace(out=results, solver="direct", petsc="", force=True, rerun=[])
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(leaderboard, "BOARDS", [board])
        patch.setattr(runs, "simplex_rows", lambda *args, **kwargs: [])
        assert leaderboard.main(args) == 0


@pytest.mark.serial
def test_the_readme_recipe_puts_a_users_run_on_the_leaderboard(tmp_path):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs the project's git checkout (its committed results/)")
    commands = recipe()
    assert [c[:2] for c in commands] == [
        ["tissuebench", "export"],
        ["python", "my_solver.py"],
        ["tissuebench", "compare"],
        ["tissuebench", "leaderboard"],
    ], commands
    mywork = tmp_path / "mywork"  # outside the clone, with no results/ of its own
    mywork.mkdir()
    if not (ROOT / "results" / "leaderboard.json").is_file():  # no committed record: the user's
        tiny_record(mywork / "results")
    clone = hashes(ROOT / "results" / "leaderboard") | {
        name: hashes(ROOT / "results")[name]
        for name in ("leaderboard.json", "leaderboard.md", "leaderboard.csv")
        if (ROOT / "results" / name).is_file()
    }
    _, env = job([])
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    times = []
    for argv in commands:
        if argv[:2] == ["python", "my_solver.py"]:
            argv = [sys.executable, str(SOLVER), *argv[2:]]
        start = time.perf_counter()
        done = subprocess.run(
            argv, cwd=mywork, env=env, capture_output=True, text=True, timeout=300
        )
        times.append(time.perf_counter() - start)
        assert done.returncode == 0, f"{shlex.join(argv)}:\n{done.stdout}\n{done.stderr}"

    # the export is the self-describing JSON the solver read, and the solver used its own mesh
    doc = json.loads((mywork / "rod.json").read_text())
    assert doc["version"] == 2 and doc["truth"]["case"] == "rod"
    assert doc["units"]["metrics.E_i"] == "m^3" and doc["geometry"]["regions"]["clamped"] == "x = 0"
    compare = commands[2]
    out = mywork / compare[compare.index("--out") + 1]
    label = compare[compare.index("--label") + 1]
    summary = json.loads((out / "summary.json").read_text())
    mesh = summary["candidate"]["mesh"]
    assert mesh["cell_type"] == "tetrahedron" and mesh["nodes"] != len(doc["nodes"])
    graded = summary["runs"][label]
    assert graded["status"] == "ok" and 0 < graded["interior_error_max"] < 0.01  # m^3

    # the row on the leaderboard, with the numbers compare graded
    board = (mywork / "results" / "leaderboard.md").read_text()
    assert label in board
    # and on the page, by its label: its point (in its own colour, labelled) and the list of
    # users' runs at the top, which links to its case
    page = (mywork / "results" / "leaderboard" / "index.html").read_text()
    assert f'data-label="{label}"' in page and f'<a href="#rod-MP3">{label}</a>' in page
    with open(mywork / "results" / "leaderboard.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["case"] == "rod-MP3" and label in r["label"]]
    assert len(rows) == 1, f"{len(rows)} rows of {label} on rod-MP3 in leaderboard.csv"
    row = rows[0]
    assert row["status"] == "ok" and int(row["dofs"]) == 3 * mesh["nodes"]
    for metric in ("interior_error_max", "relative_error_max", "surface_error_mean"):
        assert float(row[metric]) == pytest.approx(graded[metric], rel=1e-9), metric
    # the whole board is there, every case of the clone's record, and the clone is untouched
    record = json.loads((mywork / "results" / "leaderboard.json").read_text())
    if (ROOT / "results" / "leaderboard.json").is_file():
        committed = json.loads((ROOT / "results" / "leaderboard.json").read_text())
        names = [c["board"]["name"] for c in record["cases"]]
        assert names == [c["board"]["name"] for c in committed["cases"]]
    after = hashes(ROOT / "results" / "leaderboard") | {
        name: hashes(ROOT / "results")[name]
        for name in ("leaderboard.json", "leaderboard.md", "leaderboard.csv")
        if (ROOT / "results" / name).is_file()
    }
    assert after == clone, "the recipe wrote into the clone's results/"
    print(f"recipe steps (s): {', '.join(f'{t:.1f}' for t in times)}; total {sum(times):.1f}")
