"""How long `tissuebench leaderboard` takes to grade many users' rows (issue 35): a benchmark,
not a test.

    tissuebench bench --only leaderboard-users [--users 200] [--ranks 1,2] [--out results]
    python -m tissuebench.workflows.bench.leaderboard_users --users 200 --work /tmp/users

It copies the committed results/ (git ls-files) into WORK/template/results, grades one user run
of rod-MP3 with `tissuebench compare` (our implicit on gmsh's unstructured tetrahedra, exported
and run as a user would), and puts USERS copies of that compare folder under
results/leaderboard/rod-MP3/user/ (each its own label and wall time, sealed as compare seals
it). Then, for each number of ranks, a fresh copy of that folder is graded by `[mpiexec -n
RANKS] tissuebench leaderboard --out results` (each row against the truth `rod`, cached:
`tissuebench truth rod` first, with its error budget, said in one line as it ends), and timed:
the command's wall time (from start to the written page: reading, grading, rendering), the
seconds per row (wall / users) and the rows' own grading seconds (from their lines, also in
WORK/ranks-N/leaderboard.log as they come), with the machine's load average before and after.
With --out, the table is written to OUT/performance-leaderboard.md (and .json).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
NAMES = ("performance-leaderboard.json", "performance-leaderboard.md")
TRUTH = (
    "rod"  # the truth case that rod-MP3's rows, the copied user's among them, are graded against
)


def sh(*argv, cwd: Path) -> str:
    done = subprocess.run([str(a) for a in argv], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(
            f"{' '.join(map(str, argv))} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}"
        )
    return done.stdout + done.stderr


def tools() -> tuple[Path, Path]:
    """The tissuebench and mpiexec beside this Python (the venv's), else on PATH."""
    here = Path(sys.executable).parent
    found = []
    for name in ("tissuebench", "mpiexec"):
        path = here / name
        found.append(path if path.exists() else Path(shutil.which(name) or name))
    return found[0], found[1]


def prepare(users: int, template: Path, log=print) -> None:
    """template/results: the committed results with `users` copies of one user's compare
    folder of rod-MP3, none graded yet; template/rod.json, mine/ and rod.reference.xdmf, how
    the user made it."""
    from tissuebench.workflows.io.manifest import seal
    from tissuebench.workflows.io.summary import read_compare_summary, write_summary

    tb, _ = tools()
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z", "results"], capture_output=True, text=True
    ).stdout.split("\0")
    for name in filter(None, listed):
        target = template / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target)
    log("a user's run: tissuebench export rod, run on unstructured tetrahedra, compare")
    sh(tb, "export", "rod", "--material", "MP3", "--out", "rod.json", cwd=template)
    sh(tb, "run", "rod", "--material", "MP3", "--cell", "tetrahedron", "--mesh", "unstructured",
       "--algorithms", "implicit", "--out", "mine", cwd=template)  # fmt: skip
    folder = template / "results" / "leaderboard" / "rod-MP3" / "user"
    first = folder / "u0000"
    sh(tb, "compare", "rod.reference.xdmf", "mine/implicit.xdmf", "--out", first,
       "--label", "user-0000", "--wall-time", "1.0", cwd=template)  # fmt: skip
    for k in range(1, users):
        target = folder / f"u{k:04d}"
        shutil.copytree(first, target)
        summary = read_compare_summary(target)
        assert summary is not None, f"{target}: compare wrote no summary"
        (run,) = summary["runs"].values()
        summary["runs"] = {f"user-{k:04d}": {**run, "wall_time_s": 1.0 + k / 1000}}
        write_summary(target, summary)
        seal(target)


def time_leaderboard(template: Path, work: Path, ranks: int, users: int) -> dict:
    """`tissuebench leaderboard --out results` on a fresh copy of template in work, on `ranks`
    ranks: its wall time (s), the rows' own seconds and the load average around it."""
    tb, mpiexec = tools()
    shutil.copytree(template, work)
    argv = [str(tb), "leaderboard", "--out", "results"]
    if ranks > 1:
        argv = [str(mpiexec), "-n", str(ranks), *argv]
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PMI_", "HYDRA_", "MPIR_"))}
    env["OMP_NUM_THREADS"] = "1"
    log = work / "leaderboard.log"  # its lines as they come (a row per line as it is graded)
    load_before = os.getloadavg()
    start = time.perf_counter()
    with open(log, "w") as f:
        done = subprocess.run(argv, cwd=work, stdout=f, stderr=f, env=env)
    wall = time.perf_counter() - start
    load_after = os.getloadavg()
    out = log.read_text()
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed:\n{out[-2000:]}")
    seconds = [float(s) for s in re.findall(r"graded user row .* in ([0-9.]+) s", out)]
    if len(seconds) != users:
        raise RuntimeError(f"{len(seconds)} rows said graded of {users}:\n{out[-2000:]}")
    record = json.loads((work / "results" / "leaderboard.json").read_text())
    graded = [
        r
        for c in record["cases"]
        for r in c["rows"]
        if r["source"] == "user"
        and r.get("truth")
        and r.get("budget", {}).get("algorithm") is not None
    ]
    return {
        "users": users,
        "ranks": ranks,
        "wall_s": wall,
        "per_row_s": wall / users,
        "row_seconds": {
            "mean": sum(seconds) / len(seconds),
            "min": min(seconds),
            "max": max(seconds),
        },
        "graded_rows": len(graded),
        "mesh": graded[0]["mesh"] if graded else "?",
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in load_after],
        "cores": os.cpu_count(),
    }


