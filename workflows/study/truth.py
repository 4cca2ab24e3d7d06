"""The paper against the truth (issue 25, item 5; SPEC sections 7 and 10): data for the
section of results/README.md that report.truth_section renders.

- How far the paper's own reference (`implicit` on the paper's mesh) is from the truth: rod
  n = 3 against the truth `rod`; block N = 20 with a needle of width w = 0.2 m (the paper used
  a point needle, which has no converged solution, SPEC 10) for MP1 and MP2 against
  `block-MP1-w0.2` and `block-MP2-w0.2`.
- Claims 1, 2 and 5 of SPEC 7 with the truth as the yardstick: the paper's five algorithms on
  the block (MP1; and implicit, quasi-static MP2) at N = 20, w = 0.2, h = 1/30 s, T = 10 s, each
  graded against the truth of its case (claim 5: every run against the MP2 truth).

The runs are case folders of OUT (workflows/study.run_case: the output rule, skipped when
complete): truth-rod-MP3 and truth-block-w0.2. Each truth is read from its cache or, where it
is not cached on this machine (a first run), computed there once (solvers/truth/store.py:
about 65 s for the rod, 83 s and 269 s for the blocks on one core), with its expected time and its
progress said first.

Units: E_n and E_s dimensionless, E_i in m^d (m^2 on the block, m^3 on the rod) as SPEC 6.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.compare import summarize
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.io.series import read_on_rank0
from tissuebench.workflows.run.case import Case, algorithm_case, run_case

ALGORITHMS = ("implicit", "explicit", "implicit-lumped", "explicit-lumped", "quasi-static")
ORDER = ("explicit", "implicit-lumped", "explicit-lumped", "quasi-static")  # claim 1
METRICS = ("relative_error", "surface_error", "interior_error")  # E_n, E_s, E_i
READINGS = ("mean", "max")
FAR = 10  # 'far less' taken as ten times less (as report.FAR)
ROUGHLY = 2  # 'roughly the sum' taken as within a factor 2 (as report.ROUGHLY)
WIDTH = 0.2  # m, the needle width of the block's truth cases

ROD, BLOCK = "truth-rod-MP3", "truth-block-w0.2"  # the case folders in OUT
# (what, case folder, run label, truth case): the paper's own reference against the truth
REFERENCES = (
    ("rod, n = 3", ROD, "implicit", "rod"),
    ("block MP1, N = 20, w = 0.2 m", BLOCK, "implicit-MP1", "block-MP1-w0.2"),
    ("block MP2, N = 20, w = 0.2 m", BLOCK, "implicit-MP2", "block-MP2-w0.2"),
)


def cases(solver: str = "direct", petsc: str = "") -> list[Case]:
    """The runs graded against the truth: the rod's reference (n = 3) and, on the block at
    N = 20 with w = 0.2 m, the five algorithms with MP1 and implicit and quasi-static MP2 (the
    case's own metrics are against implicit MP2, as block-MP2-vs-MP1)."""
    runs = [
        ("implicit-MP2", "implicit", "MP2"),
        *((f"{a}-MP1", a, "MP1") for a in ALGORITHMS),
        ("quasi-static-MP2", "quasi-static", "MP2"),
    ]
    return [
        algorithm_case(
            ROD,
            "rod",
            "MP3",
            [],
            solver=solver,
            petsc=petsc,
            description="Bending rod, MP3, n = 3: the paper's reference, to be graded against "
            "the truth (SPEC 10)",
        ),
        Case(
            BLOCK,
            "block",
            runs,
            "implicit-MP2",
            options={"needle_width": WIDTH},
            solver=solver,
            petsc=petsc,
            description="Block and needle, N = 20, needle width w = 0.2 m: the five algorithms "
            "with MP1, implicit and quasi-static MP2, to be graded against the truth (SPEC 10)",
        ),
    ]


# --- the data ------------------------------------------------------------------------------


@dataclass
class Reference:
    """The paper's reference on one case against its truth: `values` {metric_reading: value}
    (None if the truth is not cached), the truth's own E_i max estimate `own`, and `command`,
    the line that computes the truth."""

    what: str
    label: str
    truth: str
    values: dict | None
    own: float
    command: str


@dataclass
class Claim:
    """A claim of SPEC 7 judged against the truth: `holds` (None if it could not be judged),
    `checks` {(metric, reading): bool}, `numbers` the values it rests on."""

    number: int
    holds: bool | None
    checks: dict = field(default_factory=dict)
    numbers: dict = field(default_factory=dict)
    parts: dict = field(default_factory=dict)  # {part of the claim: readings where it holds}


@dataclass
class PaperTruth:
    """Everything the section shows: the references, every graded run {truth: {label:
    {metric_reading: value}}}, the truths' own errors {truth: E_i max}, the claims, and the
    truth cases that are not cached."""

    references: list
    graded: dict
    own: dict
    claims: list
    missing: list


# --- the verdicts (pure) -------------------------------------------------------------------


def ordered(errors: dict) -> bool:
    """Claim 1 on one metric and reading: explicit < both lumped schemes < quasi-static."""
    e, il, el, qs = (errors[a] for a in ORDER)
    return bool(e < min(il, el) and max(il, el) < qs)


def sum_ratio(explicit: float, implicit_lumped: float, explicit_lumped: float) -> float:
    """Claim 2: explicit-lumped's error over explicit's plus lumping's (implicit-lumped's)."""
    return explicit_lumped / (explicit + implicit_lumped)


def roughly(ratio: float) -> bool:
    """'Roughly the sum': the ratio within a factor ROUGHLY of 1."""
    return bool(1 / ROUGHLY <= ratio <= ROUGHLY)


def material_ratio(quasi_static_mp2: float, mp1: dict) -> tuple[str, float]:
    """Claim 5: (the MP1 run of smallest error, its error over quasi-static MP2's)."""
    smallest = min(mp1, key=lambda k: mp1[k])
    return smallest, mp1[smallest] / quasi_static_mp2


def claim_order(runs: dict) -> Claim:
    """Claim 1 from {algorithm: {metric_reading: value}} of the MP1 runs against the MP1 truth;
    the verdict rests on the time-mean of every metric (as the paper's report)."""
    checks, numbers = {}, {}
    parts = {"explicit the closest": 0, "quasi-static the worst": 0}
    for m in METRICS:
        for r in READINGS:
            errors = {a: runs[a][f"{m}_{r}"] for a in ORDER}
            checks[m, r] = ordered(errors)
            numbers[m, r] = errors
            parts["explicit the closest"] += errors["explicit"] == min(errors.values())
            parts["quasi-static the worst"] += errors["quasi-static"] == max(errors.values())
    return Claim(1, all(checks[m, "mean"] for m in METRICS), checks, numbers, parts)


def claim_sum(runs: dict) -> Claim:
    """Claim 2 from {algorithm: {metric_reading: value}}: on the time-mean of E_n (as the
    paper's report), with E_i and the maxima beside it."""
    checks, numbers = {}, {}
    for m in ("relative_error", "interior_error"):
        for r in READINGS:
            e, il, el = (runs[a][f"{m}_{r}"] for a in ORDER[:3])
            ratio = sum_ratio(e, il, el)
            checks[m, r] = roughly(ratio)
            numbers[m, r] = {
                "explicit": e,
                "implicit-lumped": il,
                "explicit-lumped": el,
                "ratio": ratio,
            }
    return Claim(2, checks["relative_error", "mean"], checks, numbers)


def claim_material(runs: dict) -> Claim:
    """Claim 5 from {label: {metric_reading: value}} against the MP2 truth (labels
    ALGORITHM-MP1 and quasi-static-MP2): the smallest MP1 error more than FAR times
    quasi-static MP2's, on the time-mean of every metric."""
    checks, numbers = {}, {}
    parts = {"quasi-static MP2 below every MP1 run": 0}
    mp1 = [f"{a}-MP1" for a in ALGORITHMS]
    for m in METRICS:
        for r in READINGS:
            q = runs["quasi-static-MP2"][f"{m}_{r}"]
            smallest, ratio = material_ratio(q, {k: runs[k][f"{m}_{r}"] for k in mp1})
            checks[m, r] = bool(ratio > FAR)
            parts["quasi-static MP2 below every MP1 run"] += bool(ratio > 1)
            numbers[m, r] = {
                "quasi-static-MP2": q,
                "smallest": smallest,
                "value": runs[smallest][f"{m}_{r}"],
                "ratio": ratio,
            }
    return Claim(5, all(checks[m, "mean"] for m in METRICS), checks, numbers, parts)


def judge(graded: dict) -> list[Claim]:
    """Claims 1, 2 and 5 from the graded runs {truth: {label: values}}; a claim whose truth
    is missing is Claim(n, None)."""
    mp1 = graded.get("block-MP1-w0.2")
    mp2 = graded.get("block-MP2-w0.2")
    claims = []
    if mp1 is None:
        claims += [Claim(1, None), Claim(2, None)]
    else:
        runs = {a: mp1[f"{a}-MP1"] for a in ALGORITHMS}
        claims += [claim_order(runs), claim_sum(runs)]
    claims.append(Claim(5, None) if mp2 is None else claim_material(mp2))
    return claims


# --- grading -------------------------------------------------------------------------------


def _values(curves: dict) -> dict:
    values = {}
    for m in METRICS:
        peak, mean = summarize(curves[m])
        values[f"{m}_max"], values[f"{m}_mean"] = peak, mean
    return values


def grade_runs(folder: Path, labels: list[str], truth: TruthSamples | None, comm: MPI.Comm) -> dict:
    """{label: {metric_reading: value}} of each run's displacement series (folder/label.xdmf)
    graded against the truth (rank 0's TruthSamples). Collective."""
    from tissuebench.metrics.truth import grade_truth

    result = {}
    for label in labels:
        (series,) = read_on_rank0(comm, (folder / f"{label}.xdmf", "displacement"))
        result[label] = _values(grade_truth(truth, series, comm, label=label).curves)
    return result


# truth case: (the case folder of its runs, the labels graded against it; None: every run)
WANTED: dict[str, tuple[str, list[str] | None]] = {
    "rod": (ROD, ["implicit"]),
    "block-MP1-w0.2": (BLOCK, [f"{a}-MP1" for a in ALGORITHMS]),
    "block-MP2-w0.2": (BLOCK, None),
}


TRUTHS = tuple(WANTED)  # the truth cases the section needs, in its order
# the busy processes beside the truths' workers in a first paper: the paper's own, running its
# cases (in the bench of 2026-11-28 they took block-MP2-w0.2's truth from 288 s, as estimated
# for two free cores, to 478 s; jobs.sharing counts it)
BESIDE = 1


def missing(comm: MPI.Comm = MPI.COMM_WORLD) -> list[str]:
    """The truth cases of TRUTHS with no cache file on this machine (the same on every rank;
    a file that cannot be read is found, said and computed again when it is read)."""
    from tissuebench.solvers.truth.store import cache_path

    names = [name for name in TRUTHS if not cache_path(name).is_file()] if comm.rank == 0 else None
    return comm.bcast(names, root=0)


def first_run_line(names: list[str], jobs: int = 1) -> str:
    """One line before a paper whose truths are not cached: which, how long they take, and
    whether they are computed `jobs` processes at a time beside the paper's cases (jobs > 1) or
    one after another after them."""
    from tissuebench.solvers.truth.store import cache_dir, expected_seconds, expected_words
    from tissuebench.workflows.truth.jobs import left_seconds

    each = ", ".join(f"{name} ({expected_words(name)})" for name in names)
    seconds = [expected_seconds(name) for name in names]
    if jobs > 1:
        when = (
            f"{jobs} processes at a time beside the paper's cases (about "
            f"{left_seconds(names, [], False, jobs, BESIDE) / 60:.0f} min here)"
        )
    else:
        when = f"after the paper's cases (about {sum(seconds) / 60:.0f} min in all on one core)"
    return (
        f"paper: the truths {each} are not cached on this machine: computed once in this run, "
        f"{when}; later runs read them from {cache_dir()}"
    )


def run_folders(
    out: Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    solver: str = "direct",
    petsc: str = "",
    force: bool = False,
    log: Callable[[str], None] = print,
) -> dict[str, tuple[Path, list[str]]]:
    """Run (or keep) the case folders OUT/truth-*: {case folder: (folder, its run labels)}.
    They need no truth (grade() reads it). Collective."""
    folders = {}
    for case in cases(solver, petsc):
        folder = Path(out) / case.name
        labels = [run.label for run in case.runs]
        missing = any(not (folder / f"{label}.xdmf").is_file() for label in labels)
        missing = comm.bcast(missing, root=0)  # the series are not committed: run them again
        run_case(case, folder, comm, log=log, force=force or missing)
        folders[case.name] = (folder, labels)
    return folders


def grade(
    name: str,
    folders: dict[str, tuple[Path, list[str]]],
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] = print,
) -> tuple[dict, float | None]:
    """({label: {metric_reading: value}}, the truth's own E_i max in m^d) of the runs that the
    truth case `name` (of TRUTHS) grades, in `folders` (run_folders'): the truth read from its
    cache or, where it is not cached, computed there once (its expected time and progress said
    to `log`). Collective."""
    from tissuebench.metrics.truth import own_error
    from tissuebench.solvers.truth.store import truth_samples

    case, labels = WANTED[name]
    folder = folders[case][0]
    truth = truth_samples(name, comm=comm, log=log if comm.rank == 0 else None)
    own = comm.bcast(own_error(truth) if comm.rank == 0 and truth is not None else None, root=0)
    return grade_runs(folder, folders[case][1] if labels is None else labels, truth, comm), own


