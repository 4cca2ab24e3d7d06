"""Grading a simulator's output against a reference, with files: `compare` checks the options
and that the output folder can be written, grades (metrics/compare.py) and writes
OUT/metrics.csv, OUT/metrics.png and OUT/summary.json, each renamed into place once complete
(rank 0 writes).

OUT/summary.json is compare's summary, shaped like a run folder's so that an outside run can
join a table of ours: `kind` "compare", the `reference` and `candidate` files with the field
read from each (the candidate's path absolute, symbolic links resolved, so that the
leaderboard finds its series from any working folder), `notes` (how the series were read),
`h`, `steps`, `end_time`, `metrics` ({metric: {symbol, unit}}: E_n and E_s dimensionless,
E_i in m^d) and `runs` {label: {status, diverged_step, diverged_time, steps, wall_time_s,
<metric>_max, <metric>_mean for every metric}}; the candidate's label and wall time are
`--label` and `--wall-time` (the run's total wall seconds, setup included).
Against a contact reference (SPEC 12: workflows/compare/contact.py) summary.json also has
`contact` {force_error (1; null without --needle-force), interpenetration_max (m), force_given,
force_file, force_reference, reference_force_own_error, units}, the run's entry force_error and
interpenetration_max, `metrics` their symbols and units, and metrics.csv the columns
interpenetration (m) and, with a force, force_x and force_y (N/m) after the status; other
references' files are as before.
`reference.fingerprint` says what the reference is (reference_fingerprint: its benchmark, case,
options, material, model, h, T, mesh size, nodes and dimension, as its run folder or the
export beside it says, or the truth case), and `candidate.mesh` the candidate's mesh (mesh_of:
cell type, cells, nodes, dofs): the leaderboard takes a compare folder only under the case it
was graded against.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.core.fingerprint import fingerprint
from tissuebench.metrics.cells import NAMES
from tissuebench.metrics.compare import Grading, grade_series, metric_units, summarize, unit
from tissuebench.metrics.table import METRICS, panels
from tissuebench.metrics.truth import TruthGrading, grade_truth, truth_case
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.compare.contact import (
    CONTACT_METRICS,
    ContactReference,
    contact_grades,
    force_columns,
    is_contact_reference,
    reference_benchmark,
)
from tissuebench.workflows.compare.fingerprint import (
    mesh_of,
    reference_fingerprint,
    truth_fingerprint,
)
from tissuebench.workflows.io.manifest import file_hash
from tissuebench.workflows.io.output import RunFolder, collective
from tissuebench.workflows.io.series import read_on_rank0
from tissuebench.workflows.io.summary import (  # candidate_file: read here by others
    SCHEMA_VERSION,
    SUMMARY,
    CompareSummary,
    candidate_file,  # noqa: F401
    dumps,
)
from tissuebench.workflows.io.tables import spans_decades, write_metrics_csv

MAX_LABEL = 64  # characters of a candidate's label (it names rows, figures and tables)


def load_truth(case: str, comm: MPI.Comm = MPI.COMM_WORLD) -> TruthSamples | None:
    """The truth of a case, computed or loaded from its cache (solvers/truth/store.py;
    collective); rank 0 prints its progress. Rank 0's TruthSamples is the one used: it is
    handed to metrics/truth.py, which grades and computes nothing else."""
    from tissuebench.solvers.truth.store import cache_path, truth_samples

    log = say(comm)
    if comm.rank == 0 and cache_path(case).is_file():  # its reading takes seconds (200 MB)
        megabytes = cache_path(case).stat().st_size / 1e6
        log(f"truth {case}: reading it from the cache ({megabytes:,.0f} MB)")
    return truth_samples(case, comm=comm, log=log)


def say(comm: MPI.Comm = MPI.COMM_WORLD) -> Callable[[str], None]:
    """A line of progress on stdout, at once (flushed), from rank 0; nothing on the others."""

    def line(text: str) -> None:
        if comm.rank == 0:
            print(text, flush=True)

    return line


class GradingError(UserError):
    """Options of compare that cannot be taken (a label, a wall time): one line, exit 2."""


def check_label(label: str | None, candidate: str | Path | None = None) -> None:
    """Refuse (GradingError, one line saying why) a label that is not printable text of 1 to
    MAX_LABEL characters without leading or trailing spaces: `label`, or where it is None the
    one the candidate's file name gives (its name without suffix), which names the run as
    --label would (rows, figures, tables, the leaderboard's page)."""
    given = label is not None
    if not given:
        if candidate is None:
            return
        label = Path(candidate).stem
    assert label is not None  # given, or the file's
    problem = None
    if not 0 < len(label) <= MAX_LABEL:
        problem = f"is {len(label):,} characters long (at most {MAX_LABEL})"
    elif not label.isprintable():
        problem = "has characters that are not printable (a newline, a tab, a control)"
    elif label.strip() != label:
        problem = "has leading or trailing spaces"
    if problem is None:
        return
    shown = repr(label)[:40] + ("..." if len(repr(label)) > 40 else "")
    rule = f"printable text of 1 to {MAX_LABEL} characters without leading or trailing spaces"
    if given:
        raise GradingError(
            f"--label must be {rule}; {shown} {problem}: name the run, for example "
            "--label my-solver"
        )
    raise GradingError(
        f"the candidate's file name gives the label {shown}, which {problem}: a label must be "
        f"{rule}: name the run with --label, for example --label my-solver"
    )


def check_wall_time(wall_time) -> float | None:
    """The candidate's wall time in s: a finite number >= 0 (text is converted), or None."""
    if wall_time is None:
        return None
    try:
        value = float(wall_time)
    except (TypeError, ValueError):
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise GradingError(
            f"--wall-time must be a finite number of seconds >= 0, got {wall_time!r}: give "
            "the run's wall time in seconds, for example --wall-time 12.5"
        )
    return value


def compare(
    reference: str | Path,
    candidate: str | Path,
    out_dir: str | Path,
    field: str | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    reference_field: str | None = None,
    candidate_field: str | None = None,
    label: str | None = None,
    wall_time: float | str | None = None,
    force: bool = False,
    folder_of_ours: bool = False,
    needle_force: str | Path | None = None,
    contact: ContactReference | None = None,
    model: str | None = None,
) -> dict[str, str]:
    """Grade the candidate series against the reference series (XDMF, PVD, CalculiX .frd or
    .dat), write out_dir/metrics.csv, metrics.png and summary.json, and return the one-line
    summaries (see metrics.compare.Grading), the notes on how the series were read first
    (keys "note 1", ...). Collective; nothing is written unless everything was read, checked
    and computed.

    out_dir follows the output-folder rules (workflows/io/output.py): new, empty, or a compare
    folder of ours; complete results of the same inputs (the files' hashes, the fields, the
    label and the wall time) are kept unless `force`, and other inputs are refused without it.
    `folder_of_ours` writes straight into a folder that the caller is writing already (an
    external simulator's variant inside its own partial folder). A reference `truth:CASE` is
    SPEC 10's truth of that case (computed or loaded by solvers/truth/store.py; graded by
    metrics/truth.py; summary.json gets a "truth" entry: case, own error, timings).

    A contact reference (SPEC 12: a truth, run folder or export of the benchmark "contact", or
    `contact` given, as the external runner gives its export's) grades the candidate's
    interpenetration too and, with `needle_force` (the candidate's force file), its force
    error (workflows/compare/contact.py); `needle_force` against any other reference is
    refused in one line. `model`: the candidate's elastic model as its user states it (one of
    solvers.MODELS), in summary.json's candidate and inputs; the leaderboard's row and its
    error budget take it (none: the reference's)."""
    from tissuebench.solvers.models import MODELS

    if model is not None and model not in MODELS:
        raise GradingError(f"--model {model}: not an elastic model; one of {', '.join(MODELS)}")
    check_label(label, candidate)
    wall = check_wall_time(wall_time)
    case = truth_case(reference, reference_field)  # `truth:CASE`: SPEC 10's truth (None: a file)
    in_contact = is_contact_reference(reference, case, contact, comm)
    if needle_force is not None and not in_contact:
        raise GradingError(
            "--needle-force is for a contact reference (SPEC 12: the benchmark contact, or "
            f"truth:contact-...); {reference} is not one: leave --needle-force out"
        )
    if needle_force is not None and not Path(needle_force).is_file():  # before it is hashed
        what = "a folder" if Path(needle_force).is_dir() else "not a regular file"
        if not Path(needle_force).exists():
            what = "missing"
        raise GradingError(f"--needle-force {needle_force}: a CSV file is needed; this is {what}")
    truth = None

    def grading() -> Grading:  # against the reference's file, or the truth
        if case is not None:
            g = grade_against_truth(
                truth,
                candidate,
                candidate_field or field,
                comm,
                label,
                keep=in_contact,
                log=say(comm),
            )
        else:
            g = grade(
                reference,
                candidate,
                field,
                comm,
                reference_field=reference_field,
                candidate_field=candidate_field,
                label=label,
                keep=in_contact,
            )
        if in_contact:
            grades = collective(
                comm, lambda: contact_grades(g, reference, truth, contact, needle_force)
            )
            setattr(g, "contact", grades)
            g.summaries.update(grades.summaries())
        return g

    if folder_of_ours:
        truth = load_truth(case, comm) if case is not None else None
        g = grading()
        summary = summary_of(g, reference, candidate, wall)
        collective(comm, lambda: write_grading(Path(out_dir), g, summary), Path(out_dir))
        return {**{f"note {k + 1}": note for k, note in enumerate(g.notes)}, **g.summaries}
    with RunFolder(out_dir, comm) as folder:
        inputs = collective(  # a truth's by its inputs' fingerprint: read only if graded
            comm,
            lambda: compare_inputs(
                reference,
                candidate,
                field,
                reference_field,
                candidate_field,
                label,
                wall,
                case,
                needle_force,
                model,
            ),
        )
        if folder.prepare(inputs, force) == "complete":
            return {
                "skipped": f"{out_dir}: complete results for the same inputs exist, skipped "
                "(--force grades again)"
            }
        truth = load_truth(case, comm) if case is not None else None
        g = grading()
        summary = summary_of(g, reference, candidate, wall)
        if model is not None:  # as stated by the user (absent: the reference's)
            summary["candidate"]["model"] = model
        summary["inputs"], summary["fingerprint"] = inputs, fingerprint(inputs)
        with folder.writing() as tmp:
            collective(comm, lambda: write_grading(tmp, g, summary), folder.path)
    return {**{f"note {k + 1}": note for k, note in enumerate(g.notes)}, **g.summaries}


def series_files(path: Path) -> dict[str, str]:
    """{name: SHA-256} of a series file and the files that belong to it beside it (its .h5,
    the .vtu of a .pvd, the .inp of a .dat: every file named STEM.* or STEM_*)."""
    path = Path(path)
    if not path.is_file():
        return {}
    stem = path.name.split(".")[0]
    siblings = [
        p
        for p in sorted(path.parent.iterdir())
        if p.is_file() and (p.name.startswith(f"{stem}.") or p.name.startswith(f"{stem}_"))
    ]
    return {p.name: file_hash(p) for p in {path, *siblings}}


def compare_inputs(
    reference,
    candidate,
    field,
    reference_field,
    candidate_field,
    label,
    wall,
    case=None,
    needle_force=None,
    model=None,
):
    """Every input that changes a compare folder's numbers (rank 0: it reads the files); for a
    truth (`case`), its case and the fingerprint of its inputs (the cache's key: known without
    reading the truth, which a complete folder of the same inputs never needs); the candidate's
    needle force file and its stated model when given (absent otherwise, so that other folders
    keep their fingerprint)."""
    from importlib.metadata import version

    if case is not None:
        from tissuebench.solvers.truth.store import inputs as truth_inputs

        ref = {"truth": case, "fingerprint": fingerprint(truth_inputs(case))}
    else:
        ref = {"file": str(Path(reference).resolve()), "files": series_files(reference)}
    given = {}
    if needle_force is not None:
        path = Path(needle_force)
        given = {"needle_force": {"file": str(path.resolve()), "sha256": file_hash(path)}}
    if model is not None:
        given["model"] = model
    return {
        **given,
        "command": "compare",
        "reference": ref,
        "candidate": {"file": str(Path(candidate).resolve()), "files": series_files(candidate)},
        "field": field,
        "reference_field": reference_field,
        "candidate_field": candidate_field,
        "label": label,
        "wall_time_s": wall,
        "tissuebench": version("tissuebench"),
    }


def none_if_nan(x):
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else x


def summary_of(g: Grading, reference, candidate, wall_time: float | None) -> CompareSummary:
    """compare's summary.json (see the module docstring)."""
    from importlib.metadata import version

    times = g.times
    graded = g.status.count("ok")
    worst = next((s for s in g.status if s != "ok"), "ok")
    entry = {
        "status": worst,
        "diverged_step": g.candidate_diverged,
        "diverged_time": None
        if g.candidate_diverged is None
        else float(times[g.candidate_diverged]),
        "reason": g.candidate_reason,
        "steps": g.candidate_steps - 1,
        "graded_steps": max(graded - 1, 0),
        "wall_time_s": wall_time,
    }
    for name in METRICS:
        peak, mean = summarize(g.curves[name])
        entry[f"{name}_max"], entry[f"{name}_mean"] = none_if_nan(peak), none_if_nan(mean)
    steps = len(times) - 1
    dim = (getattr(g, "candidate_mesh", None) or {}).get("dimension")
    truth = {"truth": g.summary()} if isinstance(g, TruthGrading) else {}
    metrics = metric_units(dim)
    grades = getattr(g, "contact", None)
    contact = {}
    if grades is not None:  # SPEC 12: a contact reference's two readings (absent otherwise)
        entry.update(grades.entry())
        metrics = {**metrics, **CONTACT_METRICS}
        contact = {"contact": grades.summary()}
    return {
        "kind": "compare",
        "schema_version": SCHEMA_VERSION,
        "reference": {
            "file": str(reference),
            "field": g.fields[0],
            "fingerprint": {
                **(getattr(g, "reference_fingerprint", None) or {}),
                "h": float(times[1] - times[0]) if steps else None,
                "end_time": float(times[-1]),
            },
        },
        "candidate": {
            "file": str(Path(candidate).resolve()),  # found from any working folder
            "field": g.fields[1],
            "label": g.label,
            "mesh": getattr(g, "candidate_mesh", None),
        },
        "notes": g.notes,
        "h": float(times[1] - times[0]) if steps else None,
        "steps": steps,
        "end_time": float(times[-1]),
        "metrics": metrics,
        "reference_diverged_step": g.reference_diverged,
        "reference_diverged_reason": g.reference_reason,
        "runs": {g.label: entry},
        "versions": {"tissuebench": version("tissuebench")},
        "files": ["metrics.csv", "metrics.png", SUMMARY],
        **truth,  # type: ignore[typeddict-item]
        **contact,
    }


def write_grading(out: Path, g: Grading, summary: CompareSummary) -> None:
    """metrics.csv, metrics.png and summary.json in out, each renamed into place once
    complete."""
    out.mkdir(parents=True, exist_ok=True)
    final = [out / "metrics.csv", out / "metrics.png", out / SUMMARY]
    temporary = [p.with_name(f".{p.name}.{os.getpid()}.tmp") for p in final]
    try:
        grades = getattr(g, "contact", None)
        extra = None if grades is None else {g.label: force_columns(grades, len(g.times))}
        write_metrics_csv(
            temporary[0], g.times, {g.label: g.curves}, {g.label: g.status}, extra=extra
        )
        plot(temporary[1], g.title, g.times, g.curves, metric_dim(summary), grades)
        temporary[2].write_text(dumps(summary))
        for tmp, path in zip(temporary, final, strict=True):
            os.replace(tmp, path)
    finally:
        for tmp in temporary:
            tmp.unlink(missing_ok=True)


def metric_dim(summary) -> int | None:
    """The body's dimension that a compare summary's E_i unit states ("m^3": 3), or None."""
    for entry in (summary.get("metrics") or {}).values() if isinstance(summary, dict) else ():
        u = entry.get("unit") if isinstance(entry, dict) else None
        if isinstance(u, str) and u.startswith("m^") and u[2:].isdigit():
            return int(u[2:])
    return None


@interrupt.drawing  # a signal while drawing: raised once drawn (core/interrupt.py)
def plot(path, title, times, curves, dim: int | None = None, contact=None):
    """One panel per metric against time (E_n, E_s, E_i with its unit on a body of dimension
    `dim`; a variant such as E_i's nodal form dashed in its metric's panel); against a contact
    reference (`contact`: its ContactGrades) the interpenetration (mm) and, where the candidate
    hands it, its force on the tool (N/m in 2D, N in 3D) too."""
    from matplotlib.figure import Figure  # no pyplot: no global backend state

    groups = panels()
    extra = 0 if contact is None else 1 + (contact.force is not None)
    fig = Figure(figsize=(7, 2.7 * (len(groups) + extra)), layout="constrained")
    axes = fig.subplots(len(groups) + extra, 1, sharex=True, squeeze=False)[:, 0]
    for ax, names in zip(axes, groups, strict=False):
        for name, style in zip(names, ["-", "--"], strict=False):
            ax.plot(times, curves[name], style, label=METRICS[name].label)
        if spans_decades(np.concatenate([curves[n] for n in names])):
            ax.set_yscale("log")
        u = unit(names[0], dim)
        said = "" if u in (None, "dimensionless") else f" ({u})"
        ax.set_ylabel(METRICS[names[0]].label + said)
        ax.grid(True, alpha=0.3)
        if len(names) > 1:
            ax.legend()
    if contact is not None:
        ax = axes[len(groups)]
        ax.plot(times, 1e3 * np.asarray(contact.interpenetration), color="C3")
        ax.set_ylabel("interpenetration,\nlargest -g_n (mm)")
        ax.grid(True, alpha=0.3)
        if contact.force is not None:
            ax = axes[len(groups) + 1]
            force = np.asarray(contact.force)
            for i in range(force.shape[1]):
                ax.plot(times[: len(force)], force[:, i], label=f"F_{'xyz'[i]}")
            ax.set_ylabel(f"force on the tool ({contact.force_unit})")
            ax.legend(fontsize=8)
            ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].set_title(title)
    fig.savefig(path, format="png", dpi=120)


