"""A truth being computed (issue 33): the computing process holds the case's lock, any other
that needs the case waits for it, says so and reads its result instead of computing it
again; a lock whose process has gone is removed. `truth all --jobs 2` computes two cases at
a time in worker processes, each under its lock, and caches the same truths as one at a time.

The waiting tests use small synthetic truths (test_newcomer_truth_cache.synthetic) in a
cache of their own; the command test computes two quick truths for real."""

import json
import subprocess
import threading
import time
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import tissuebench
from test_newcomer_truth_cache import synthetic

from tissuebench.solvers.truth import store
from tissuebench.solvers.truth.samples import TruthSamples

pytestmark = [pytest.mark.serial, pytest.mark.slow]  # other processes hold the locks


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(store, "WAIT_POLL_SECONDS", 0.05)
    return store.cache_path("rod", quick=True)


@pytest.fixture
def computed(monkeypatch):
    """The cases store.compute is asked for (a synthetic truth each), with the lock's holder
    at that moment."""
    calls = []

    def compute(case, quick=False, comm=None, log=None):
        calls.append((case, store.computing(case, quick), store.lock_path(case, quick).exists()))
        return synthetic(case, quick)

    monkeypatch.setattr(store, "compute", compute)
    return calls


def hold_lock(case: str, holder: int, **fields) -> Path:
    """Write by hand the lock that process `holder` would hold on `case` (quick), started 2 min
    ago with an estimate of 10 min, with `fields` changed (None: left out)."""
    lock = store.lock_path(case, True)
    lock.parent.mkdir(parents=True, exist_ok=True)
    held = {
        "pid": holder,
        "started": time.time() - 120,
        "expected_s": 600,
        **store.process_identity(holder),
        "cache": str(lock.parent),
    }
    held.update(fields)
    lock.write_text(json.dumps({k: v for k, v in held.items() if v is not None}))
    return lock


def test_a_reader_waits_for_the_process_computing_it_and_reads_its_result(cache, computed):
    other = subprocess.Popen(["sleep", "60"])  # the process computing the case
    try:
        hold_lock("rod", other.pid)
        lines = []

        def finish():  # what the other process does when its computation ends
            time.sleep(0.5)
            synthetic().save(cache)
            store.lock_path("rod", True).unlink()

        threading.Thread(target=finish).start()
        samples = store.truth_samples("rod", quick=True, log=lines.append)
    finally:
        other.kill()
        other.wait()
    assert computed == []  # read, not computed again
    assert isinstance(samples, TruthSamples) and samples.case == "rod"
    waiting = [line for line in lines if "being computed by process" in line]
    assert len(waiting) == 1 and f"process {other.pid} for 2 min" in waiting[0]
    assert "about 8 min left" in waiting[0]


def test_a_lock_whose_process_has_gone_is_removed_and_the_case_computed(cache, computed):
    gone = subprocess.Popen(["true"])
    gone.wait()
    hold_lock("rod", gone.pid)
    samples = store.truth_samples("rod", quick=True)
    assert samples is not None and store.load_cached("rod", quick=True) is not None
    # computed once, under a lock of this process's own, which is gone afterwards
    assert [(case, exists) for case, _, exists in computed] == [("rod", True)]
    assert computed[0][1] is None  # computing() ignores this process's own lock
    assert not store.lock_path("rod", True).exists()


YESTERDAY = "yesterday"
HOSTILE_LOCKS = {  # the lock's fields as written by hand: what makes each not hold
    "not-tissuebench": ({"process_start": None, "command": None}, "not identified"),
    "pid-reused": ({"process_start": 1}, "another process now"),
    "other-command": ({"command": "tissuebench\0truth\0rod\0"}, "not the process that wrote"),
    "pid-0": ({"pid": 0}, "invalid pid (0)"),
    "pid-negative": ({"pid": -1}, "invalid pid (-1)"),
    "pid-text": ({"pid": "1234"}, "invalid pid"),
    "pid-bool": ({"pid": True}, "invalid pid"),
    "started-yesterday": ({"started": YESTERDAY}, "invalid start time ('yesterday')"),
    "started-nan": ({"started": float("nan")}, "invalid start time"),
    "started-future": ({"started": time.time() + 86400}, "in the future"),
    "started-missing": ({"started": None}, "invalid start time (None)"),
    "estimate-text": ({"expected_s": "long"}, "invalid estimate"),
    "estimate-negative": ({"expected_s": -5}, "invalid estimate"),
    "other-cache": ({"cache": "/elsewhere/cache/truth"}, "another cache"),
    "too-old": ({"started": time.time() - 2 * 86400}, "times its estimate"),
}


