"""`tissuebench bench [--quick] [--out DIR]`: how fast the algorithms run, against a scikit-fem +
SciPy peer, the memory-bandwidth limit and 2 MPI ranks.

For the rod (n = 2 .. 48) and the block on matching numbers of degrees of freedom, one run
measures, side by side: the assembly time of K and M; the setup time (everything before the
first step: step matrix, factorisation or preconditioner, initial acceleration) and the time
per step (median after a warm-up) of every algorithm; the peak memory (resident set, summed
over ranks) during each; the same on 2 ranks; the peer (workflows/bench/peer_skfem.py) doing the
same steps on the same mesh; whether both give the same displacement; a STREAM-like triad and the
bytes an explicit-lumped step must move, giving measured / limit. With the elastic models of
SPEC 8: the explicit-lumped step with neo-hookean and with corotational beside the linear one
(ratios), its real-time capacity, and the Newton iterations per implicit step of svk,
neo-hookean and corotational at the paper's loads.

`--only explicit-models` measures only the explicit-lumped step with each elastic model and
remedy beside the linear one (1 rank, the full sizes unless --quick) into
DIR/performance-explicit.md and .json, leaving DIR/performance.* alone.

`--only paths` times the commands a user waits on, each whole, with the estimates they print
(workflows/bench/paths.py), into DIR/performance-paths.md and .json.

`--only leaderboard-users` times `tissuebench leaderboard` grading --users copies (200; 20
with --quick) of one user's compare folder, serial and under `mpiexec -n 2` (--ranks 1,2),
into DIR/performance-leaderboard.md and .json (workflows/bench/leaderboard_users.py; the
truth `rod` must be computed).

A quick run never replaces a full one: without --out it writes into a folder of the system's
temporary directory, and it refuses an --out whose performance.json holds a full run.

The measurements (budgets, capacity search) are workflows/bench/measure.py, its worker processes
workflows/bench/workers.py;
the tables are workflows/bench/tables.py (the targets targets.py), the figure and report
workflows/bench/report.py.
Writes DIR/performance.md, DIR/performance.png and DIR/performance.json. A full run then times
the paths a user waits on, as `--only paths` does (into DIR/performance-paths.md and .json), and
performance.md gives their table beside the step benchmarks'. Only the driver (one process, not
under mpiexec) prints.
"""

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

from tissuebench.core.errors import UserError
from tissuebench.workflows.bench.measure import measure, measure_explicit
from tissuebench.workflows.bench.report import plot, write_explicit_report, write_report
from tissuebench.workflows.bench.tables import model_step_rows, text_table
from tissuebench.workflows.bench.targets import summary_tables
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.io.output import check_writable, write_owned

FILES = ("performance.json", "performance.png", "performance.md")


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "bench",
        help=HELP["bench"],
        description="Measure assembly, setup and step times of every algorithm against a "
        "scikit-fem + SciPy peer, the memory-bandwidth limit and 2 MPI ranks; write "
        "DIR/performance.md, .png and .json. Needs the 'bench' extra.",
    )
    p.add_argument("--quick", action="store_true", help="small sizes only (a minute or two)")
    p.add_argument(
        "--only",
        choices=["explicit-models", "leaderboard-users", "contact", "contact-3d", "paths"],
        default=None,
        help="explicit-models: only the explicit-lumped step with each elastic model and "
        "remedy against the linear one (1 rank), into DIR/performance-explicit.md and .json, "
        "leaving DIR/performance.* alone; leaderboard-users: only `tissuebench leaderboard` "
        "grading --users user rows on each of --ranks, into DIR/performance-leaderboard.md "
        "and .json; contact: only the explicit-lumped step with the needle as contact against "
        "it glued (SPEC 12), into DIR/performance-contact.md and .json; contact-3d: the same "
        "step of the cylinder with the capsule against it with no tool (SPEC 13), into "
        "DIR/performance-contact-3d.md and .json; paths: the commands a user waits on, each "
        "timed whole (a first and a warm `paper`, `truth rod` and `truth contact-MP1`, `run`'s "
        "phases, a 1e5-node `compare`, a 200-user leaderboard) with their printed estimates, "
        "into DIR/performance-paths.md and .json (about 30 min)",
    )
    p.add_argument(
        "--users",
        type=int,
        default=None,
        help="with --only leaderboard-users: how many user rows (default 200; 20 with --quick)",
    )
    p.add_argument(
        "--ranks",
        default="1,2",
        help="with --only leaderboard-users: the numbers of ranks to time (default 1,2)",
    )
    p.add_argument(
        "--out",
        default=None,
        type=Path,
        help="output directory (default results; with --quick, "
        f"{quick_out()}, so that a quick run never replaces the full results)",
    )
    p.set_defaults(func=main)


def explicit_models(args: argparse.Namespace) -> int:
    """`tissuebench bench --only explicit-models`: measure_explicit, its json and report."""
    mode = "quick" if args.quick else "full"
    out = Path(args.out) if args.out is not None else quick_out() if args.quick else Path("results")
    names = ("performance-explicit.json", "performance-explicit.md")
    path = out / names[0]
    if args.quick and path.exists():
        try:
            full = json.loads(path.read_text()).get("mode") == "full"
        except (OSError, ValueError, AttributeError):
            full = False
        if full:
            raise UserError(f"{path} holds a full run, which a quick run does not replace")
    check_writable(out, owned=names)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    print(f"tissuebench bench --only explicit-models ({mode}): 1 rank per worker", flush=True)
    records = measure_explicit(mode, out, lambda line: print(line, flush=True))
    wall = time.perf_counter() - start
    result = {"mode": mode, "only": "explicit-models", "wall_s": wall, "records": records}
    write_owned(path, lambda tmp: tmp.write_text(json.dumps(result)))
    write_explicit_report(records, mode, wall, out)
    print(f"\nexplicit step / linear explicit-lumped step\n{text_table(*model_step_rows(records))}")
    print(f"\nwall {wall:.0f} s; wrote {out / names[1]}")
    return 0