# --- grading files ---------------------------------------------------------------------------


def body_of(reference: str | Path) -> dict | None:
    """The body of the benchmark that the reference poses (its folder says which), where it is
    no box (its entry's `body`: the cylinder's curved side); None otherwise or when unknown."""
    from tissuebench.meshes import BENCHMARKS

    name = reference_benchmark(reference, None)
    entry = BENCHMARKS.get(name) if isinstance(name, str) else None
    return entry.body if entry is not None and entry.body else None


def grade(
    reference: str | Path,
    candidate: str | Path,
    field: str | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    *,
    reference_field: str | None = None,
    candidate_field: str | None = None,
    label: str | None = None,
    keep: bool = False,
) -> Grading:
    """Measure the candidate series against the reference series (XDMF, PVD, CalculiX .frd or
    .dat files). The point field of each side is `reference_field` / `candidate_field`, else
    `field`, else the first of series.DEFAULT_FIELDS that the file holds. A series that
    starts at t = h starts from the zero initial state at t = 0 (a note says so). A series'
    first step with a non-finite displacement, or one beyond 100 times its largest extent, is
    its divergence (Grading gives the reason): nothing is graded from there on. A candidate
    on another mesh of the reference's body (triangles, quadrilaterals, tetrahedra or
    hexahedra) is graded on its own mesh, SPEC section 9 (a note says so).
    `label` names the candidate (default: its file name without suffix). Collective over
    comm; the same Grading on every rank. `keep`: rank 0's Grading keeps the candidate series
    read (`candidate_series`).

    Raises InputError on every rank for unreadable files, meshes of different dimensions or
    bodies, time stamps that do not match, degenerate cells, a mesh boundary that touches
    itself, a missing field, complex values, or a series whose steps change the mesh or
    its node order.
    """
    ref, cand = read_on_rank0(
        comm, (reference, reference_field or field), (candidate, candidate_field or field)
    )
    body = body_of(reference) if comm.rank == 0 else None  # rank 0 checks the body
    g = grade_series(ref, cand, comm, label=label, body=body)
    if comm.rank == 0:  # rank 0 writes the summary (its attributes beyond Grading's: getattr)
        setattr(g, "reference_fingerprint", reference_fingerprint(reference, ref))
        setattr(g, "candidate_mesh", mesh_of(cand))
        if keep:
            setattr(g, "candidate_series", cand)
    return g


