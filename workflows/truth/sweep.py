"""SPEC 10's load sweep below the large rod's fold, in truth.md: for each load scale tried
(solvers/truth/fallbacks.py ROD_SWEEP, in its order of preference), its levels' smallest J,
the first level that folded (J below FOLDED at a quadrature point) and when, whether its levels
converge and its own error meets the target; and which s is the case rod-nhb-sL."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np

from tissuebench.solvers.truth.cases import CASES, GRADED
from tissuebench.solvers.truth.fallbacks import ROD_SWEEP, SWEEP_CASES
from tissuebench.workflows.io.text import fmt
from tissuebench.workflows.truth.crease import FOLDED

SOURCE = "rod-nhb-s3"  # the case that creases (SPEC 10)
# PETSc's SNES reasons for a Newton solve that did not converge, as the truth's error gives them
SNES_REASONS = {
    -3: "its linear solve failed",
    -4: "a non-finite residual",
    -5: "its iteration limit",
    -6: "its line search failed",
    -8: "its residual stopped decreasing",
}


def sweep_cases() -> list[str]:
    """The sweep's cases in the order tried: graded, largest s first; then the uniform ones."""
    return list(SWEEP_CASES)


def levels_of_case(case: str) -> str:
    """How a sweep case's levels are laid out: "graded" or "uniform"."""
    return "graded" if case in GRADED else "uniform"


def fallback(summaries: dict) -> str | None:
    """The uniform-level case whose truth meets the target, where no graded one does."""
    return _first_meeting(summaries, "uniform")


def folded(h: dict) -> tuple[int, float] | None:
    """(level, t in s) of the coarsest level whose smallest J falls below FOLDED, and the first
    step it does; None when no level folds."""
    dt = h["h"]
    for level, series in zip(h["levels"], h["min_jacobian"], strict=True):
        below = np.flatnonzero(np.asarray(series) < FOLDED)
        if below.size:
            return level, float(below[0] * dt)
    return None


def chosen(summaries: dict) -> str | None:
    """The case rod-nhb-sL: the largest s of the sweep whose graded truth meets the target
    (None: none computed does)."""
    return _first_meeting(summaries, "graded")


def _first_meeting(summaries: dict, levels: str) -> str | None:
    """The first sweep case on `levels` ("graded", "uniform") whose truth meets the target."""
    for case in SWEEP_CASES:
        summary = summaries.get(case)
        if levels_of_case(case) == levels and summary and summary["own_error"]["meets_target"]:
            return case
    return None


def failure_words(failure: dict) -> str:
    """A failed computation of the sweep in words: which level failed when, its smallest J."""
    j = failure.get("smallest_J")
    at = failure.get("smallest_J_at") or []
    where = f" at X = ({', '.join(f'{x:.3f}' for x in at)}) m" if at else ""
    smallest = "" if j is None else f"; smallest J before it {j:.3g}{where}"
    code = re.search(r"\((-?\d+)\)\s*$", failure["error"])
    why = SNES_REASONS.get(int(code.group(1)), f"reason {code.group(1)}") if code else ""
    return (
        f"Newton fails on n = {failure['level']} at t = {failure['t']:.3g} s"
        f"{f' ({why})' if why else ''}{smallest}"
    )


def failure_fold(failure: dict) -> str:
    """The folded column of a failed computation: its level, if its last state's J < FOLDED."""
    j = failure.get("smallest_J")
    if j is not None and j < FOLDED:
        return f"n = {failure['level']}, by t = {failure['t']:.3g} s"
    return "no (Newton fails)"


def sweep_lines(summaries: dict, failures: dict | None = None) -> list[str]:
    """truth.md's section on the sweep ([] when none of its cases is computed or failed);
    failures: {case: store.load_failure's record} of the cases whose computation failed."""
    failures = failures or {}
    if not any(case in summaries or case in failures for case in sweep_cases()):
        return []
    lines = [
        "## rod-nhb-sL: the large rod below the fold (SPEC 10)",
        "",
        f"The large rod {SOURCE} creases (below), so its truth is taken at the largest load "
        f"scale L of {', '.join(f'{s:g}' for s in ROD_SWEEP)} whose hierarchy meets the target: "
        "neo-hookean-barrier, MP3, levels n = 2, 4, 8 graded toward the clamped face's edges (as "
        f"rod-MP2's), the finest with h and h/2. A level folds where its smallest J = det F "
        f"falls below {FOLDED:g}.",
        "",
        "| s | case | levels | smallest J on each level (n = 2, 4, 8) | folded | E_i max "
        "between levels (m^3) | own E_i max (m^3) | target (m^3) | meets |",
        "|---:|---|---|---|---|---|---:|---:|---|",
    ]
    for case in sweep_cases():
        s = CASES[case][3]
        summary = summaries.get(case)
        if summary is None and case in failures:
            f = failures[case]
            done = ", ".join(f"{j:.3g}" for j in f["levels_done_smallest_J"])
            lines.append(
                f"| {s:g} | {case} | {levels_of_case(case)} | {done}, then: {failure_words(f)} | "
                f"{failure_fold(f)} | | n/a | | no |"
            )
            continue
        if summary is None:
            lines.append(f"| {s:g} | {case} | {levels_of_case(case)} | not computed | | | | | |")
            continue
        h, own = summary["hierarchy"], summary["own_error"]
        smallest = ", ".join(f"{min(j):.3g}" for j in h["min_jacobian"])
        fold = folded(h)
        where = f"n = {fold[0]} at t = {fold[1]:.3g} s" if fold else "no"
        diffs = ", ".join(fmt(max(d)) for d in h["level_differences"])
        total = own["interior_error_max"]
        lines.append(
            f"| {s:g} | {case} | {levels_of_case(case)} | {smallest} | {where} | {diffs} | "
            f"{fmt(total) if math.isfinite(total) else 'n/a'} | {fmt(own['target'])} | "
            f"{'yes' if own['meets_target'] else 'no'} |"
        )
    case, instead = chosen(summaries), fallback(summaries)
    if case:
        said = (
            f"L = {case.removeprefix('rod-nhb-s')}: the truth rod-nhb-sL is **{case}** (its "
            "section below), graded on the leaderboard's large rod cases."
        )
    elif instead:
        said = (
            "No load scale of the sweep meets the target on graded levels: each folds on its "
            f"finest. On uniform levels, whose cells at the edges are those of the graded n = 4, "
            f"**{instead}** meets it (its section below): the leaderboard's large rod is graded "
            "against it, a truth that does not resolve the fold at the lower edges."
        )
    else:
        said = (
            "No load scale of the sweep computed so far meets the target (the table says where "
            "each failed or folded): the large rod has no truth, and the leaderboard grades "
            "nothing at large load against one."
        )
    lines += ["", said, ""]
    return lines


