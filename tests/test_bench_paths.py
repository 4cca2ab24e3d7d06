"""The bench of the user's paths (workflows/bench/paths.py): a command timed whole with its
lines, the estimates it printed read back and set beside the times they estimated, and the
report's verdicts, on commands and lines made here."""

import json
import sys

import pytest

from tissuebench.workflows.bench.paths import (
    ESTIMATE_FACTOR,
    Timed,
    estimates,
    parallel_name,
    phases,
    report,
    seconds_of,
    timed,
)

pytestmark = pytest.mark.serial  # subprocesses


def test_timed_keeps_lines_in_order_with_their_times():
    said: list[str] = []
    code = (
        "import time; print('a', flush=True); print('run:  50%|#####     | 1/2'); "
        "time.sleep(0.3); print('b'); raise SystemExit(3)"
    )
    record = timed("probe", [sys.executable, "-c", code], {}, said.append)
    assert record.code == 3
    assert [line for _, line in record.lines] == ["a", "b"]  # the progress bar's left out
    (ta, _), (tb, _) = record.lines
    assert tb - ta >= 0.25 and record.wall_s >= tb  # b came after the sleep, before the end
    assert said[-1].startswith("probe: ") and "(exit 3)" in said[-1]


def test_seconds_of():
    assert seconds_of("(about 62 s here)") == 62.0
    assert seconds_of("x (about 7 min here); later") == 420.0
    assert seconds_of("no estimate") is None


def test_estimates_read_from_a_paper_and_a_truth():
    paper = Timed("paper, empty truth cache", ["paper"], wall_s=700.0)
    paper.lines = [
        (
            1.0,
            "paper: the truths rod (about 1 min) are not cached on this machine: computed "
            "once in this run, 2 processes at a time before the paper's cases (about 7 min here); "
            "later runs read /c",
        ),
        (1.5, "truth: started block-MP2-w0.2 (about 300 s, its runs 2 at a time)"),
        (
            2.0,
            "  [block-MP2-w0.2] truth block-MP2-w0.2: not in the cache, computing it once "
            "(about 5 min here, its runs 2 at a time; later runs read /c)",
        ),
        (360.0, "truth: block-MP2-w0.2 done in 358 s (700 s of CPU; 1 of 1, 358 s in all)"),
        (600.0, "paper: done"),
    ]
    found = {e["what"]: e for e in estimates(paper)}
    # the worker's own line is not the paper's: only the truth and the paper's truths
    assert set(found) == {"truth block-MP2-w0.2", "paper's truths"}
    assert found["truth block-MP2-w0.2"]["ratio"] == pytest.approx(358 / 300)
    assert found["paper's truths"]["about_s"] == 420.0
    assert found["paper's truths"]["took_s"] == 360.0  # to its last truth's end
    assert all(e["holds"] for e in found.values())

    truth = Timed("truth rod, empty cache", ["truth"], wall_s=100.0)
    truth.lines = [(0.5, "truth rod: not in the cache, computing it once (about 40 s here, x)")]
    (e,) = estimates(truth)
    assert e["ratio"] == pytest.approx(2.5) and not e["holds"]  # beyond ESTIMATE_FACTOR
    assert ESTIMATE_FACTOR < 2.5


def paper_record(wall: float) -> dict:
    """A timed `paper` from an empty truth cache, as measure() records it: `wall` s, exit 0,
    the load 1 before and 2 after."""
    return {
        "name": "paper, empty truth cache",
        "argv": [],
        "code": 0,
        "wall_s": wall,
        "lines": [],
        "load_before": (1.0, 1.0, 1.0),
        "load_after": (2.0, 1.0, 1.0),
    }


def test_report_says_targets_met_or_not():
    record = paper_record(500.0)
    runs = {
        "run rod --no-figures": {
            "phases_s": {"mesh": 0.1, "run implicit": 1.0},
            "loop_s": 1.0,
            "outside_s": 3.0,
        }
    }
    text = report(
        {"when": "now", "slowdown": 1.0, "records": [record], "estimates": [], "runs": runs}, "m"
    )
    assert "| paper, empty truth cache | 500.0 | 480 | NOT met | ok | 1.0 / 2.0 |" in text
    assert "NOT met (at most 3.0 s)" in text
    record["wall_s"] = 479.0
    runs["run rod --no-figures"]["outside_s"] = 1.5
    text = report(
        {"when": "now", "slowdown": 1.0, "records": [record], "estimates": [], "runs": runs}, "m"
    )
    assert "| 479.0 | 480 | met |" in text and "--no-figures: met." in text


def test_phases_take_the_truth_grading_that_follows_them(tmp_path):
    phases_s = {"mesh": 0.5, "run implicit": 1.0, "run explicit": 2.0, "metrics": 3.0}
    (tmp_path / "summary.json").write_text(json.dumps({"phases_s": phases_s}))
    record = Timed("run rod", ["run"], wall_s=9.0)
    record.lines = [(8.0, "out: against the truth     1.25 s"), (8.1, "results in out")]
    r = phases(tmp_path, record)
    assert r["loop_s"] == 3.0 and r["outside_s"] == 0.5 + 3.0 + 1.25 and r["command_s"] == 9.0


