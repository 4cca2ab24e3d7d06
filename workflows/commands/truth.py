"""`tissuebench truth CASE|all [--quick] --out DIR`: the converged reference of SPEC 10.

Computes each named case once (Q2, Taylor-Hood Q2-Q1 where nu >= 0.45 or neo-Hookean; the
trapezoidal rule; three uniformly refined levels and h, h/2 on the finest), estimates its own
error from them and caches it outside git ($TISSUEBENCH_CACHE/truth/, default
~/.cache/tissuebench/truth/, keyed by the fingerprint of its inputs); a second call reads the
cache, and a cache file that cannot be read (cut short, corrupt) is named in one line and
computed again. `compare truth:CASE`, `paper` and the leaderboard read the same cache.

Writes DIR/truth.md (per case: levels, dofs, wall time, observed order, the estimated own E_i
max in space and time and whether it meets SPEC 10's target, 0.2 % of the truth's own E_i
against rest) and DIR/truth.csv (case,level,dofs,time,u_x,u_y,u_z: the rod cases' tip at t = 1,
2, ..., 10 s on every level, the finest labelled `truth`). Cases not named are reported from
the cache when they are there, else as not yet computed with their expected cost. With more
than one case to compute, one rank and --jobs N > 1 (default: the cores, at most 2), the cases
run N at a time in worker processes (workflows/truth/jobs.py). --quick: rod n = 1, 2, 4 and
block N = 10, 20, 40 to T = 1 s (30 steps), a check of the workflow, cached under its own key;
it never replaces a full truth.md (--force does). Nor does a run whose cache lacks truths that
truth.md reports as computed (a fresh machine's, in a clone's results/): it computes and caches
the cases named and leaves truth.md as it is, saying so (--force writes it from this cache).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.solvers.truth.cases import (
    CASES,
)
from tissuebench.solvers.truth.store import (
    QUICK_STEPS,
    cache_path,
    check_case,
    is_cached,
    load_cached,
    load_failure,
    truth_samples,
)
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.commands.arguments import truth_case
from tissuebench.workflows.io.output import OutputError, check_writable, collective, write_set
from tissuebench.workflows.truth.crease import crease_figures
from tissuebench.workflows.truth.jobs import compute_in_parallel
from tissuebench.workflows.truth.report import (
    CREASE,
    MARKER,
    NAME,
    csv_rows,
    fmt,
    markdown,
    quick_levels,
    reported,
    summary,
    sweep_failures,
    write_csv,
)
from tissuebench.workflows.truth.sweep import record as sweep_record


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "truth",
        help=HELP["truth"],
        description=__doc__.split("\n\n")[1] + " " + __doc__.split("\n\n")[2],
    )
    p.add_argument(
        "cases",
        nargs="+",
        metavar="CASE",
        type=lambda text: truth_case(text, all_too=True),
        help=f"one or more of {', '.join(CASES)}, or all",
    )
    p.add_argument(
        "--out", type=Path, default=Path("results"), help="output folder (default results)"
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"{quick_levels()}, {QUICK_STEPS} steps (T = 1 s): checks "
        "the workflow; never replaces a full truth.md",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="let a --quick run replace a full truth.md, and a run whose cache lacks truths it "
        "reports",
    )
    p.add_argument(
        "--jobs",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="processes at a time, one core each: cases side by side, and a linear case's "
        "runs (its levels and steps) side by side (default: the cores, at most 2; one rank "
        "only: under mpiexec the ranks share each case)",
    )
    # a worker of --jobs: compute and cache the cases, write no report
    p.add_argument("--compute-only", action="store_true", help=argparse.SUPPRESS)
    p.set_defaults(func=main)


def requested(names: list[str]) -> list[str]:
    """The cases named (all: every case), in CASES' order; UserError for any other name."""
    for name in names:
        if name != "all":
            check_case(name)
    return [c for c in CASES if "all" in names or c in names]


def full_report(out: Path) -> str | None:
    """The text of out/truth.md where it holds the full truth (not a quick one), else None."""
    try:
        text = (out / f"{NAME}.md").read_text(errors="replace")
    except OSError:
        return None
    return text if text.split("\n", 1)[0] == MARKER else None


def check_target(out: Path, quick: bool, force: bool) -> None:
    """Refuse, without force, to replace a full truth.md by a quick one."""
    if quick and not force and full_report(out) is not None:
        raise OutputError(
            f"{out / NAME}.md: holds the full truth; a --quick run does not replace it "
            "(--force does)"
        )