def record(summaries: dict, failures: dict | None = None) -> dict | None:
    """What results/README.md says of the fold (crease.json, written by `tissuebench truth`):
    the creased case's levels (smallest J, when and where), its figures, and the sweep's rows;
    None while the creased case is not computed."""
    summary = summaries.get(SOURCE)
    if summary is None or not summary.get("crease"):
        return None
    h = summary["hierarchy"]
    levels = [
        {"n": n, "smallest_J": float(min(j)), "t": at[0], "X": at[1:]}
        for n, j, at in zip(h["levels"], h["min_jacobian"], h["min_jacobian_at"], strict=True)
    ]
    sweep = []
    for case in sweep_cases():
        s = CASES[case][3]
        other = summaries.get(case)
        if other is None:
            failure = (failures or {}).get(case)
            sweep.append({"s": s, "case": case, "computed": False, "failed": failure})
            continue
        fold = folded(other["hierarchy"])
        sweep.append(
            {
                "s": s,
                "case": case,
                "computed": True,
                "folded": None if fold is None else {"n": fold[0], "t": fold[1]},
                "meets": bool(other["own_error"]["meets_target"]),
                "own_error": other["own_error"]["interior_error_max"],
                "target": other["own_error"]["target"],
            }
        )
    return {"case": SOURCE, "levels": levels, **summary["crease"], "sweep": sweep}


def readme_section(path: Path) -> list[str]:
    """results/README.md's section on the fold, from crease.json at path ([] without it)."""
    if not path.is_file():
        return []
    r = json.loads(path.read_text())
    js = ", ".join(
        f"n = {lv['n']}: {lv['smallest_J']:.3g} at t = {lv['t']:.3g} s, "
        f"X = ({', '.join(f'{x:.3f}' for x in lv['X'])}) m"
        for lv in r["levels"]
    )
    rows = []
    for row in r["sweep"]:
        head = f"s = {row['s']:g} ({levels_of_case(row['case'])} levels): "
        if not row["computed"]:
            failed = row.get("failed")
            rows.append(head + (failure_words(failed) if failed else "not computed"))
            continue
        fold = row["folded"]
        rows.append(
            head
            + (f"folds on n = {fold['n']} at t = {fold['t']:.3g} s" if fold else "no fold")
            + f", {'meets' if row['meets'] else 'does not meet'} the target"
        )
    taken = [row for row in r["sweep"] if row["computed"] and row["meets"]]
    if taken and levels_of_case(taken[0]["case"]) == "graded":
        graded = f"The leaderboard grades the large rod against {taken[0]['case']}."
    elif taken:
        graded = (
            f"No graded hierarchy meets the target, so the leaderboard grades the large rod "
            f"against {taken[0]['case']}, whose uniform levels see no fold: a simulator's error "
            "against it is its error against the smooth branch, and says nothing of the fold."
        )
    else:
        graded = "No load of the sweep has a truth yet, so no simulator is graded at large load."
    folder = path.parent.name
    return [
        "## The large rod creases (SPEC 10)",
        "",
        f"At three times its load the neo-Hookean rod ({r['case']}: MP3, the barrier law) has no "
        "converged truth: refined near the clamp, a few cells on the compressed lower edges fold. "
        f"Each level's smallest J = det F: {js}. The coarse levels level off; the finest falls "
        f"below {FOLDED:g} (t = {r['t']:.3g} s: {r['cells']} cells with a corner below "
        f"{FOLDED:g}, the least {r['least_corner_J']:.3g}). This is the surface creasing of "
        "neo-Hookean solids under compression, which starts where the surface is compressed "
        "most and whose tip is singular, so no grid resolves it; without self-contact the folded "
        "faces pass through each other.",
        "",
        f"![smallest J against time, each level]({folder}/{Path(r['J']).name})",
        "",
        f"![the folded cells on the finest level]({folder}/{Path(r['folded']).name})",
        "",
        "What it means for a fast simulator: its large-deformation result on a coarse mesh is "
        "smooth because the mesh cannot see the fold, not because the tissue does not fold. At "
        "this load a smooth answer is the static branch a coarse grid selects, and no "
        "simulator's error against the continuum can be stated. Below it, the sweep of SPEC 10 "
        f"(results/truth.md): {'; '.join(rows)}. {graded}",
        "",
    ]