@pytest.mark.parametrize("name", HOSTILE_LOCKS)
def test_a_lock_that_does_not_hold_is_taken_over_in_one_line(cache, computed, name):
    """A lock naming a live process that is not the one that wrote it (not tissuebench, a
    reused id, another command line), a field invalid, another cache's, or older than its
    estimate times the bound: taken over at once with one line, and the case computed (no wait
    for ever, no traceback)."""
    fields, said = HOSTILE_LOCKS[name]
    other = subprocess.Popen(["sleep", "60"])  # alive, and not tissuebench
    try:
        lock = hold_lock("rod", other.pid, **fields)
        lines: list[str] = []
        started = time.monotonic()
        samples = store.truth_samples("rod", quick=True, log=lines.append)
    finally:
        other.kill()
        other.wait()
    assert time.monotonic() - started < 30  # computed (synthetic), not waited for
    assert samples is not None and [case for case, _, _ in computed] == ["rod"]
    taken = [line for line in lines if "took over" in line]
    assert len(taken) == 1 and str(lock) in taken[0] and said in taken[0], lines
    assert not lock.exists()


@pytest.mark.parametrize(
    "text", [b"", b"{", b"[1, 2]", b'"pid"', b"{" * 100_000, b"\0\xff\xfe", b'{"pid": 1e999}']
)
def test_a_lock_that_cannot_be_parsed_is_taken_over(cache, computed, text):
    lock = store.lock_path("rod", True)
    lock.parent.mkdir(parents=True, exist_ok=True)
    lock.write_bytes(text)
    lines: list[str] = []
    assert store.load_cached("rod", quick=True, log=lines.append) is None  # a reader
    assert len(lines) == 1 and "took over" in lines[0] and not lock.exists(), lines


@pytest.mark.parametrize("kind", ["folder", "fifo", "link"])
def test_a_lock_that_is_not_a_file_neither_blocks_nor_hangs(cache, computed, kind):
    """A folder, a FIFO (reading it would block) or a link at the lock's name: said, and the
    case computed (without a lock where the folder cannot be removed)."""
    import os

    lock = store.lock_path("rod", True)
    lock.parent.mkdir(parents=True, exist_ok=True)
    if kind == "folder":
        (lock / "inside").mkdir(parents=True)
    elif kind == "fifo":
        os.mkfifo(lock)
    else:
        lock.symlink_to("/dev/zero")
    lines: list[str] = []
    samples = store.truth_samples("rod", quick=True, log=lines.append)
    assert samples is not None and [case for case, _, _ in computed] == ["rod"]
    assert any("took over" in line and "not a file" in line for line in lines), lines
    assert lock.is_dir() if kind == "folder" else not lock.exists()


def test_a_lock_taken_over_is_not_removed_by_the_process_that_held_it(cache, computed, monkeypatch):
    """The computation ends after its lock was taken over: it leaves the new holder's lock."""
    holder = subprocess.Popen(["sleep", "60"])
    compute = store.compute  # the computed fixture's

    def taken_over(case, quick=False, comm=None, log=None):
        hold_lock(case, holder.pid)  # another process took the lock over meanwhile
        return compute(case, quick, comm, log)

    monkeypatch.setattr(store, "compute", taken_over)
    try:
        store.truth_samples("rod", quick=True)
        held = json.loads(store.lock_path("rod", True).read_text())
    finally:
        holder.kill()
        holder.wait()
    assert held["pid"] == holder.pid


def test_the_lock_goes_when_the_computation_fails(cache, monkeypatch):
    def fail(case, quick=False, comm=None, log=None):
        assert store.lock_path(case, quick).exists()
        raise RuntimeError("truth: Newton did not converge")

    monkeypatch.setattr(store, "compute", fail)
    with pytest.raises(RuntimeError, match="Newton"):
        store.truth_samples("rod", quick=True)
    assert not store.lock_path("rod", True).exists()