def compute(
    out: Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    solver: str = "direct",
    petsc: str = "",
    force: bool = False,
    log: Callable[[str], None] = print,
) -> PaperTruth:
    """Run (or keep) the case folders OUT/truth-*, grade their runs against each truth (read
    from its cache, or computed and cached where it is not: its expected time and progress are
    said to `log`) and judge claims 1, 2 and 5. Collective."""
    return finish(run_folders(out, comm, solver, petsc, force, log), {}, comm, log)


def finish(
    folders: dict[str, tuple[Path, list[str]]],
    done: dict[str, tuple[dict, float | None]],
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] = print,
) -> PaperTruth:
    """The section's data: each truth of TRUTHS graded in its order, as `done` already holds
    it ({truth: grade()'s pair}: those graded as their workers ended) or by grade() here, and
    claims 1, 2 and 5 judged. Collective."""
    pairs = {
        name: done[name] if name in done else grade(name, folders, comm, log) for name in TRUTHS
    }
    return assemble(
        {name: graded for name, (graded, _) in pairs.items()},
        {name: own for name, (_, own) in pairs.items()},
        [],
    )


def assemble(graded: dict, own: dict, missing: list[str]) -> PaperTruth:
    """The section's data from the runs graded against each truth (`graded`: truth case ->
    {run label: values}), the truths' own errors (m^d) and the truths not computed."""
    references = [
        Reference(
            what,
            label,
            name,
            graded[name][label] if name in graded else None,
            own.get(name, np.nan),
            f"tissuebench truth {name}",
        )
        for what, _, label, name in REFERENCES
    ]
    return PaperTruth(references, graded, own, judge(graded), missing)
