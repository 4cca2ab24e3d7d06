"""`tissuebench compare REFERENCE CANDIDATE --out DIR`: grade any simulator's output."""

import argparse
import sys
from pathlib import Path
from typing import Any, cast

from mpi4py import MPI

from tissuebench.metrics.truth import PREFIX as TRUTH_PREFIX
from tissuebench.solvers.models import MODELS
from tissuebench.solvers.truth.cases import CASES
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.compare.grading import MAX_LABEL, compare
from tissuebench.workflows.io.series import DEFAULT_FIELDS, check_input_path
from tissuebench.workflows.io.summary import read_compare_summary

REFERENCE_DIVERGED = 3  # exit status: the reference diverged (results written, one line said)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "compare",
        help=HELP["compare"],
        description="Compare two displacement time series of the same body, on the same mesh or "
        "each on its own (first-order triangles, quadrilaterals, tetrahedra or hexahedra; SPEC "
        "9: the candidate is evaluated at the reference's nodes and quadrature points): XDMF/HDF5, "
        "ParaView "
        ".pvd of .vtu, or CalculiX's output as it comes (the ASCII .frd, or the .dat of "
        "*NODE PRINT with its deck, the .inp of the same name, beside it). Writes "
        "DIR/metrics.csv, DIR/metrics.png and DIR/summary.json (DIR: a new or empty folder, or a "
        "compare folder of ours; the same inputs again are skipped). summary.json records what "
        "the reference is (benchmark, case, material, model, h, T, mesh, as its run folder or "
        "the export beside it says, or the truth case) and the candidate's mesh (cells, nodes, "
        "dofs): `tissuebench leaderboard` takes the folder only under that case. A series "
        "that starts at t = h "
        "(CalculiX writes none at t = 0) starts from the zero initial state at t = 0. Time "
        "stamps match within 1e-5 of max(|t|, h) (six printed digits). A series with a "
        "non-finite displacement, or one beyond 100 times the domain's largest extent, has "
        "diverged from that step: the metrics are NaN from that step on and the status column "
        "and summary.json say why. Complex fields, and series whose steps move or renumber "
        "their nodes, are refused. The series are checked to fit in the available memory "
        "before they are read (from their datasets' shapes). The metrics are printed as E_n "
        "and E_s (dimensionless) and E_i (m^2 in 2D, m^3 in 3D; SPEC 6), with their keys in "
        "metrics.csv and summary.json (relative_error, surface_error, interior_error; "
        "summary.json's `metrics` gives each key's symbol and unit). Against a contact "
        "reference (SPEC 12) also the candidate's interpenetration (m: the largest -g_n over "
        "its deformed right edge, every step; a metrics.csv column) and, with --needle-force, "
        "its force error (dimensionless), in summary.json as interpenetration_max and "
        "force_error.",
        epilog="Exit status: 0 graded; 2 bad input (one line on stderr: an unreadable or "
        "missing file, a symbolic-link loop, series that cannot fit in memory, ...); "
        f"{REFERENCE_DIVERGED} the reference diverged (SPEC 3: a non-finite displacement, or one "
        "beyond 100 x the domain's largest extent): the results are written, nothing from that "
        "step on is graded, and one line on stderr names the step and the value; 1 the "
        "environment failed; 130 and 143 interrupted (SIGINT, SIGTERM).",
    )
    p.add_argument(
        "reference",
        type=reference_arg,
        help="reference series (.xdmf, .pvd, .frd or .dat), or truth:CASE, the converged "
        f"reference of a SPEC 10 case ({', '.join(CASES)}; computed once and "
        "cached): the candidate is graded on its own mesh at the truth's vertices and "
        "quadrature points, and needs every t_i = i h",
    )
    p.add_argument("candidate", type=Path, help="candidate series (.xdmf, .pvd, .frd or .dat)")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    names = ", ".join(DEFAULT_FIELDS)
    p.add_argument(
        "--field",
        help=f"point field of both series (default: the first of {names} that each file holds)",
    )
    p.add_argument("--reference-field", help="point field of the reference (overrides --field)")
    p.add_argument("--candidate-field", help="point field of the candidate (overrides --field)")
    p.add_argument(
        "--label",
        help="the candidate's name in metrics.csv and summary.json (default: its file name "
        f"without suffix): printable text of 1 to {MAX_LABEL} characters without leading or "
        "trailing spaces, else refused in one line",
    )
    p.add_argument(
        "--wall-time",
        metavar="SECONDS",
        help="the candidate run's wall time in seconds from its posed problem to its last "
        "step, set-up included (assembly, factorisations, every step; not the interpreter's "
        "start nor writing output), as the leaderboard times our runs and the simulators'; "
        "recorded in summary.json; the leaderboard divides it by the simulated time to rank "
        "the run's cost (s per simulated s)",
    )
    p.add_argument(
        "--model",
        choices=list(MODELS),
        help="the candidate's elastic model, as you state it (recorded in summary.json): the "
        "leaderboard's row says it, and its error budget runs our implicit with it on the "
        "candidate's mesh (the model part: it against the truth's model; the algorithm part: "
        "your run against it). Default: the model of the case the reference poses",
    )
    p.add_argument(
        "--needle-force",
        type=Path,
        metavar="FILE.csv",
        help="against a contact reference (SPEC 12: the benchmark contact, or truth:contact-*): "
        "the candidate's needle force, columns time (s), force_x, force_y (N/m, the force per "
        "unit thickness the tissue exerts on the needle), one row per step; graded as the "
        "force error max_i |F - F_ref| / max |F_ref| against the reference's force (a "
        "truth's, impulse-averaged; our run's contact.csv or export). Without it the force "
        "error is 'not given'. Refused for any other reference",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="replace a compare folder of ours that holds results of other inputs",
    )
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    """Print (rank 0) how the series were read, where a series diverged, if it did, and the
    metrics' one-line summaries (with their units). Returns the exit status: 0, or
    REFERENCE_DIVERGED with one line on stderr when the reference diverged (this grading's,
    or that of the complete results kept for the same inputs)."""
    given = [args.needle_force] if args.needle_force is not None else []
    for path in (args.reference, args.candidate, *given):
        if not str(path).startswith(TRUTH_PREFIX):
            check_input_path(path)  # a symbolic-link loop: one line, exit 2
    summaries = compare(
        args.reference,
        args.candidate,
        args.out,
        field=args.field,
        reference_field=args.reference_field,
        candidate_field=args.candidate_field,
        label=args.label,
        wall_time=args.wall_time,
        force=args.force,
        needle_force=args.needle_force,
        model=args.model,
    )
    if MPI.COMM_WORLD.rank == 0:
        for line in summaries.values():
            print(line)
        if "skipped" not in summaries:
            print(f"wrote {args.out / 'metrics.csv'}, {args.out / 'metrics.png'} and summary.json")
    diverged = reference_divergence(summaries, args.out)
    if diverged is None:
        return 0
    if MPI.COMM_WORLD.rank == 0:
        print(
            f"tissuebench compare: the {diverged}; nothing from that step on is graded (status "
            f"'reference diverged' in {args.out / 'metrics.csv'}): compare against a reference "
            f"that did not diverge (exit status {REFERENCE_DIVERGED})",
            file=sys.stderr,
        )
    return REFERENCE_DIVERGED


def reference_arg(text: str) -> Path:
    """The reference argument: a series file, or truth:CASE with CASE checked as the arguments
    are parsed (a case without a truth is refused there, in one line)."""
    from tissuebench.metrics.truth import truth_case

    try:
        truth_case(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    return Path(text)


def reference_divergence(summaries: dict[str, str], out: Path) -> str | None:
    """ "reference diverged at step K (t = T s): REASON" when the reference diverged, as this
    grading's summaries say, or, when it was skipped, as the summary.json kept in `out` says;
    None when it did not."""
    if "skipped" not in summaries:
        return summaries.get("reference")
    summary = cast(dict[str, Any], read_compare_summary(out) or {})  # its keys read with get
    step, reason, h = (
        summary.get(k) for k in ("reference_diverged_step", "reference_diverged_reason", "h")
    )
    if step is None:
        return None
    at = f" (t = {step * h:.6g} s)" if isinstance(h, (int, float)) else ""
    return f"reference diverged at step {step}{at}: {reason}"