def contact(args: argparse.Namespace) -> int:
    """`tissuebench bench --only contact` (or contact-3d): workflows/bench/contact.py (or
    contact3d.py)."""
    from tissuebench.workflows.bench import contact, contact3d

    bench = contact3d if args.only == "contact-3d" else contact
    part = "performance-contact-3d" if args.only == "contact-3d" else "performance-contact"
    mode = "quick" if args.quick else "full"
    out = Path(args.out) if args.out is not None else quick_out() if args.quick else Path("results")
    names = (f"{part}.json", f"{part}.md")
    check_writable(out, owned=names)
    out.mkdir(parents=True, exist_ok=True)
    print(f"tissuebench bench --only {args.only} ({mode}): 1 rank", flush=True)
    start = time.perf_counter()
    records = bench.measure(mode, lambda line: print(line, flush=True))
    wall = time.perf_counter() - start
    bench.write(out, records, mode, wall)
    print(f"\n{bench.table(records)}\n\nwall {wall:.0f} s; wrote {out / names[1]}")
    return 0


def leaderboard_users(args: argparse.Namespace) -> int:
    """`tissuebench bench --only leaderboard-users`: workflows/bench/leaderboard_users.py."""
    from tissuebench.workflows.bench import leaderboard_users as bench

    users = args.users if args.users is not None else 20 if args.quick else 200
    if users < 1:
        raise UserError(f"--users {users}: at least 1")
    try:
        ranks = bench.ranks_of(args.ranks)
    except argparse.ArgumentTypeError as err:
        raise UserError(f"--ranks {err}") from None
    out = Path(args.out) if args.out is not None else quick_out() if args.quick else Path("results")
    print(f"tissuebench bench --only leaderboard-users: {users} user rows, ranks {ranks}")
    try:
        return bench.run(users, ranks, out, None, lambda line: print(line, flush=True))
    except RuntimeError as err:
        raise UserError(" ".join(str(err).split())[:2000]) from None


def paths(args: argparse.Namespace) -> int:
    """`tissuebench bench --only paths`: workflows/bench/paths.py (no quick form: its paths are
    the user's, whole)."""
    from tissuebench.workflows.bench import paths as bench

    if args.quick:
        raise UserError("--only paths has no --quick: it times the user's commands as they are")
    out = Path(args.out) if args.out is not None else Path("results")
    print("tissuebench bench --only paths: each command a user waits on, timed whole", flush=True)
    try:
        return bench.run(out, lambda line: print(line, flush=True))
    except RuntimeError as err:
        raise UserError(" ".join(str(err).split())[:2000]) from None


def quick_out() -> Path:
    """Where `bench --quick` writes without --out."""
    return Path(tempfile.gettempdir()) / "tissuebench-bench-quick"


def holds_full_run(out: Path) -> bool:
    """Whether out/performance.json is the result of a finished full run."""
    try:
        data = json.loads((out / "performance.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and data.get("mode") == "full" and not data.get("partial")


def main(args: argparse.Namespace) -> int:
    if int(os.environ.get("PMI_SIZE", os.environ.get("OMPI_COMM_WORLD_SIZE", "1"))) > 1:
        raise UserError("run `tissuebench bench` without mpiexec: it starts its own 2-rank runs")
    if getattr(args, "only", None) == "explicit-models":
        return explicit_models(args)
    if getattr(args, "only", None) == "leaderboard-users":
        return leaderboard_users(args)
    if getattr(args, "only", None) in ("contact", "contact-3d"):
        return contact(args)
    if getattr(args, "only", None) == "paths":
        return paths(args)
    try:
        import pyamg  # noqa: F401
        import scipy  # noqa: F401
        import skfem  # noqa: F401
    except ImportError as err:
        raise UserError(
            f"the bench needs the 'bench' extra (pip install -e '.[bench]'): {err}"
        ) from None
    mode = "quick" if args.quick else "full"
    if args.out is None:
        out = quick_out() if args.quick else Path("results")
    else:
        out = Path(args.out)
    if args.quick and holds_full_run(out):
        raise UserError(
            f"{out / 'performance.json'} holds a full run, which a quick run does not replace: "
            "give another --out"
        )
    check_writable(out, owned=FILES)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    print(
        f"tissuebench bench ({mode}): workers pinned to 1 BLAS/OpenMP thread per rank", flush=True
    )
    records, probes, paper, newton = measure(mode, out, lambda line: print(line, flush=True))
    user_paths = None
    if mode == "full":  # the commands a user waits on, each whole (no quick form)
        from tissuebench.workflows.bench import paths as bench_paths

        print("tissuebench bench: the paths a user waits on, each command whole", flush=True)
        user_paths = bench_paths.measure_into(
            out, lambda line: print(line, flush=True), command="tissuebench bench"
        )
    wall = time.perf_counter() - start
    result = {
        "mode": mode,
        "wall_s": wall,
        "records": records,
        "capacity_probes": probes,
        "paper_s": paper,
        "newton": newton,
    }
    write_owned(out / "performance.json", lambda tmp: tmp.write_text(json.dumps(result)))
    write_owned(out / "performance.png", lambda tmp: plot(records, tmp))
    write_report(records, probes, paper, mode, wall, out, newton, user_paths)
    for title, table in summary_tables(records, probes, paper, newton):
        print(f"\n{title}\n{text_table(*table)}")
    print(f"\nwall {wall:.0f} s; wrote {out / 'performance.md'} and {out / 'performance.png'}")
    return 0