def test_report_sets_one_rank_beside_two_outside_the_run_target():
    def run(whole, metrics):
        return {"phases_s": {"metrics": metrics}, "loop_s": 1.0, "outside_s": 40.0,
                "command_s": whole}  # fmt: skip

    runs = {
        "run rod --no-figures": {"phases_s": {}, "loop_s": 0.5, "outside_s": 1.5},
        parallel_name(1): run(60.0, 40.0),
        parallel_name(2): run(40.0, 20.0),
    }
    text = report(
        {"when": "now", "slowdown": 1.0, "records": [], "estimates": [], "runs": runs}, "m"
    )
    assert "the whole command 60.0 s on one rank, 40.0 s on two (1.50 x)" in text
    assert "its metrics 40.0 s on one rank, 20.0 s on two (2.00 x)" in text
    assert "--no-figures: met." in text  # the paper's run alone: the larger rod's 40 s is not in it


def test_a_full_bench_reports_the_paths_it_timed(tmp_path, monkeypatch):
    """measure_into writes performance-paths.md and .json and returns what it measured;
    performance.md's section (report.paths_section) gives the same table and run's verdict, and
    says where a quick run left the paths untimed."""
    from tissuebench.workflows.bench import paths
    from tissuebench.workflows.bench.report import paths_section

    record = paper_record(300.0)
    runs = {
        "run block --no-figures": {
            "phases_s": {"run implicit": 1.0},
            "loop_s": 1.0,
            "outside_s": 2.5,
        }
    }
    measured = {"when": "now", "slowdown": 0.8, "records": [record], "estimates": [], "runs": runs}
    monkeypatch.setattr(paths, "measure", lambda work, log: dict(measured))
    result = paths.measure_into(tmp_path, lambda line: None, command="tissuebench bench")
    assert json.loads((tmp_path / "performance-paths.json").read_text()) == json.loads(
        json.dumps(result)
    )
    written = (tmp_path / "performance-paths.md").read_text()
    assert written.startswith("# The paths a user waits on\n\n`tissuebench bench` (now;")
    section = "\n".join(paths_section(result))
    row = "| paper, empty truth cache | 300.0 | 480 | met | ok | 1.0 / 2.0 |"
    assert row in section and row in written
    assert "--no-figures: NOT met (at most 2.5 s)." in section
    assert "Not timed in a quick run" in "\n".join(paths_section(None))


def test_the_warm_papers_time_by_part_and_kind(tmp_path):
    """paper_parts sums each case's phases by part of the study and kind of phase, from the
    folders of the study's own cases (others in OUT, and cases not run, are not counted); the
    report gives the table with its sum and the paper's wall time beside it, and leaves the
    section out of a run that did not measure it."""
    from tissuebench.workflows.bench import paper_parts
    from tissuebench.workflows.study.common import LARGE_DEFORMATION

    def case(folder, runs, phases_s):
        folder.mkdir(parents=True)
        summary = {"runs": dict.fromkeys(runs, {}), "phases_s": phases_s}
        (folder / "summary.json").write_text(json.dumps(summary))
        return folder

    large = tmp_path / LARGE_DEFORMATION
    big = {"run a+svk": 10.0, "run b+svk": 20.0, "metrics": 30.0, "figures": 5.0}
    parts = {
        paper_parts.PART_1: [
            case(tmp_path / "rod", "ab", {"mesh": 0.5, "run a": 1.0, "run b": 2.0, "metrics": 3.0}),
            tmp_path / "not-run",
        ],
        paper_parts.TRUTH: [
            case(tmp_path / "t", "a", {"run a": 0.25, "figures": 4.0, "output": 1.0})
        ],
        paper_parts.PART_2: [
            case(large / "rod-s3", "abcd", big),
            case(large / "block-s2", "ab", {"run a": 1.0, "forms": 0.5}),
        ],
    }
    case(tmp_path / "leaderboard", "abc", {"run a": 100.0})  # not the paper's
    found = paper_parts.paper_parts(tmp_path, parts)
    one, two, truth = (
        found[p] for p in (paper_parts.PART_1, paper_parts.PART_2, paper_parts.TRUTH)
    )
    assert (one["cases"], one["runs"], one["time loops"], one["metrics"], one["the rest"]) == (
        1, 2, 3.0, 3.0, 0.5)  # fmt: skip
    assert (two["cases"], two["runs"], two["time loops"], two["metrics"], two["the rest"]) == (
        2, 6, 31.0, 30.0, 0.5)  # fmt: skip
    assert (truth["time loops"], truth["figures"], truth["output"]) == (0.25, 4.0, 1.0)
    lines = paper_parts.table(found, wall_s=40.0)
    total = 6.5 + 66.5 + 5.25
    all_row = f"| all the cases | 4 | 9 | 34.2 | 33.0 | 9.0 | 1.0 | 1.0 | {total:.1f} | 100% |"
    assert all_row in lines
    assert lines[-1].endswith(f"add up to {total:.1f} s of one core's time (1.96 x the wall time).")
    assert paper_parts.paper_parts(tmp_path / "leaderboard") == {}  # no case of the study
    record = paper_record(300.0) | {"name": "paper, warm", "wall_s": 40.0}
    result = {"when": "now", "slowdown": 1.0, "records": [record], "estimates": [], "runs": {}}
    assert "## Where the warm `paper`" not in report(result, "m")
    text = report(result | {"paper_parts": found}, "m")
    assert "## Where the warm `paper` spends its time" in text and lines[-1] in text
