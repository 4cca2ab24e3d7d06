"""`tissuebench paper` on a machine where its truths are not cached (issue 36): it says which
and how long before it starts, then computes them (their expected time and progress said)
and grades against them, so that a first run writes the report we publish rather than "not
cached". The truths' computation, the study's runs and the grading are replaced here (a full
truth takes minutes): what is checked is which truths are computed, when, and what is said."""

import argparse
from pathlib import Path

from mpi4py import MPI

import pytest
from test_newcomer_truth_cache import agreed, synthetic

from tissuebench.solvers.truth import store
from tissuebench.workflows.commands import paper
from tissuebench.workflows.study import paper as study_paper
from tissuebench.workflows.study import truth as paper_truth

COMM = MPI.COMM_WORLD


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty truth cache; the truths' computation replaced by synthetic ones (`computed`
    lists the cases computed)."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))
    computed = []

    def compute(case, quick=False, comm=COMM, log=None):
        computed.append(case)
        return synthetic(case, quick) if comm.rank == 0 else None

    monkeypatch.setattr(store, "compute", compute)
    return computed


def test_a_first_run_says_which_truths_it_computes_and_how_long(cache):
    assert paper_truth.missing(COMM) == ["rod", "block-MP1-w0.2", "block-MP2-w0.2"]
    line = paper_truth.first_run_line(paper_truth.missing(COMM))
    assert line == (
        "paper: the truths rod (about 65 s), block-MP1-w0.2 (about 83 s), block-MP2-w0.2 "
        "(about 4 min) are not cached on this machine: computed once in this run, after the "
        f"paper's cases (about 7 min in all on one core); later runs read them from "
        f"{store.cache_dir()}"
    )
    # two processes: each linear case's runs side by side (split.py), one case after another,
    # each as long as its busiest process, then 10 s in one: 0.62 x 55 + 0.54 x 73 + 0.54 x 259
    # + 3 x 10 s = 243 s; beside the paper's own process, 3 on the 2 cores: x 3/2, 365 s
    assert (
        "computed once in this run, 2 processes at a time beside the paper's cases (about 6 min "
        "here)"
    ) in paper_truth.first_run_line(paper_truth.missing(COMM), jobs=2)
    store.truth_samples("rod", comm=COMM)
    assert paper_truth.missing(COMM) == ["block-MP1-w0.2", "block-MP2-w0.2"]


def test_the_paper_computes_the_truths_it_needs_then_reads_them(cache, monkeypatch):
    monkeypatch.setattr(paper_truth, "run_case", lambda *args, **kwargs: None)
    graded = []

    def grade_runs(folder, labels, truth, comm):
        graded.append((Path(folder).name, truth.case if comm.rank == 0 else None))
        return {
            label: {f"{m}_{r}": 1e-3 for m in paper_truth.METRICS for r in paper_truth.READINGS}
            for label in labels
        }

    monkeypatch.setattr(paper_truth, "grade_runs", grade_runs)
    said = []
    out = Path(COMM.bcast(str(Path(store.cache_dir()).parent.parent / "results")))
    result = paper_truth.compute(out, COMM, log=said.append)
    failures = []
    if cache != ["rod", "block-MP1-w0.2", "block-MP2-w0.2"]:
        failures.append(f"computed {cache}")
    if result.missing != [] or set(result.graded) != set(paper_truth.TRUTHS):
        failures.append(f"missing {result.missing}, graded {list(result.graded)}")
    if any(c.holds is None for c in result.claims):
        failures.append("a claim not judged")
    if COMM.rank == 0:
        for name in paper_truth.TRUTHS:  # its expected time first, then it is cached
            first = (
                f"truth {name}: not in the cache, computing it once ({store.expected_words(name)}"
            )
            if not any(line.startswith(first) for line in said):
                failures.append(f"not said: {first}")
            if not store.cache_path(name).is_file():
                failures.append(f"{name} not cached")
        if [truth for _, truth in graded] != list(paper_truth.TRUTHS):
            failures.append(f"graded against {graded}")
    said.clear()
    paper_truth.compute(out, COMM, log=said.append)  # a second run reads them
    if len(cache) != 3:
        failures.append(f"computed again: {cache}")
    if COMM.rank == 0 and sum("from the cache" in line for line in said) != 3:
        failures.append(f"not read from the cache: {said}")
    assert agreed(failures) == []


