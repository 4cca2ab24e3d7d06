"""Issue 61 item 2: the bench's bandwidth table (bytes moved, the step's achieved bandwidth
beside the triad's) and the load of other processes during a measurement (the threshold, the
one rerun of a noisy measurement, what the rows say), on synthetic numbers."""

import math
import subprocess
import sys

import pytest

from tissuebench.workflows.bench import machine
from tissuebench.workflows.bench.measure import run_quiet
from tissuebench.workflows.bench.report import load_text
from tissuebench.workflows.bench.tables import bandwidth_rows, load_cell
from tissuebench.workflows.bench.workers import explicit_lumped_bytes

LIMIT = machine.LOAD_LIMIT


def side(step_s, triad_Bps, others, reruns=0, bytes_=None):
    record = {"step_s": step_s, "matrix_type": "block CSR"}
    if bytes_ is not None:
        record["bytes"] = bytes_
    return {
        "cases": {"explicit-lumped/-": record},
        "triad_Bps": triad_Bps,
        "load": {"others_cores": others, "loadavg_1min": 1.0, "wall_s": 10.0},
        "reruns": reruns,
    }


def test_bytes_of_one_step():
    """The matrix once and 9 vectors of doubles (one pass: 6 read, 3 written)."""
    assert explicit_lumped_bytes(1000, 10) == 1000 + 9 * 8 * 10


def test_bandwidth_row_states_bytes_achieved_bandwidth_and_load():
    dofs, nbytes = 200_000, 400 * 2**20
    record = {
        "benchmark": "rod",
        "size": 32,
        "dofs": dofs,
        "ours1": side(0.1, 8e9, 0.05, bytes_=nbytes),
        "ours2": side(0.08, 9e9, LIMIT + 0.5, reruns=1),
        "peer": {"cases": {}},
    }
    header, rows = bandwidth_rows([record])
    row = dict(zip(header, rows[0], strict=True))
    assert row["MiB moved"] == pytest.approx(400)
    assert row["bytes/dof"] == pytest.approx(nbytes / dofs)
    assert row["triad 1r GB/s"] == pytest.approx(8.0)
    assert row["step 1r GB/s"] == pytest.approx(nbytes / 0.1 / 1e9)
    assert row["step 2r GB/s"] == pytest.approx(nbytes / 0.08 / 1e9)
    assert row["meas/limit 1r"] == pytest.approx(0.1 / (nbytes / 8e9))
    assert row["others' load 1r (cores)"] == "0.05"
    assert row["others' load 2r (cores)"] == f"{LIMIT + 0.5:.2f} (> {LIMIT:g}: noisy) rerun"


def test_load_cell_and_threshold():
    assert not machine.noisy({"others_cores": LIMIT})
    assert machine.noisy({"others_cores": LIMIT + 1e-9})
    assert not machine.noisy(None) and not machine.noisy({"others_cores": math.nan})
    assert load_cell({}) == "-" and load_cell({"load": {"others_cores": math.nan}}) == "-"
    assert load_cell({"load": {"others_cores": 0.1}, "reruns": 1}) == "0.10 rerun"


def fake_runs(loads):
    """A stand-in for run_worker whose successive results carry these others' loads."""
    calls = []

    def run(kind, ranks, spec, tmp, tag, timeout):
        calls.append(tag)
        others = loads[len(calls) - 1]
        return {"cases": {}, "n": len(calls), "load": {"others_cores": others}}

    return run, calls


@pytest.mark.parametrize(
    "loads, calls, kept",
    [
        ([0.1], 1, 1),  # quiet: once
        ([LIMIT + 0.3, 0.05], 2, 2),  # noisy, then quiet: the rerun kept
        ([LIMIT + 0.3, LIMIT + 0.6], 2, 1),  # noisy twice: the quieter kept, and no third run
    ],
)
def test_a_noisy_measurement_is_taken_once_more(loads, calls, kept, tmp_path):
    run, made = fake_runs(loads)
    lines = []
    result = run_quiet("ours", 1, {}, tmp_path, "rod-32-ours1", 60.0, lines.append, run=run)
    assert len(made) == calls and result["n"] == kept
    assert result["reruns"] == calls - 1 and len(lines) == calls - 1
    if calls == 2:
        assert result["first_load"]["others_cores"] == loads[0]
        assert "rod-32-ours1" in lines[0] and "once more" in lines[0]


def test_load_text_counts_reruns_and_noisy_measurements():
    records = [
        {"ours1": side(0.1, 8e9, 0.0), "ours2": side(0.1, 8e9, LIMIT + 1, reruns=1)},
        {"ours1": side(0.1, 8e9, 0.1, reruns=1)},
    ]
    text = load_text(records)
    assert "2 of 3 measurements were taken again, and 1 stayed noisy" in text
    assert "rows say so" in text
    assert load_text([{"ours1": side(0.1, 8e9, 0.0)}]).endswith("0 stayed noisy.")


def test_load_meter_numbers():
    """Around a child process that spins for 0.5 s (its CPU time is the measurement's own, not
    another process's), the meter's numbers are finite and non-negative where /proc/stat is
    readable."""
    if math.isnan(machine.busy_seconds()):
        pytest.skip("no /proc/stat")
    meter = machine.LoadMeter()
    subprocess.run(
        [sys.executable, "-c", "import time\nt = time.time()\nwhile time.time() - t < 0.5: pass"],
        check=True,
    )
    load = meter.stop()
    assert load["wall_s"] >= 0.5 and load["others_cores"] >= 0 and load["loadavg_1min"] >= 0


