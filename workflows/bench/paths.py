"""The paths a user waits on, each timed as a whole command, in one run (issue 46):
`tissuebench bench --only paths [--out results]` writes OUT/performance-paths.md and .json.

In order, each in a process of its own (the venv's tissuebench), its output read line by line
with the time each line came:

1. `truth rod` and `truth contact-MP1` (SPEC 12: its levels, its half step and its penalty
   check, about 13 min) from an empty truth cache (a folder of the run's own);
2. `paper` from an empty truth cache (another), as a first `make paper` is: its truths
   computed first, --jobs at a time, then the study; and `paper` again into a new folder, warm
   (its truths cached, its forms compiled), with where its time goes by part of the study
   and kind of phase (workflows/bench/paper_parts.py);
3. `run rod` and `run block` (the paper's rod and block, their defaults), warm: with
   --no-figures and with figures, their phases (summary.json's phases_s) split into the time
   loops ("run ...") and the rest; and `run rod --mesh-size PARALLEL_N --no-figures` on one
   rank and under `mpiexec -n 2`, side by side;
4. `compare truth:rod CANDIDATE` of a candidate of about 1e5 nodes (the rod's hexahedra at
   n = 36, 99,937 nodes, a synthesised series at the truth's 301 steps:
   workflows/bench/grading.py's);
5. `leaderboard` grading 200 users' rows (workflows/bench/leaderboard_users.py, one rank).

Every estimate a command printed ("about N s", "about N min") is set beside the time it
estimated: `truth`'s for its computation (its wall time), `paper`'s for its truths (from its
start to its last truth's end) and each truth's (its worker's own line "done in T s"). The
machine's speed (core/speed.py's slowdown, which scales every estimate) and load average are
recorded around each command. Targets: TARGETS; estimates hold within ESTIMATE_FACTOR.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

NAMES = ("performance-paths.json", "performance-paths.md")
ESTIMATE_FACTOR = 1.5  # an estimate holds if the time is within this factor of it, either way
TARGETS = {  # s
    "paper, empty truth cache": 480.0,
    "run, outside the loop (warm, --no-figures)": 2.0,
}
TRUTH_PHASE = re.compile(r": against the truth\s+(\d+(?:\.\d+)?) s$")  # run's last phase
BAR = re.compile(r"\d+%\|")  # a progress bar (tqdm) as it is redrawn
ABOUT = re.compile(r"about (\d+(?:\.\d+)?) (s|min)\b")
STARTED = re.compile(r"truth: started (\S+) \(about (\d+(?:\.\d+)?) s")
DONE = re.compile(r"truth: (\S+) done in (\d+(?:\.\d+)?) s")
CANDIDATE_N = 36  # the rod's mesh size of the 1e5-node candidate: (2n+1)(n+1)^2 = 99,937 nodes
CONTACT_TRUTH = "contact-MP1"  # the contact truth whose estimate is checked (issue 59)
PARALLEL_N = 12  # the rod's mesh size run on one rank and on two (the README's mpiexec line)
PAPER_BENCHMARKS = ("rod", "block")  # run at their defaults: what the run target is of
USERS = 200


@dataclass
class Timed:
    """One command: its argv, exit code, wall time (s), lines with their time (s from its
    start) and the load average (1, 5, 15 min) before and after."""

    name: str
    argv: list[str]
    code: int = 0
    wall_s: float = 0.0
    lines: list[tuple[float, str]] = field(default_factory=list)
    load_before: tuple[float, ...] = ()
    load_after: tuple[float, ...] = ()


def tissuebench() -> str:
    """The tissuebench beside this Python (the venv's), else on PATH."""
    here = Path(sys.executable).parent / "tissuebench"
    return str(here) if here.exists() else shutil.which("tissuebench") or "tissuebench"


def timed(name: str, argv: list[str], env: dict[str, str], log: Callable[[str], None]) -> Timed:
    """Run argv to its end, its output (stdout and stderr) line by line with their times (a
    progress bar's left out); each line also to log, prefixed with the name."""
    record = Timed(name, argv, load_before=os.getloadavg())
    start = time.perf_counter()
    env = {**env, "PYTHONUNBUFFERED": "1", "TISSUEBENCH_PROGRESS_BARS": "0"}
    with subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env
    ) as process:
        assert process.stdout is not None
        for line in process.stdout:
            line = line.rstrip()
            if line and not BAR.search(line):  # a progress bar's line is not kept
                record.lines.append((time.perf_counter() - start, line))
                log(f"  [{name}] {line}")
    record.code = process.returncode
    record.wall_s = time.perf_counter() - start
    record.load_after = os.getloadavg()
    log(f"{name}: {record.wall_s:.1f} s (exit {record.code})")
    return record