class Started(Exception):
    """The paper's first case began."""


@pytest.mark.serial
def test_the_paper_says_it_before_its_first_case(cache, tmp_path, monkeypatch, capsys):
    def first_case(*args, **kwargs):
        raise Started

    monkeypatch.setattr(study_paper, "run_case", first_case)
    args = argparse.Namespace(
        out=tmp_path / "results", solver="direct", petsc="", force=False, jobs=1
    )
    with pytest.raises(Started):
        paper.main(args)
    out = capsys.readouterr().out.strip().splitlines()
    assert out == [paper_truth.first_run_line(list(paper_truth.TRUTHS))]


@pytest.mark.serial
def test_the_paper_starts_its_truths_side_by_side_before_its_first_case(
    cache, tmp_path, monkeypatch, capsys
):
    started = []

    def first_case(*args, **kwargs):
        raise Started

    class SideBySide:  # the truths' workers, started and then stopped by the signal
        def __init__(self, cases, quick, jobs, say, beside=0):
            self.pending = list(cases)
            started.append((list(cases), quick, jobs))

        def start(self):
            started.append("started")

        def stop(self):
            started.append("stopped")

    monkeypatch.setattr(study_paper, "run_case", first_case)
    monkeypatch.setattr(study_paper, "TruthJobs", SideBySide)
    args = argparse.Namespace(
        out=tmp_path / "results", solver="direct", petsc="", force=False, jobs=2
    )
    with pytest.raises(Started):
        paper.main(args)
    assert started == [(list(paper_truth.TRUTHS), False, 2), "started", "stopped"]
    out = capsys.readouterr().out.strip().splitlines()
    assert out == [paper_truth.first_run_line(list(paper_truth.TRUTHS), jobs=2)]


@pytest.mark.serial
def test_each_truth_is_graded_as_soon_as_its_worker_ends(cache, tmp_path, monkeypatch):
    """With the truths computed side by side, the paper grades each one while the workers of
    the others still run (not all after the last has ended), each once, and its section lists
    them in their order (rod, block-MP1, block-MP2) whatever order they ended in."""
    events = []
    state = {"polls": None}  # the workers' polls since the truth's runs were made

    class Workers:  # after them: block-MP2 ends at the 2nd poll, block-MP1 the 4th, rod the 6th
        def __init__(self, cases, quick, jobs, say, beside=0):
            self.pending, self.succeeded = list(cases), []

        def start(self):
            pass

        def poll(self):
            if state["polls"] is None:
                return True
            state["polls"] += 1
            ends = {2: "block-MP2-w0.2", 4: "block-MP1-w0.2", 6: "rod"}
            if state["polls"] in ends:
                self.succeeded.append(ends[state["polls"]])
            events.append(("poll", state["polls"] < 6))
            return state["polls"] < 6

        def stop(self):
            pass

    def run_folders(*args, **kwargs):
        state["polls"] = 0
        return {}

    def grade(name, folders, comm, log=print):
        events.append(("grade", name))
        return {}, 1e-6

    assembled = []
    monkeypatch.setattr(study_paper, "TruthJobs", Workers)
    monkeypatch.setattr(study_paper, "POLL_SECONDS", 0.0)
    monkeypatch.setattr(study_paper, "run_case", lambda *args, **kwargs: None)
    monkeypatch.setattr(study_paper, "explicit_limits", lambda *args: {})
    monkeypatch.setattr(study_paper.report, "paper_report", lambda *args: "report\n")
    monkeypatch.setattr(paper_truth, "run_folders", run_folders)
    monkeypatch.setattr(paper_truth, "grade", grade)
    monkeypatch.setattr(
        paper_truth, "assemble", lambda graded, own, missing: assembled.append(list(graded))
    )
    study_paper.run_paper(tmp_path / "results", jobs=2)
    grades = [name for kind, name in events if kind == "grade"]
    assert sorted(grades) == sorted(paper_truth.TRUTHS)  # each once
    last_poll = max(i for i, e in enumerate(events) if e[0] == "poll")
    graded_at = {name: events.index(("grade", name)) for name in grades}
    # block-MP2 and block-MP1 graded while the rod's worker still ran; the rod after it ended
    assert graded_at["block-MP2-w0.2"] < graded_at["block-MP1-w0.2"] < last_poll
    assert graded_at["rod"] > last_poll
    assert assembled == [list(paper_truth.TRUTHS)]