def dropped(out: Path, summaries: dict) -> list[str]:
    """The cases a full truth.md in `out` reports as computed that `summaries` lack (this cache
    lacks them: a fresh machine, another $TISSUEBENCH_CACHE): writing it would lose them."""
    text = full_report(out)
    return [] if text is None else [c for c in reported(text) if c not in summaries]


def main(args: argparse.Namespace) -> int:
    comm = MPI.COMM_WORLD
    names = list(args.cases)
    cases = requested(names)
    if args.jobs < 1:
        raise UserError(f"--jobs must be at least 1, not {args.jobs}")
    if args.compute_only:  # a worker of --jobs
        jobs = args.jobs if comm.size == 1 else 1  # a linear case's runs side by side
        for case in cases:
            truth_samples(case, args.quick, comm, lambda line: print(line, flush=True), jobs)
        return 0
    out = args.out
    check_writable(out, comm, owned=[f"{NAME}.md", f"{NAME}.csv"])
    collective(comm, lambda: check_target(out, args.quick, args.force))
    session = comm.bcast(time.strftime("%Y-%m-%d %H:%M %Z"))
    interrupt.will_write([out / f"{NAME}.md", out / f"{NAME}.csv"])

    def say(line: str) -> None:
        if comm.rank == 0:
            print(line, flush=True)

    failed = []
    if "all" in names:  # a case that failed for today's inputs is tried again only if named
        standing = [c for c in cases if load_failure(c, args.quick) is not None]
        for case in standing:
            say(
                f"truth {case}: failed when last computed (truth.md says where); not tried "
                f"again by `all`: `tissuebench truth {case}` does"
            )
        cases = [c for c in cases if c not in standing]
    todo = [c for c in cases if not is_cached(c, args.quick, comm)]
    if comm.size == 1 and args.jobs > 1 and len(todo) > 1:
        failed = compute_in_parallel(todo, args.quick, args.jobs, say)
    summaries = {}
    for case in CASES:
        if case in cases and case not in failed:
            try:
                jobs = args.jobs if comm.size == 1 else 1  # a linear case's runs side by side
                samples = truth_samples(case, args.quick, comm, log=say, jobs=jobs)
            except RuntimeError as err:  # a Newton solve that failed: kept as evidence
                say(f"truth {case}: FAILED: {err} (where: truth.md)")
                failed.append(case)
                samples = None
        else:  # reported if it is in the cache already
            samples = load_cached(case, args.quick, comm)
        if samples is not None:
            summaries[case] = summary(samples)
            if not args.quick and comm.rank == 0:  # SPEC 10: a fold is a finding, drawn
                summaries[case]["crease"] = crease_figures(samples, out / CREASE)
            path = cache_path(case, args.quick)
            summaries[case]["cached_at"] = path.stat().st_mtime if path.is_file() else None
            if case in cases:
                own = samples.own_error
                say(
                    f"truth {case}: own E_i max {fmt(own['interior_error_max'])} "
                    f"{own['units']} (target {fmt(own['target'])})"
                )
        samples = None
        interrupt.checkpoint(comm)

    # rank 0 reads the file and every rank takes its answer: they return or write together
    lost = comm.bcast(
        dropped(out, summaries) if comm.rank == 0 and not (args.quick or args.force) else []
    )
    if lost:  # the cases named are cached all the same
        say(
            f"truth: {out / NAME}.md reports truths this cache lacks ({', '.join(lost)}): left "
            "as it is (--force writes it from this cache alone, --out DIR elsewhere)"
        )
        interrupt.will_write([])
        return 1 if failed else 0

    def write():  # one set: both staged with the manifest, then renamed (a full disk: the old)
        text = markdown(summaries, args.quick, names, comm.size, session)
        files = {
            out / f"{NAME}.csv": lambda tmp: write_csv(tmp, csv_rows(summaries)),
            out / f"{NAME}.md": lambda tmp: tmp.write_text(text + "\n"),
        }
        fold = None if args.quick else sweep_record(summaries, sweep_failures(summaries))
        if fold is not None:  # what results/README.md says of the fold (tissuebench paper)
            files[out / CREASE / "crease.json"] = lambda tmp: tmp.write_text(
                json.dumps(fold, indent=1) + "\n"
            )
        write_set(files)

    collective(comm, write, out)
    interrupt.will_write([])
    say(f"wrote {out / NAME}.md and {out / NAME}.csv")
    if failed:
        say(f"truth: not computed, they failed (their lines above): {', '.join(failed)}")
        return 1
    return 0


__all__ = ["main", "add_parser", "requested", "UserError"]