def numbers_agree(work: Path, ranks: list[int]) -> bool:
    """Whether every run's record holds the same users' rows (truth columns and budgets)."""
    seen = []
    for n in ranks:
        record = json.loads((work / f"ranks-{n}" / "results" / "leaderboard.json").read_text())
        rows = {
            r["label"]: (r.get("truth"), r.get("budget"))
            for c in record["cases"]
            for r in c["rows"]
            if r["source"] == "user"
        }
        seen.append(rows)
    return all(s == seen[0] for s in seen)


def measure_users(users: int, ranks: list[int], work: Path, log=print) -> dict:
    """prepare, then time_leaderboard for each number of ranks: the records and whether the
    runs' numbers agree."""
    from mpi4py import MPI

    from tissuebench.solvers.truth.store import is_cached

    if not is_cached(TRUTH, comm=MPI.COMM_SELF):
        raise RuntimeError(
            f"the truth {TRUTH} is not computed here: `tissuebench truth {TRUTH}` first"
        )
    template = work / "template"
    prepare(users, template, log)
    records = []
    for n in ranks:
        log(f"tissuebench leaderboard on {n} rank(s), {users} user rows ...")
        records.append(time_leaderboard(template, work / f"ranks-{n}", n, users))
        log(row_line(records[-1]))
    return {"records": records, "agree": numbers_agree(work, ranks)}


def row_line(r: dict) -> str:
    return (
        f"| {r['users']} | {r['ranks']} | {r['wall_s']:.1f} | {r['per_row_s']:.3f} | "
        f"{r['row_seconds']['mean']:.3f} ({r['row_seconds']['min']:.2f} to "
        f"{r['row_seconds']['max']:.2f}) | {r['load_before'][0]:.2f} / {r['load_after'][0]:.2f} |"
    )


HEADER = (
    "| users | ranks | wall s | s per row (wall / users) | a row's own grading, s: mean "
    "(min to max) | load average (1 min) before / after |\n|---|---|---|---|---|---|"
)


def report(result: dict, when: str, machine: str) -> str:
    """OUT/performance-leaderboard.md."""
    lines = [
        "# The leaderboard's users graded: 200 rows",
        "",
        f"`tissuebench bench --only leaderboard-users` ({when}; {machine}): "
        f"{result['records'][0]['users']} copies of one user's compare folder of rod-MP3 (our "
        f"implicit on gmsh's unstructured {result['records'][0]['mesh']}) graded "
        "by `tissuebench "
        "leaderboard --out results` from the committed record, each row against the truth "
        "`rod` (its 301 steps at 27,648 quadrature points) with its error budget (our implicit "
        "run on the row's mesh), serial and under `mpiexec -n 2`. The wall time is the whole "
        "command: start-up, reading and checking the folders, the truth loaded (on each rank), "
        "the grading, and the page, tables and figures written.",
        "",
        HEADER,
        *[row_line(r) for r in result["records"]],
        "",
        "The numbers of every row are the same on 1 and 2 ranks: "
        + ("yes (the records' users' rows are equal)." if result["agree"] else "NO."),
        "",
        "Before (issue 35): 200 rows took 2,060 s here (10.2 s a row, under a load of 4 to 10), "
        "2.3 s a row on a quiet machine: each row ran our implicit on its mesh again, located "
        "the truth's points in its mesh twice and interpolated and differenced the truth's "
        "200 MB of values in numpy, twice. Now a row's series is read once, its mesh located "
        "once and our implicit run once per mesh (rows on one mesh share them, on each rank), "
        "E_i against the truth is one compiled loop over the truth's values "
        "(metrics/kernels.py), and the rows are shared out among the ranks. The machine has "
        f"{result['records'][0]['cores']} cores, shared with other work: the load average says "
        "how busy it was.",
        "",
    ]
    return "\n".join(lines)


def run(users: int, ranks: list[int], out: Path | None, work: Path | None, log=print) -> int:
    """The benchmark: measured in work (a new temporary folder by default, removed after), its
    table printed and, with out, written to OUT/performance-leaderboard.md and .json."""
    from tissuebench.workflows.io.output import check_writable, write_owned
    from tissuebench.workflows.leaderboard.figures import machine

    if out is not None:
        check_writable(out, owned=NAMES)
    keep = work is not None
    work = Path(tempfile.mkdtemp(prefix="tissuebench-users-")) if work is None else work.resolve()
    if keep and work.exists() and any(work.iterdir()):
        raise RuntimeError(f"{work}: not empty; name a new folder")
    try:
        result = measure_users(users, ranks, work, log)
    finally:
        if not keep:
            shutil.rmtree(work, ignore_errors=True)
    result["when"], result["machine"] = time.strftime("%Y-%m-%d %H:%M %Z"), machine()
    text = report(result, result["when"], result["machine"])
    log("\n" + HEADER + "\n" + "\n".join(row_line(r) for r in result["records"]))
    log(f"same numbers on every number of ranks: {'yes' if result['agree'] else 'NO'}")
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_owned(out / NAMES[0], lambda tmp: tmp.write_text(json.dumps(result, indent=1)))
        write_owned(out / NAMES[1], lambda tmp: tmp.write_text(text))
        log(f"wrote {out / NAMES[1]}")
    return 0 if result["agree"] else 1


def ranks_of(text: str) -> list[int]:
    try:
        ranks = [int(x) for x in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text}: not a list of numbers, e.g. 1,2") from None
    if not ranks or min(ranks) < 1:
        raise argparse.ArgumentTypeError(f"{text}: ranks are at least 1")
    return ranks


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--users", type=int, default=200)
    p.add_argument("--ranks", type=ranks_of, default=[1, 2], help="e.g. 1,2 (default)")
    p.add_argument("--work", type=Path, default=None, help="a new folder (kept)")
    p.add_argument("--out", type=Path, default=None, help="write the report here")
    args = p.parse_args()
    return run(args.users, args.ranks, args.out, args.work)


if __name__ == "__main__":
    sys.exit(main())
