"""How long `tissuebench leaderboard` takes to grade many users' rows (issue 35): a benchmark
script, not a test.

    python -m tissuebench.workflows.bench.leaderboard_users --users 200 --work /tmp/users

It copies the committed results/ (git ls-files) into WORK/results, grades one user run of
rod-MP3 with `tissuebench compare` (our implicit on gmsh's unstructured tetrahedra, exported
and run as a user would), puts USERS copies of that compare folder under
WORK/results/leaderboard/rod-MP3/user/ (each its own label, sealed as compare seals it), and
times `tissuebench leaderboard --out WORK/results`, which grades each against the truth `rod`
(cached: `tissuebench truth rod` first) with its error budget and says each row as it ends.
It prints the total, the seconds per row (from those lines, also in WORK/leaderboard.log as
they come) and the machine's load average.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def sh(*argv, cwd: Path) -> str:
    done = subprocess.run([str(a) for a in argv], cwd=cwd, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(map(str, argv))} failed:\n{done.stdout[-2000:]}{done.stderr[-2000:]}")
    return done.stdout + done.stderr


def main() -> int:
    from tissuebench.workflows.output import seal
    from tissuebench.workflows.summary import read_compare_summary, write_summary

    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--users", type=int, default=200)
    p.add_argument("--work", type=Path, required=True, help="a new folder")
    args = p.parse_args()
    work = args.work.resolve()
    if work.exists():
        sys.exit(f"{work}: exists; name a new folder")
    tb = Path(sys.executable).with_name("tissuebench")
    listed = subprocess.run(
        ["git", "-C", str(ROOT), "ls-files", "-z", "results"], capture_output=True, text=True
    ).stdout.split("\0")
    for name in filter(None, listed):
        target = work / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, target)
    sh(tb, "export", "rod", "--material", "MP3", "--out", "rod.json", cwd=work)
    sh(tb, "run", "rod", "--material", "MP3", "--cell", "tetrahedron", "--mesh", "unstructured",
       "--algorithms", "implicit", "--out", "mine", cwd=work)  # fmt: skip
    users = work / "results" / "leaderboard" / "rod-MP3" / "user"
    first = users / "u0000"
    sh(tb, "compare", "rod.reference.xdmf", "mine/implicit.xdmf", "--out", first,
       "--label", "user-0000", "--wall-time", "1.0", cwd=work)  # fmt: skip
    for k in range(1, args.users):
        folder = users / f"u{k:04d}"
        shutil.copytree(first, folder)
        summary = read_compare_summary(folder)
        (run,) = summary["runs"].values()
        summary["runs"] = {f"user-{k:04d}": {**run, "wall_time_s": 1.0 + k / 1000}}
        write_summary(folder, summary)
        seal(folder)
    start = time.perf_counter()
    log = work / "leaderboard.log"  # its lines as they come (a row per line as it is graded)
    with open(log, "w") as f:
        done = subprocess.run(
            [str(tb), "leaderboard", "--out", "results"], cwd=work, stdout=f, stderr=f
        )
    total = time.perf_counter() - start
    out = log.read_text()
    if done.returncode != 0:
        sys.exit(f"tissuebench leaderboard failed:\n{out[-2000:]}")
    seconds = [float(s) for s in re.findall(r"graded user row .* in ([0-9.]+) s", out)]
    per = sum(seconds) / len(seconds) if seconds else float("nan")
    print(
        f"{args.users} user rows: tissuebench leaderboard took {total:.1f} s; {len(seconds)} "
        f"rows graded, {per:.2f} s per row (min {min(seconds, default=0):.2f}, max "
        f"{max(seconds, default=0):.2f}); load average {os.getloadavg()[0]:.2f} on "
        f"{os.cpu_count()} cores"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