def seconds_of(text: str) -> float | None:
    """The first "about N s" or "about N min" of a line, in s; None without one."""
    found = ABOUT.search(text)
    if found is None:
        return None
    return float(found[1]) * (60.0 if found[2] == "min" else 1.0)


def estimates(record: Timed) -> list[dict]:
    """The estimates a command printed, each with the time it estimated (s): a `truth`'s
    computation ("computing it once (about ...)": the command's wall time), a `paper`'s truths
    ("the truths ... are not cached": its start to its last truth's end) and each truth of
    those ("truth: started CASE (about N s": its "done in T s")."""
    found: list[dict[str, Any]] = []
    started: dict[str, float] = {}
    last_done = None
    for at, line in record.lines:
        if (hit := STARTED.search(line)) is not None:
            started[hit[1]] = float(hit[2])
        elif (hit := DONE.search(line)) is not None:
            last_done = at
            if hit[1] in started:
                found.append(
                    {"what": f"truth {hit[1]}", "about_s": started[hit[1]], "took_s": float(hit[2])}
                )
    for _, line in record.lines:
        if record.name.startswith("truth") and "computing it once (about" in line:
            found.append(
                {"what": record.name, "about_s": seconds_of(line), "took_s": record.wall_s}
            )
        if line.startswith("paper: the truths") and last_done is not None:
            about = seconds_of(line.rsplit("(", 1)[-1])
            found.append({"what": "paper's truths", "about_s": about, "took_s": last_done})
    for e in found:
        ratio = e["took_s"] / e["about_s"] if e["about_s"] else None
        e["ratio"] = ratio
        e["holds"] = ratio is not None and 1 / ESTIMATE_FACTOR <= ratio <= ESTIMATE_FACTOR
    return found


def phases(folder: Path, record: Timed) -> dict:
    """A run's phases (its summary.json's phases_s, s) with the grading against the truth after
    them (its line "against the truth N s"): the loops ("run ...") and the rest, and the whole
    command's wall time (s)."""
    times = dict(json.loads((folder / "summary.json").read_text()).get("phases_s") or {})
    for _, line in record.lines:
        if (hit := TRUTH_PHASE.search(line)) is not None:
            times["against the truth"] = float(hit[1])
    loop = sum(v for k, v in times.items() if k.startswith("run "))
    return {
        "phases_s": times,
        "loop_s": loop,
        "outside_s": sum(times.values()) - loop,
        "command_s": record.wall_s,
    }


def run_name(benchmark: str, figures: bool) -> str:
    """The name of a paper benchmark's run at its defaults."""
    return f"run {benchmark}" + ("" if figures else " --no-figures")


def parallel_name(ranks: int) -> str:
    """The name of the rod run at PARALLEL_N on `ranks` ranks."""
    return f"run rod --mesh-size {PARALLEL_N} --no-figures, {ranks} rank{'s' if ranks > 1 else ''}"


def candidate(folder: Path) -> Path:
    """The 1e5-node candidate: the rod at n = CANDIDATE_N, 301 steps of h (grading.py's late
    series)."""
    import numpy as np

    from tissuebench.workflows.bench import grading

    mesh = grading.rod(CANDIDATE_N)
    assert mesh is not None  # one process: its rank 0
    points, cells = mesh
    path = folder / "candidate.xdmf"
    grading.write(path, points, cells, "hexahedron", np.arange(301) * grading.H, late=True)
    return path


