"""A third benchmark defined in the test folder alone (tests/toy_benchmark.py: a 2D plate under
gravity, registered through meshes.register) goes through every command as the rod and the
block do (issue 34 item 1): run, export, compare (two runs; a run against its truth), truth
--quick, the paper's report and the leaderboard, each through the command line's main() in this
process (where the plate is registered). Small sizes: a few seconds each."""

import argparse
import csv
import json

from mpi4py import MPI

import pytest
from toy_benchmark import NAME, registered

from tissuebench.meshes import BENCHMARKS
from tissuebench.solvers.truth.cases import CASES
from tissuebench.workflows.cli import main

pytestmark = pytest.mark.slow  # a minute or more in all: make test starts it first


@pytest.fixture(scope="module")
def plate():
    with registered() as entry:
        yield entry
    assert NAME not in BENCHMARKS and NAME not in CASES


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A truth cache of the test's own."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))


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
def test_paper_report_and_leaderboard(plate, tmp_path, cache, monkeypatch):
    from tissuebench.solvers import ALGORITHMS, MODELS
    from tissuebench.solvers.models import REFERENCE_MODEL, run_label
    from tissuebench.workflows import paper_truth
    from tissuebench.workflows.boards import Board
    from tissuebench.workflows.commands import paper
    from tissuebench.workflows.leaderboard import build
    from tissuebench.workflows.study import algorithm_case, model_case

    # the paper's report on the plate's cases: part 1 (every algorithm) and part 2 (every model)
    first = [algorithm_case("plate-MP3", NAME, "MP3", list(ALGORITHMS), description="Plate")]
    reference = run_label("implicit", REFERENCE_MODEL)
    second = [model_case("plate-MP3-s1", NAME, "MP3", list(ALGORITHMS), list(MODELS), reference)]
    monkeypatch.setattr(paper, "cases", lambda *a: first)
    monkeypatch.setattr(paper, "model_cases", lambda *a: second)
    monkeypatch.setattr(paper_truth, "cases", lambda *a: [])
    monkeypatch.setattr(paper_truth, "missing", lambda comm: [])
    monkeypatch.setattr(paper_truth, "compute", lambda *a, **k: None)
    out = tmp_path / "paper"
    assert main(["paper", "--out", str(out)]) == 0
    readme = (out / "README.md").read_text()
    assert "## plate-MP3" in readme and "plate-MP3-s1" in readme
    assert (out / "plate-MP3" / "errors.png").is_file()

    # the leaderboard on a case of the plate, graded against its truth (which it reads from
    # the cache: computed first, at its full levels, in seconds)
    assert main(["truth", NAME, "--out", str(tmp_path / "truth")]) == 0
    board = Board(
        "plate-MP3", NAME, "MP3", "linear", simulators=(), truth=NAME, description="the plate"
    )
    monkeypatch.setattr(build, "BOARDS", [board])
    args = argparse.Namespace(
        out=tmp_path / "board", solver="direct", petsc="", force=False, rerun=[]
    )
    assert build.main(args) == 0
    table = rows(tmp_path / "board" / "leaderboard.csv")
    assert {r["case"] for r in table} == {"plate-MP3"}
    assert len(table) >= len(ALGORITHMS)
    print(table[0])
    print([r["label"] for r in table])