def test_truth_all_with_two_jobs_caches_what_one_at_a_time_does(tmp_path, monkeypatch):
    """Two quick cases, two workers at once, in a cache of their own: the same truths, value for
    value and under the same keys, as computed one at a time in one process (store.truth_samples
    in this one, from the suite's shared cache, where the other tests' quick truths are, or
    computed into it here)."""
    cases = ("rod", "block-MP1-w0.2")
    one_at_a_time = {c: store.truth_samples(c, quick=True, comm=MPI.COMM_SELF) for c in cases}
    names = {c: store.cache_path(c, True).name for c in cases}
    cache, out = tmp_path / "cache", tmp_path / "out"
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))
    result = tissuebench("truth", *cases, "--quick", "--jobs", "2", "--out", str(out))
    assert result.returncode == 0, result.stderr[-2000:]
    said = result.stdout
    assert "truth: computing 2 cases, 2 processes at a time" in said
    assert said.count("truth: started ") == 2 and said.count(" s of CPU; ") == 2
    assert "[block-MP1-w0.2] block-MP1-w0.2 n=40:" in said  # a worker's lines, with its case
    assert (out / "truth.md").is_file()
    for case in cases:
        (a,) = (cache / "truth").glob(f"{case}-quick-*.npz")
        assert a.name == names[case]  # the same inputs, the same key
        with np.load(a) as x:
            assert np.array_equal(x["u_points"], one_at_a_time[case].u_points)
    assert not list((cache / "truth").glob(".*.computing"))


def test_a_reader_that_does_not_wait_says_the_case_is_being_computed(cache):
    """load_cached (the leaderboard's reader) does not wait: one line says who computes it."""
    other = subprocess.Popen(["sleep", "60"])
    try:
        hold_lock("rod", other.pid)
        lines = []
        assert store.load_cached("rod", quick=True, log=lines.append) is None
    finally:
        other.kill()
        other.wait()
    assert len(lines) == 1 and f"being computed by process {other.pid}" in lines[0]
    assert lines[0].endswith("not read until it ends")


def test_truth_md_states_how_long_the_cache_took_to_compute():
    """From each case's file time and own wall time: the span from the first start to the
    last write; no line where a case is missing or the cases were computed at other times."""
    from tissuebench.solvers.truth.cases import CASES
    from tissuebench.workflows.truth.report import computed_words

    # two at a time: cases of 600 s each, ending at 600, 600, 1200, 1200, ...
    summaries = {
        c: {"cached_at": 1e9 + 600 * (1 + k // 2), "hierarchy": {"total_wall": 600.0}}
        for k, c in enumerate(CASES)
    }
    (line, blank) = computed_words(summaries)
    last = 600 * (1 + (len(CASES) - 1) // 2)  # the last pair's end (a last case alone: its own)
    assert f"{last} s of wall time in all" in line
    assert f"add up to {600 * len(CASES)} s" in line and blank == ""
    assert computed_words({c: summaries[c] for c in list(CASES)[1:]}) == []
    summaries[next(iter(CASES))]["cached_at"] = 1e9 - 86400  # a day before the others
    assert computed_words(summaries) == []


def test_beside_other_busy_processes_every_estimate_is_longer():
    """Workers beside the paper's own busy process share the cores with it: every estimate,
    the workers' own (their TISSUEBENCH_SLOWDOWN) included, is (jobs + beside) / jobs longer."""
    from tissuebench.core.speed import slowdown
    from tissuebench.workflows.truth.jobs import TruthJobs, left_seconds

    cases = ["rod", "block-MP1-w0.2", "block-MP2-w0.2"]
    alone = left_seconds(cases, [], False, 2)
    assert left_seconds(cases, [], False, 2, beside=1) == pytest.approx(1.5 * alone)
    work = TruthJobs(cases, False, 2, lambda line: None, beside=1)
    assert float(work.env["TISSUEBENCH_SLOWDOWN"]) == pytest.approx(1.5 * slowdown())
    assert float(TruthJobs(cases, False, 2, lambda line: None).env["TISSUEBENCH_SLOWDOWN"]) == (
        pytest.approx(slowdown())
    )