def measure(work: Path, log: Callable[[str], None]) -> dict:
    """Every path, timed in work (caches and outputs there)."""
    from tissuebench.core.speed import slowdown
    from tissuebench.workflows.bench import leaderboard_users, paper_parts

    tb = tissuebench()
    slow = slowdown()
    log(f"machine speed: the probe takes {slow:.2f} x its time where the estimates were measured")
    env = {k: v for k, v in os.environ.items() if k != "TISSUEBENCH_SLOWDOWN"}
    first = {**env, "TISSUEBENCH_CACHE": str(work / "cache-truth")}
    second = {**env, "TISSUEBENCH_CACHE": str(work / "cache-paper")}
    commands = [
        ("truth rod, empty cache", [tb, "truth", "rod", "--out", str(work / "truth")], first),
        (  # a contact truth (SPEC 12): its levels, half step and penalty check in one estimate
            f"truth {CONTACT_TRUTH}, empty cache",
            [tb, "truth", CONTACT_TRUTH, "--out", str(work / "truth-contact")],
            first,
        ),
        ("paper, empty truth cache", [tb, "paper", "--out", str(work / "paper-1")], second),
        ("paper, warm", [tb, "paper", "--out", str(work / "paper-2")], second),
    ]
    records = [timed(name, argv, cache, log) for name, argv, cache in commands]
    warm = records[-1]  # where its time goes, by part of the study and kind of phase
    parts = paper_parts.paper_parts(work / "paper-2") if warm.code == 0 else None
    runs = {}
    for benchmark in PAPER_BENCHMARKS:
        for figures in (False, True):
            name = run_name(benchmark, figures)
            out = work / name.replace(" ", "_")
            argv = [tb, "run", benchmark, "--out", str(out)] + ([] if figures else ["--no-figures"])
            records.append(timed(name, argv, second, log))
            if records[-1].code == 0:
                runs[name] = phases(out, records[-1])
    mpiexec = str(Path(sys.executable).parent / "mpiexec")
    for ranks in (1, 2):
        name = parallel_name(ranks)
        out = work / f"run_rod_{PARALLEL_N}_{ranks}"
        argv = [tb, "run", "rod", "--mesh-size", str(PARALLEL_N), "--no-figures", "--out", str(out)]
        argv = argv if ranks == 1 else [mpiexec, "-n", str(ranks), *argv]
        records.append(timed(name, argv, second, log))
        if records[-1].code == 0:
            runs[name] = phases(out, records[-1])
    path = candidate(work)
    records.append(
        timed(
            "compare, 1e5-node candidate",
            [tb, "compare", "truth:rod", str(path), "--out", str(work / "compare")],
            second,
            log,
        )
    )
    os.environ["TISSUEBENCH_CACHE"] = second["TISSUEBENCH_CACHE"]  # the truth rod, computed
    start, load = time.perf_counter(), os.getloadavg()
    users = leaderboard_users.measure_users(USERS, [1], work / "users", log)
    board = Timed(f"leaderboard, {USERS} users' rows", ["tissuebench", "leaderboard"])
    board.wall_s = users["records"][0]["wall_s"]
    board.load_before, board.load_after = load, os.getloadavg()
    log(f"(the leaderboard's bench, preparation included: {time.perf_counter() - start:.0f} s)")
    records.append(board)
    return {
        "when": time.strftime("%Y-%m-%d %H:%M %Z"),
        "slowdown": slow,
        "records": [asdict(r) for r in records],
        "estimates": [e for r in records for e in estimates(r)],
        "runs": runs,
        "paper_parts": parts,
    }


def _row(record: dict) -> str:
    target = TARGETS.get(record["name"])
    met = "" if target is None else ("met" if record["wall_s"] <= target else "NOT met")
    return (
        f"| {record['name']} | {record['wall_s']:.1f} | {'' if target is None else f'{target:g}'}"
        f" | {met} | {'ok' if record['code'] == 0 else f'exit {record["code"]}'} | "
        f"{record['load_before'][0]:.1f} / {record['load_after'][0]:.1f} |"
    )


def table(result: dict) -> list[str]:
    """The paths' table (markdown lines): each command's wall time against its target."""
    return [
        "| path | wall s | target s | | exit | load before / after |",
        "|---|---:|---:|---|---|---|",
        *(_row(r) for r in result["records"]),
    ]


def outside_target(result: dict) -> str | None:
    """Whether the paper's rod and block spend at most the target outside their time loops
    (with --no-figures), as a sentence; None where they were not run."""
    target = TARGETS["run, outside the loop (warm, --no-figures)"]
    paper = [run_name(b, figures=False) for b in PAPER_BENCHMARKS]
    outside = [r["outside_s"] for name, r in result["runs"].items() if name in paper]
    if not outside:
        return None
    return (
        f"Target: `run` of the paper's rod and block outside its time loops at most {target:g} s "
        "warm, with --no-figures: "
        + ("met" if max(outside) <= target else f"NOT met (at most {max(outside):.1f} s)")
        + "."
    )


