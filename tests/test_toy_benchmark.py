"""A third benchmark defined in the test folder alone (tests/toy_benchmark.py: a 2D plate under
gravity, registered through meshes.register) goes through every command as the rod and the
block do (issue 34 item 1): run, export, compare (two runs; a run against its truth), truth
--quick, the paper's report and the leaderboard, each through the command line's main() in this
process (where the plate, its leaderboard case and its cases of the paper are registered:
toy_benchmark.registered). Small sizes: a few seconds each."""

import csv
import json
import os
from pathlib import Path

from mpi4py import MPI

import pytest
from toy_benchmark import BOARD, LARGE, NAME, PAPER, registered

from tissuebench.meshes import BENCHMARKS
from tissuebench.solvers.truth.cases import CASES
from tissuebench.workflows.cli import main
from tissuebench.workflows.leaderboard.boards import BOARDS
from tissuebench.workflows.study import cases as paper_cases

RESULTS = Path(__file__).resolve().parent.parent / "results"

pytestmark = pytest.mark.slow  # a minute or more in all: make test starts it first


@pytest.fixture(scope="module")
def plate():
    with registered() as entry:
        yield entry
    assert NAME not in BENCHMARKS and NAME not in CASES
    assert BOARD.name not in {b.name for b in BOARDS}
    assert {c.name for c in paper_cases.cases() + paper_cases.model_cases()}.isdisjoint(
        {PAPER.name, LARGE.name}
    )


@pytest.fixture
def cache(tmp_path):
    """A truth cache of the test's own ($TISSUEBENCH_CACHE, as it was again after the test)."""
    before = os.environ.get("TISSUEBENCH_CACHE")
    os.environ["TISSUEBENCH_CACHE"] = str(tmp_path / "cache")
    yield
    if before is None:
        del os.environ["TISSUEBENCH_CACHE"]
    else:
        os.environ["TISSUEBENCH_CACHE"] = before


def summary(folder):
    return json.loads((folder / "summary.json").read_text())


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_run_export_compare_and_truth(plate, tmp_path, cache):
    comm = MPI.COMM_WORLD
    run = tmp_path / "run"
    assert main(["run", NAME, "--out", str(run), "--mesh-size", "2"]) == 0
    s = summary(run)
    assert s["benchmark"] == NAME and s["mesh_size"] == 2
    assert {r["status"] for r in s["runs"].values()} == {"ok"}
    assert (run / "tip.csv").is_file()  # the entry's probe

    export = tmp_path / "export" / "plate.json"
    comm.barrier()
    assert main(["export", NAME, "--out", str(export), "--mesh-size", "2"]) == 0
    data = json.loads(export.read_text())
    assert data["dimension"] == 2
    assert data["geometry"]["extents"] == [[0.0, 0.4], [0.0, 0.1]]
    assert data["geometry"]["regions"] == {"clamped": "x = 0"}  # the entry's posing
    assert data["truth"]["case"] == NAME

    graded = tmp_path / "compare"
    reference = tmp_path / "export" / "plate.reference.xdmf"
    assert main(["compare", str(reference), str(run / "explicit.xdmf"), "--out", str(graded)]) == 0
    errors = rows(graded / "metrics.csv")
    assert len(errors) == 21 and float(errors[-1]["relative_error"]) < 0.1

    quick = tmp_path / "truth"
    assert main(["truth", NAME, "--quick", "--out", str(quick)]) == 0
    text = (quick / "truth.md").read_text()
    assert f"## {NAME}\n\n{NAME}, MP3, linear, load scale s = 1.0." in text, text

    against = tmp_path / "truth-graded"
    assert (
        main(["compare", f"truth:{NAME}", str(run / "explicit.xdmf"), "--out", str(against)]) == 0
    )
    fingerprint = summary(against)["reference"]["fingerprint"]
    assert fingerprint["truth"] == NAME and fingerprint["dimension"] == 2