def test_limit_uses_the_triad_sampled_between_the_steps():
    """Where a side's step carries triad samples, its limit and the peer comparison at equal
    bandwidth use their median, not the worker's one triad taken before (issue 61: that one
    swung 14.5-20.1 GB/s within an hour)."""
    nbytes, peer_bytes = 400 * 2**20, 500 * 2**20
    ours1 = side(0.1, 20e9, 0.0, bytes_=nbytes)
    ours1["cases"]["explicit-lumped/-"].update(triad_Bps=5e9, triad_samples_Bps=[4e9, 5e9, 7e9])
    peer = {
        "cases": {"explicit-lumped/-": {"step_s": 0.2, "triad_Bps": 10e9}},
        "explicit_lumped_bytes": peer_bytes,
    }
    record = {"benchmark": "rod", "size": 48, "dofs": 200_000, "ours1": ours1, "peer": peer}
    header, rows = bandwidth_rows([record])
    row = dict(zip(header, rows[0], strict=True))
    assert row["triad 1r GB/s"] == pytest.approx(5.0)
    assert row["triad 1r spread GB/s"] == "4.0-7.0"
    assert row["meas/limit 1r"] == pytest.approx(0.1 / (nbytes / 5e9))
    assert row["peer meas/limit (CSR)"] == pytest.approx(0.2 / (peer_bytes / 10e9))
    assert row["ours/peer"] == pytest.approx(0.5)
    assert row["ours/peer at equal triad"] == pytest.approx(0.1 * 5e9 / (0.2 * 10e9))


def test_triad_is_sampled_before_the_first_step_and_after_every_fifth():
    """triad.timed_steps on a real triad: 1 + steps // TRIAD_EVERY samples, each a finite
    positive bandwidth, the steps timed in order and the state carried through."""
    from mpi4py import MPI

    from tissuebench.workflows.bench.triad import TRIAD_EVERY, Triad, timed_steps

    triad = Triad(MPI.COMM_WORLD, size=2**16)
    times: list[float] = []
    seen = []
    try:
        state, samples = timed_steps(
            lambda s: s + 1, 0, 12, MPI.COMM_WORLD, times, triad, after=lambda: seen.append(1)
        )
    finally:
        triad.destroy()
    assert state == 12 and len(times) == 12 and len(seen) == 12
    assert len(samples) == 1 + 12 // TRIAD_EVERY
    assert all(math.isfinite(b) and b > 0 for b in samples)
    assert triad.nbytes == 3 * 8 * 2**16


def test_a_target_the_triad_forbids_says_so():
    """Issue 61's done-when: a missed explicit-lumped target says where the bandwidth measured
    beside the step forbids it. Ours/peer: forbidden where 0.7 x the peer's step is shorter
    than our own limit (bytes / our triad); the 2-rank speed-up: where the 2-rank triad is
    less than 1.7 x the 1-rank one. Synthetic numbers: one size of each kind."""
    from tissuebench.workflows.bench.targets import targets

    nbytes = 100e6

    def record(size, ours_s, ours_triad, peer_s, ours2_s, triad2):
        ours1 = side(ours_s, ours_triad, 0.0, bytes_=nbytes)
        ours2 = side(ours2_s, triad2, 0.0, bytes_=nbytes)
        for ours in (ours1, ours2):
            ours["cases"]["explicit-lumped/-"]["h"] = 1 / 30  # s
        peer = {"cases": {"explicit-lumped/-": {"step_s": peer_s, "triad_Bps": 20e9}}}
        return {
            "benchmark": "rod",
            "size": size,
            "dofs": 300_000,
            "ours1": ours1,
            "ours2": ours2,
            "peer": peer,
        }

    # rod 32: our limit 100e6 / 10e9 = 10 ms > 0.7 x 12 ms: forbidden; its 2 ranks 1.8x
    # rod 48: our limit 5 ms, ours 10 ms, peer 12 ms (0.83): not forbidden; 2 ranks 1.25x on
    # triads 30/20 = 1.5 < 1.7: forbidden
    recs = [
        record(32, 0.011, 10e9, 0.012, 0.011 / 1.8, 30e9),
        record(48, 0.010, 20e9, 0.012, 0.008, 30e9),
    ]
    header, rows = targets(recs)
    status = {row[0]: row[header.index("status")] for row in rows}
    assert status["explicit-lumped step: ours/peer"] == (
        "NOT met; the triad forbids it at rod 32, not at rod 48"
    )
    speed_up = status["2 ranks vs 1: explicit-lumped - step speed-up"]
    assert speed_up == "NOT met; the triad forbids it at rod 48"
    # the 2-rank triad at 1.7 x the 1-rank one: no longer forbidden
    recs[1]["ours2"]["triad_Bps"] = 34e9
    header, rows = targets(recs)
    status = {row[0]: row[header.index("status")] for row in rows}
    assert status["2 ranks vs 1: explicit-lumped - step speed-up"] == "NOT met"
