"""`tissuebench contact --out DIR`: the contact study of SPEC 12.

For each contact case whose truth is computed (`tissuebench truth contact-MP1`, ...): our five
algorithms on the contact block (N = 20, kappa = 10), implicit with kappa = 1, 100, 1000 and on
N = 10 and 40, each graded against the truth (E_i, the needle force's error, the
interpenetration, the cost). Runs go to DIR/contact/runs/ (their series stay out of git); writes
DIR/contact/contact.md, contact.csv, and per case force-CASE.png and deformed-CASE.png (rank 0).
A case without its truth is named with the command that computes it.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from functools import partial
from pathlib import Path

from mpi4py import MPI

from tissuebench.core.errors import UserError
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.store import is_cached, truth_samples
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.contact import report, study
from tissuebench.workflows.io.output import check_writable, collective, write_set
from tissuebench.workflows.io.tables import write_table


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "contact",
        help=HELP["contact"],
        description=__doc__.split("\n\n")[1],
    )
    p.add_argument("--out", default="results", help="output directory (default: results)")
    p.add_argument(
        "--cases",
        default=",".join(study.contact_cases()),
        help=f"contact cases, comma-separated (default: {','.join(study.contact_cases())})",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a check of the workflow: N = 8 and 16 to T = 1 s against the quick truths, into "
        "DIR/contact-quick (never the full study's folder)",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    comm = MPI.COMM_WORLD
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in study.contact_cases()]
    if unknown or not cases:
        raise UserError(
            f"--cases: {', '.join(unknown) or 'none given'}; the contact cases are "
            f"{', '.join(study.contact_cases())}"
        )
    out = Path(args.out) / ("contact-quick" if args.quick else "contact")
    names = ["contact.md", "contact.csv"]
    names += [f"{kind}-{c}.png" for c in cases for kind in ("force", "deformed")]
    check_writable(out, comm, owned=names)

    def say(line: str) -> None:
        if comm.rank == 0:
            print(line, flush=True)

    truths: dict = {}
    rows: list[dict] = []
    missing: list[str] = []
    unconverged: list[str] = []
    files: dict[Path, Callable[[Path], None]] = {}
    for case in cases:
        if not args.quick and not is_cached(case, comm=comm):
            missing.append(case)
            continue
        truth = truth_samples(case, args.quick, comm, log=say)
        own = truth.own_error.get("interior_error_max") if truth is not None else None
        if not comm.bcast(own is not None and math.isfinite(own), root=0):
            unconverged.append(case)  # its levels do not converge: nothing is graded on it
            continue
        force = study.truth_force(truth) if truth is not None else None
        folders = study.run_study(case, out / "runs", comm, log=say, quick=args.quick)
        for folder in folders:
            rows += study.grade(truth, folder, force, comm)
        if comm.rank != 0:
            continue
        assert truth is not None and force is not None  # rank 0's
        truths[case] = (truth, force)
        _, _, model, scale, _ = CASES[case]
        h = float(truth.times[1] - truth.times[0])
        files[out / f"force-{case}.png"] = partial(
            report.plot_force, case=case, folder=folders[0], force=force, model=model, h=h
        )
        implicit = study.label_of("implicit", model)
        stiffest = max(folders, key=lambda f: float(f.name.rpartition("kappa")[2]))
        shown = [(folders[0], implicit), (folders[0], study.label_of("explicit-lumped", model))]
        files[out / f"deformed-{case}.png"] = partial(
            report.plot_deformed,
            case=case,
            truth=truth,
            scale=scale,
            runs=[*shown, (stiffest, implicit)],
        )

    def write_md(tmp: Path) -> None:
        tmp.write_text(report.markdown(rows, truths, missing, unconverged) + "\n")

    def write_csv(tmp: Path) -> None:
        write_table(tmp, report.COLUMNS, [[r[k] for k in report.COLUMNS] for r in rows])

    def write() -> None:
        write_set({**files, out / "contact.md": write_md, out / "contact.csv": write_csv})

    collective(comm, write, out)
    if comm.rank == 0:
        for case in missing:
            print(f"{case}: its truth is not computed; run `tissuebench truth {case}` first")
        for case in unconverged:
            print(f"{case}: its truth's levels do not converge (truth.md): not graded")
        print(f"wrote {out / 'contact.md'} ({len(rows)} runs graded)")
    return 0
