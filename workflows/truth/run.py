"""What `tissuebench run` says of its runs against the truth (SPEC 10): where the run poses a
truth case (its benchmark, material, model, load scale and needle width; any mesh, scheme,
algorithm and contact penalty) and that truth is cached here, each run's E_i against it, as
`tissuebench compare truth:CASE` grades it; else one line saying why there is none. The truth
is never computed here (that takes minutes to an hour: `tissuebench truth CASE`)."""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.series import InputError
from tissuebench.metrics.truth import grade_truth
from tissuebench.solvers.materials import Material, get_material
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.fallbacks import fallbacks_of
from tissuebench.solvers.truth.store import cache_path, expected_words, load_cached, load_failure
from tissuebench.workflows.io.series import read_on_rank0
from tissuebench.workflows.io.summary import CaseSummary

E_I = "interior_error"  # the metric's name in a grading's curves (metrics/table.py)
# the options a truth case poses (the others, e.g. our contact penalty kappa, do not change it)
POSED = ("load_scale", "needle_width")
PROPERTIES = ("E", "nu", "rho", "alpha", "beta")


def truth_of(benchmark: str, material: Material, model: str, options: dict) -> str | None:
    """The truth case a run poses, or None: same benchmark, material (every property), model,
    load scale (default 1) and needle width (default none), and no other shape option."""
    extra = set(options) - set(POSED) - {"kappa"}
    if extra:
        return None
    for case, (bench, name, case_model, scale, width) in CASES.items():
        mat = get_material(name)
        if (
            bench == benchmark
            and case_model == model
            and all(getattr(mat, p) == getattr(material, p) for p in PROPERTIES)
            and float(options.get("load_scale", 1.0)) == scale
            and options.get("needle_width") == width
        ):
            return case
    return None


def truth_lines(
    summary: CaseSummary, folder: Path, material: Material, comm: MPI.Comm = MPI.COMM_WORLD
) -> list[str]:
    """One line per run of the case folder (every run in `material`, ours or a .toml file's)
    against its truth where that truth is cached (rank 0's lines; [] elsewhere), else one line
    saying why not. Collective."""
    if summary.plane not in (None, "strain"):
        return ["against the truth: none (the truths are posed in plane strain)"]
    lines: list[str] = []
    by_case: dict[str, list[str]] = {}
    for label, run in summary.runs.items():
        case = truth_of(summary.benchmark, material, run.model, summary.options)
        if case is None:
            lines.append(f"{label}: against the truth: none poses this run (SPEC 10's cases)")
            continue
        by_case.setdefault(case, []).append(label)
    for case, labels in by_case.items():
        truth = load_cached(case, comm=comm)
        if comm.allreduce(truth is not None if comm.rank == 0 else False, op=MPI.LOR) is False:
            instead = fallback_line(case)  # a case that does not converge: its fallback
            if instead is not None:
                lines.append(instead)
                continue
            failure = load_failure(case)
            if failure is not None:
                lines.append(
                    f"against the truth {case}: none, its computation fails (Newton, on n = "
                    f"{failure['level']} at t = {failure['t']:.3g} s; `tissuebench truth "
                    f"{case}` writes where to truth.md)"
                )
                continue
            lines.append(
                f"against the truth {case}: not cached here (`tissuebench truth {case}`, "
                f"{expected_words(case)} on one core, then `tissuebench compare truth:{case} "
                f"{folder}/RUN.xdmf --out DIR`)"
            )
            continue
        size = truth.own_error["size"] if comm.rank == 0 and truth is not None else np.nan
        located: dict = {}  # the runs share one mesh: the truth's points located in it once
        for label in labels:
            path = folder / f"{label}.xdmf"
            lines.append(_graded(truth, case, path, label, size, comm, located))
    return lines if comm.rank == 0 else []


def fallback_line(case: str) -> str | None:
    """Where `case` is one whose levels do not converge (solvers/truth/fallbacks.py takes it at
    smaller loads), one line naming its first fallback and the load scale to run at, where
    `run` grades its runs against that truth (the case the run then poses: truth_of), once it
    is cached; None for a case without fallbacks (computing its truth is the advice)."""
    taken = fallbacks_of(case)
    if not taken:
        return None
    first, scale = taken[0]
    when = (
        "its truth is cached here"
        if cache_path(first).is_file()
        else f"once `tissuebench truth {first}` has computed it, {expected_words(first)} on one "
        "core"
    )
    others = [f"{c} (s = {s:g})" for c, s in taken[1:]]
    more = f"; its other fallbacks: {', '.join(others)}" if others else ""
    return (
        f"against the truth {case}: none, its levels do not converge "
        f"(solvers/truth/fallbacks.py); its fallback is {first}, at load scale s = {scale:g}: "
        f"run again with --load-scale {scale:g} (the rest as here) and its runs are graded "
        f"against {first} ({when}){more}"
    )


def _graded(
    truth, case: str, path: Path, label: str, size: float, comm: MPI.Comm, located: dict
) -> str:
    """One run's line against the truth: its E_i max and mean (m^gdim), and max as a share of
    the truth's size (its E_i against rest); `located` as grade_truth's."""
    try:
        (cand,) = read_on_rank0(comm, (path, "displacement"))
        g = grade_truth(truth, cand, comm, label=label, surface=False, located=located)
    except InputError as err:
        return f"{label}: against the truth {case}: not graded ({err})"
    curve = np.asarray(g.curves[E_I], dtype=float)
    finite = curve[np.isfinite(curve)]
    if not finite.size:
        return f"{label}: against the truth {case}: no step graded"
    peak, mean = float(finite.max()), float(finite.mean())
    part = f", over {finite.size} of its {curve.size} steps" if finite.size < curve.size else ""
    return (
        f"{label}: against the truth {case}: E_i max {peak:.3g}, mean {mean:.3g} "
        f"({100 * peak / size:.2g} % of the truth's size{part})"
    )