@pytest.mark.serial  # the paper's and the leaderboard's files are rank 0's
def test_paper_report_and_leaderboard(plate, tmp_path, cache):
    from tissuebench.solvers import ALGORITHMS

    # the paper's report on the plate's cases alone: part 1 (every algorithm) and part 2
    # (every model); the paper against the truth (the rod's and the block's) is not named
    out = tmp_path / "paper"
    cases = ["--cases", "plate-MP3", "plate-MP3-s1"]
    assert main(["paper", "--out", str(out), *cases]) == 0
    readme = (out / "README.md").read_text()
    assert "## plate-MP3" in readme and "plate-MP3-s1" in readme
    assert "## block-MP1" not in readme and not (out / "truth-rod-MP3").exists()
    assert (out / "plate-MP3" / "errors.png").is_file()

    # the leaderboard on the plate's case, graded against its truth (which it reads from the
    # cache: computed first, at its full levels, in seconds): rerun alone, and joined to the
    # committed record's cases (the clone's results/leaderboard.json, only read), whose rows stay
    assert main(["truth", NAME, "--out", str(tmp_path / "truth")]) == 0
    board = tmp_path / "board"
    assert main(["leaderboard", "--out", str(board), "--rerun", BOARD.name]) == 0
    table = rows(board / "leaderboard.csv")
    recorded = rows(RESULTS / "leaderboard.csv")
    assert [r for r in table if r["case"] != BOARD.name] == recorded
    plate = [r for r in table if r["case"] == BOARD.name]
    # ours, linear, on the quadrilaterals and on SPEC 9's triangles; no simulator
    assert {r["label"].split(" (")[0] for r in plate} == set(ALGORITHMS)
    assert {r["source"] for r in plate} == {"tissuebench"}
    assert {r["status"] for r in plate} == {"ok"}
    # every row graded against the plate's truth: on the quadrilaterals (n = 2, where every
    # scheme is stable) the dynamic schemes within 20 % of it at their worst step, quasi-static
    # (the static deflection from the first step, where the plate has barely moved in 0.2 s)
    # far off: the paper's ordering (claim 1)
    truth = {r["label"]: float(r["truth_relative_error_max"]) for r in plate}
    assert all(value > 0 for value in truth.values()), truth
    dynamic = [a for a in ALGORITHMS if a != "quasi-static"]
    assert all(truth[a] < 0.2 for a in dynamic), truth
    assert truth["quasi-static"] > 100 * max(truth[a] for a in dynamic), truth


def test_the_plates_truth_computes_in_its_own_process(plate):
    """A truth case registered from elsewhere is not one a worker process knows: the linear
    truths' split (solvers/truth/split.py) leaves it to the process that registered it, in
    whatever order the modules were imported (a fresh process alone failed here, before)."""
    from tissuebench.meshes import in_contact
    from tissuebench.solvers.truth import CASES, PACKAGE_CASES
    from tissuebench.solvers.truth.split import splittable

    assert NAME in CASES and NAME not in PACKAGE_CASES
    assert not in_contact(NAME) and in_contact("contact")  # the plate's entry has no tool
    assert not splittable(NAME)
    assert splittable("rod")  # a package's linear case is split


def test_a_cache_that_lacks_truths_truth_md_reports_leaves_it(plate, tmp_path, cache, capsys):
    """`truth` into a folder whose full truth.md reports truths this cache lacks (a clone's
    results/ on a fresh machine) computes and caches the cases named and leaves truth.md as it
    was, saying so; --force writes it from this cache alone."""
    from tissuebench.solvers.truth.cases import register_case, remove_case
    from tissuebench.solvers.truth.store import is_cached
    from tissuebench.workflows.truth.report import reported

    out = tmp_path / "results"
    register_case("plate-MP1", NAME, "MP1")
    try:
        assert main(["truth", NAME, "plate-MP1", "--jobs", "1", "--out", str(out)]) == 0
        both = (out / "truth.md").read_text()
        assert reported(both) == [NAME, "plate-MP1"]
        os.environ["TISSUEBENCH_CACHE"] = str(tmp_path / "fresh")  # another machine's cache
        capsys.readouterr()
        assert main(["truth", NAME, "--out", str(out)]) == 0
        said = capsys.readouterr().out
        assert "truth.md reports truths this cache lacks (plate-MP1): left as it is" in said
        assert is_cached(NAME) and not is_cached("plate-MP1")
        assert (out / "truth.md").read_text() == both
        assert main(["truth", NAME, "--out", str(out), "--force"]) == 0
        assert reported((out / "truth.md").read_text()) == [NAME]
    finally:
        remove_case("plate-MP1")