def grade_against_truth(
    truth: TruthSamples | None,
    candidate: str | Path,
    field: str | None = None,
    comm: MPI.Comm = MPI.COMM_WORLD,
    label: str | None = None,
    keep: bool = False,
    log: Callable[[str], None] | None = None,
) -> TruthGrading:
    """Read the candidate series file (XDMF, PVD, CalculiX .frd or .dat; point field `field`,
    else the first of series.DEFAULT_FIELDS it holds) on rank 0 and grade it against the
    truth (rank 0's) with grade_truth. Collective; InputError on every rank as grade_truth,
    and for an unreadable file. `keep` as grade's. `log` (rank 0's) hears what is being done
    as it starts (reading, locating, grading: seconds each on a large candidate) and the time
    the grading took."""
    if log is not None:
        log(f"reading the candidate {candidate}")
    (cand,) = read_on_rank0(comm, (candidate, field))
    if log is not None and truth is not None and cand is not None:  # rank 0's
        log(
            f"grading it against the truth {truth.case}: locating its {len(cand.points):,} nodes "
            f"({len(cand.cells):,} {NAMES[cand.cell_type]}) in the truth's mesh, then E_n, E_i "
            f"and E_s at each of its {len(cand.times):,} time steps"
        )
    g = grade_truth(truth, cand, comm, label=label, log=log)
    if comm.rank == 0:  # rank 0 writes the summary (its attributes beyond Grading's: getattr)
        assert truth is not None  # rank 0's
        setattr(g, "reference_fingerprint", truth_fingerprint(truth.case))
        setattr(g, "candidate_mesh", mesh_of(cand))
        if keep:
            setattr(g, "candidate_series", cand)
    return g