def report(result: dict, machine: str) -> str:
    """performance-paths.md from measure()'s result."""
    from tissuebench.workflows.bench import paper_parts

    lines = [
        "# The paths a user waits on",
        "",
        f"`{result.get('command', 'tissuebench bench --only paths')}` ({result['when']}; "
        f"{machine}). Each path is one whole "
        "command in a process of its own, from its start to its end, in one run; the machine's "
        f"probe (core/speed.py) took {result['slowdown']:.2f} times its time on the machine the "
        "estimates were measured on, and every printed estimate is scaled by it. The load "
        "average (1 min) before and after each says how busy the 2 cores were.",
        "",
        *table(result),
        "",
        "## Where `run` spends its time (warm: forms compiled, the truth cached)",
        "",
        "Its phases as it says them (summary.json's phases_s, and the grading against the truth "
        "after them); the whole command also starts Python and its libraries.",
        "",
        "| command | whole command s | time loops s | the rest s | phases (s) |",
        "|---|---:|---:|---:|---|",
    ]
    for name, r in result["runs"].items():
        each = ", ".join(f"{k} {v:.2f}" for k, v in r["phases_s"].items())
        lines.append(
            f"| {name} | {r.get('command_s', float('nan')):.1f} | {r['loop_s']:.2f} | "
            f"{r['outside_s']:.2f} | {each} |"
        )
    one, two = (result["runs"].get(parallel_name(n)) for n in (1, 2))
    if one is not None and two is not None:
        ratios = {
            what: f"{a:.1f} s on one rank, {b:.1f} s on two ({a / b:.2f} x)"
            for what, a, b in (
                ("the whole command", one["command_s"], two["command_s"]),
                ("its metrics", one["phases_s"].get("metrics"), two["phases_s"].get("metrics")),
            )
            if a and b
        }
        lines += [
            "",
            f"The rod at n = {PARALLEL_N} under `mpiexec -n 2` against one rank, in this run: "
            + "; ".join(f"{what} {said}" for what, said in ratios.items())
            + ". E_s's booleans, most of the metrics, are shared out between the ranks.",
        ]
    sentence = outside_target(result)
    if sentence is not None:
        lines += ["", sentence]
    if result.get("paper_parts"):  # measured since issue 59 item 8: absent from older runs
        wall = next((r["wall_s"] for r in result["records"] if r["name"] == "paper, warm"), None)
        lines += [
            "",
            "## Where the warm `paper` spends its time",
            "",
            "Its cases' phases (summary.json's phases_s, s of one core) summed by part of the "
            "study and kind of phase (workflows/bench/paper_parts.py). A warm paper shares part "
            "2's cases with a second process beside its own, so the cases' sum can exceed the "
            "wall time; what no case holds (Python's start, the grading against the truth after "
            "the cases, the report) is the rest of the wall time.",
            "",
            *paper_parts.table(result["paper_parts"], wall),
        ]
    lines += [
        "",
        "## Estimates against the times they estimated",
        "",
        f"An estimate holds if the time is within a factor {ESTIMATE_FACTOR:g} of it.",
        "",
        "| estimate of | about s | took s | took / about | holds |",
        "|---|---:|---:|---:|---|",
    ]
    for e in result["estimates"]:
        ratio = "" if e["ratio"] is None else f"{e['ratio']:.2f}"
        lines.append(
            f"| {e['what']} | {e['about_s']:.0f} | {e['took_s']:.0f} | {ratio} | "
            f"{'yes' if e['holds'] else 'NO'} |"
        )
    return "\n".join(lines) + "\n"


def render(out: Path) -> None:
    """Write OUT/performance-paths.md again from OUT/performance-paths.json (the report's code
    changed, not the measurements): `python -m tissuebench.workflows.bench.paths --render OUT`."""
    from tissuebench.workflows.io.output import write_owned

    result = json.loads((out / NAMES[0]).read_text())
    text = report(result, result["machine"])
    write_owned(out / NAMES[1], lambda tmp: tmp.write_text(text))


def run(out: Path | None, log: Callable[[str], None] = print) -> int:
    """The benchmark (`bench --only paths`): measure_into(); 0 if every command ended well."""
    result = measure_into(out, log)
    return 0 if all(r["code"] == 0 for r in result["records"]) else 1


def measure_into(
    out: Path | None,
    log: Callable[[str], None] = print,
    command: str = "tissuebench bench --only paths",
) -> dict:
    """The benchmark, in a temporary folder removed after; its report printed and, with out,
    written to OUT/performance-paths.md and .json; its result returned. `command`: the bench
    command that ran it, for the report."""
    from tissuebench.workflows.bench.machine import machine_description
    from tissuebench.workflows.io.output import check_writable, write_owned

    if out is not None:
        check_writable(out, owned=NAMES)
    work = Path(tempfile.mkdtemp(prefix="tissuebench-paths-"))
    try:
        result = measure(work, log)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    result["machine"] = machine_description()
    result["command"] = command
    text = report(result, result["machine"])
    log("\n" + text)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_owned(out / NAMES[0], lambda tmp: tmp.write_text(json.dumps(result, indent=1)))
        write_owned(out / NAMES[1], lambda tmp: tmp.write_text(text))
        log(f"wrote {out / NAMES[1]}")
    return result


if __name__ == "__main__" and len(sys.argv) == 3 and sys.argv[1] == "--render":
    render(Path(sys.argv[2]))
