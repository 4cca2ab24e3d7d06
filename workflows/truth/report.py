"""truth.md and truth.csv (`tissuebench truth`): per case its levels, dofs, wall time, observed
orders, own E_i max in space and time against SPEC 10's target, the tip and its band, the fold
where a truth creases (truth/crease.py) and SPEC 10's sweep below it (truth/sweep.py);
truth.csv the rod cases' tip at whole seconds on every level. Rank 0; the command
(commands/truth.py) computes and writes them."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import TYPE_CHECKING, cast

import numpy as np

from tissuebench.meshes import get_entry, in_contact
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth.cases import (
    CASES,
    CONTACT_BAND,
    CONTACT_BAND_SHARE,
    CONTACT_X_GRADING,
    GRADED,
    GRADING,
    STEP_DIVISOR,
)
from tissuebench.solvers.truth.estimate import estimate_error
from tissuebench.solvers.truth.fallbacks import FALLBACKS, fallbacks_of
from tissuebench.solvers.truth.store import (
    MEASURED_STEP_SECONDS,
    TARGET_FRACTION,
    cache_dir,
    expected_seconds,
    levels_of,
    load_failure,
)
from tissuebench.workflows.io.tables import write_table
from tissuebench.workflows.io.text import fmt
from tissuebench.workflows.truth.crease import FOLDED
from tissuebench.workflows.truth.sweep import failure_words, sweep_cases, sweep_lines

if TYPE_CHECKING:
    from tissuebench.solvers.truth.samples import TruthSamples

NAME = "truth"
MARKER = "# The truth (SPEC 10)"
QUICK_NOTE = " (quick check, not the truth)"
COLUMNS = ["case", "level", "dofs", "time", "u_x", "u_y", "u_z"]
TIP_TIMES = (1.0, 5.0, 10.0)  # s: the tip times shown in truth.md


CREASE = "crease"  # OUT/crease/: the figures of a truth that folds (truth/crease.py)


# --- summaries (rank 0) ---------------------------------------------------------------------------


def floor_words(rtol: float, taken: list) -> str:
    """The steps a truth took at its residual's round-off floor ([level, t in s, ratio])."""
    head = (
        f"Its Newton may take a step whose residual fell by {rtol:g} where it stops short of "
        "1e-10 at the residual's round-off floor (solvers/truth/floor.py): "
    )
    if not taken:
        return head + "it took none."
    worst = max(ratio for _, _, ratio in taken)
    where = ", ".join(f"n = {level} at t = {t:.4g} s" for level, t, _ in taken[:6])
    more = f" and {len(taken) - 6} more" if len(taken) > 6 else ""
    return head + f"it took {len(taken)} ({where}{more}), the largest ratio {worst:.2g}."


def summary(samples: TruthSamples) -> dict:
    """What the report needs of a TruthSamples (its arrays left behind)."""
    return {
        "inputs": samples.inputs,
        "hierarchy": samples.hierarchy,
        "own_error": samples.own_error,
        "vertices": len(samples.vertices),
        "cells": len(samples.cells),
        "points": len(samples.points),
    }


def tip_band(h: dict, i: int, component: int = 1) -> tuple[float, float]:
    """(the finest level's tip component at step i, its estimated error): from the last two
    level differences (observed order) and h against h/2 (estimate.estimate_error), m."""
    tips = [np.asarray(t) for t in h["tip"]]
    values = [t[i, component] for t in tips]
    half = np.asarray(h["half_tip"])[2 * i, component] if "half_tip" in h else None
    diffs = [values[k + 1] - values[k] for k in range(len(values) - 1)]
    est = estimate_error(diffs, None if half is None else values[-1] - half)
    return values[-1], cast(float, est.total)  # a float for float differences


def static_band(h: dict, component: int = 1) -> tuple[float, float]:
    values = [s[component] for s in h["static_tip"]]
    diffs = [values[k + 1] - values[k] for k in range(len(values) - 1)]
    return values[-1], cast(float, estimate_error(diffs).total)  # a float for floats


def jacobian_cell(h: dict, k: int) -> str:
    """Level k's smallest J over the quadrature points and steps, with when and where."""
    t, *x = h["min_jacobian_at"][k]
    where = ", ".join(f"{c:.3f}" for c in x)
    return f"{min(h['min_jacobian'][k]):.3g} (t = {t:.3g} s, X = ({where}) m)"


def jacobian_lines(case: str, h: dict, diffs: list) -> list[str]:
    """What the smallest J says: an inverted state (SPEC 8), or material crushed more on each
    finer level where the levels do not converge."""
    smallest = [min(j) for j in h["min_jacobian"]]
    if min(smallest) <= 0:
        return [
            f"Some J <= 0 (smallest {fmt(min(smallest))}): an inverted element, which SPEC 8 "
            "counts as diverged; this truth is not one.",
            "",
        ]
    falls = all(b < a for a, b in zip(smallest, smallest[1:]))  # noqa: B905
    grows = len(diffs) > 1 and diffs[-1] >= diffs[-2]
    if not (falls and grows):
        return []
    mat = get_material(CASES[case][1])
    kappa = mat.lmbda + 2 * mat.mu / 3
    t, *x = h["min_jacobian_at"][-1]
    where = ", ".join(f"{c:.3f}" for c in x)
    falling = (
        "The smallest J = det F falls with every refinement ("
        + ", ".join(f"{j:.3g}" for j in smallest)
        + f"; on the finest at X = ({where}) m, t = {t:.3g} s) while the levels move apart"
    )
    if CASES[case][2] == "neo-hookean-barrier":
        return [
            falling + ". The barrier law's volumetric stress (kappa/2)(J - 1/J) grows without "
            "bound as J -> 0 (SPEC 8), so no finite load crushes the material to nothing: "
            "these levels have not converged where J is smallest.",
            "",
        ]
    return [
        falling + ": "
        "the material there is crushed further on each finer mesh. The neo-Hookean volumetric "
        f"stress kappa (J - 1) of SPEC 8 cannot exceed kappa = {kappa:.4g} Pa in compression "
        "(it tends to -kappa as J -> 0): beyond that only the shear part of the law resists "
        "crushing, and each finer mesh lets the crushed zone shrink and deepen. Uniform "
        "refinement does not converge here.",
        "",
    ]


def crease_lines(crease: dict) -> list[str]:
    """The fold's figures and what they show (truth/crease.py)."""
    least = crease["least_corner_J"]
    inverted = (
        ": an inverted corner of the trilinear interpolant, where the Q2 field's quadrature "
        "points still have J > 0"
        if least <= 0
        else ""
    )
    return [
        f"The crease (SPEC 10): the smallest J of each level against time, and the finest "
        f"grid at t = {crease['t']:.3g} s with its cells coloured by their smallest corner J "
        f"(from the displacement at the grid's vertices, trilinear): {crease['cells']} cells "
        f"below {FOLDED:g}, the least {least:.3g}{inverted}.",
        "",
        f"![smallest J against time]({crease['J']})",
        "",
        f"![the folded cells]({crease['folded']})",
        "",
    ]


def quick_levels() -> str:
    """The quick levels of each benchmark with truth cases, in words: "rod n = 1, 2, 4, ..."."""

    words = []
    for benchmark in dict.fromkeys(c[0] for c in CASES.values()):
        entry = get_entry(benchmark)
        sizes = ", ".join(map(str, entry.quick_truth_levels))
        words.append(f"{benchmark} {entry.size_name} = {sizes}")
    return ", ".join(words)


def grid(case: str) -> str:
    """The levels' grids in words."""
    if case not in GRADED:
        return "uniform grids"
    if in_contact(CASES[case][0]):  # SPEC 12: the needle as contact
        (low, high), share = CONTACT_BAND, CONTACT_BAND_SHARE
        return (
            f"grids graded toward the right edge (power {CONTACT_X_GRADING:g}) and with "
            f"{100 * share:.0f} % of the rows in the band {low:g} <= y <= {high:g} m that the "
            "needle sweeps (the levels nest)"
        )
    toward = "the needle's ends" if CASES[case][4] is not None else "the clamped face's edges"
    return (
        f"grids graded toward {toward} (power {GRADING:g}; the levels nest, as uniform "
        "refinement does)"
    )


def penalty_words(h: dict, own: dict, units: str) -> str:
    """SPEC 12's limit of a contact truth's penalty in words: the finest level again with
    10 k against it, or why that run did not end."""
    if "penalty_failed" in h:
        return (
            "Contact: the finest level again with 10 times the penalty did not run through "
            f"({h['penalty_failed']}), so the penalty's limit (SPEC 12) is unchecked here."
        )
    diff = max(h["penalty_difference"])
    holds = "under" if diff < own["interior_error_max"] / 10 else "not under"
    if "penalty_step" in h:  # at the half step, against the finest level's own half step
        counted = (
            ""
            if diff < own["interior_error_max"] / 10
            else f" It is counted in the own error instead, as its third part beside space and "
            f"time: {fmt(own['penalty'])} {units}, the difference over 0.9 (the error of k "
            "if it falls as 1/k)."
        )
        return (
            f"Contact: the finest level at the half step ({fmt(h['penalty_step'])} s) with 10 "
            f"times the penalty differs from it with the truth's penalty by E_i max {fmt(diff)} "
            f"{units}, {holds} a tenth of its own error (SPEC 12's limit of the penalty; at the "
            f"step h itself Newton cycles between active sets with 10 times the penalty).{counted}"
        )
    return (
        f"Contact: the finest level again with 10 times the penalty differs from it by E_i max "
        f"{fmt(diff)} {units}, {holds} a tenth of its own error (SPEC 12's limit of the penalty)."
    )


def step_words(k: int) -> str:
    """The truth's own step in words, where it is not the benchmark's h."""
    if k == 1:
        return ""
    return f"; the truth steps h/{k} and is sampled at the steps of h"


def time_words(h: dict, div: int) -> str:
    """Where the time order q comes from, in words."""
    if "time_order_differences" not in h:
        return "not observed"
    d1, d2 = h["time_order_differences"]
    step = "h" if div == 1 else f"h/{div}"
    return (
        f"on level {h['levels'][0]}: E_i max {fmt(d1)} between {step} and its half, {fmt(d2)} "
        "between the half and the quarter"
    )


def case_line(case: str) -> str:
    benchmark, material, model, scale, width = CASES[case]
    needle = f", needle width w = {width} m" if width is not None else ""
    line = f"{benchmark}, {material}, {model}, load scale s = {scale}{needle}"
    if case in FALLBACKS:  # SPEC 10/12: taken where its own case does not converge
        source = FALLBACKS[case][0]
        spec = (
            "SPEC 12"
            if in_contact(CASES[source][0])
            else f"SPEC 10, {'graded toward the clamp' if case in GRADED else 'uniform levels'}"
        )
        line += f"; the fallback of {source}, whose levels do not converge ({spec})"
    return line


def fallback_words(case: str, computed: bool = True) -> list[str]:
    """The cases taken in place of a case that does not converge (solvers/truth/fallbacks.py,
    which records the evidence), in a line, or none; `computed`: whether this report shows that
    evidence itself."""
    taken = [f"{c} (s = {scale:g})" for c, scale in fallbacks_of(case)]
    if not taken:
        return []
    said = "" if computed else "When last computed its levels did not converge (fallbacks.py): "
    return [
        f"{said}SPEC {12 if in_contact(CASES[case][0]) else 10} takes it at a smaller load "
        f"instead, {', '.join(taken)}, below.",
        "",
    ]


def sweep_failures(summaries: dict) -> dict:
    """The failure records (store.load_failure) of SPEC 10's sweep cases not computed."""
    cases = sweep_cases()
    found = {case: load_failure(case) for case in cases if case not in summaries}
    return {case: record for case, record in found.items() if record is not None}


def section(case: str, s: dict | None, quick: bool) -> list[str]:
    lines = [f"## {case}", "", case_line(case) + ".", ""]
    if s is None:
        if quick:
            return lines + ["Not computed in this quick check.", ""]
        sizes = levels_of(case)
        per = MEASURED_STEP_SECONDS.get(case)
        measured = ""
        if per:
            measured = (
                " Measured time per step of h (one rank, this machine): "
                + ", ".join(f"{fmt(t, 2)} s at {sizes[k]}" for k, t in enumerate(per) if t)
                + " (the first steps, on a machine shared with other jobs: an upper bound)."
            )
        minutes = expected_seconds(case, now=False) / 60  # as measured: the file stays put
        divisor = STEP_DIVISOR.get(case, 1)
        failure = load_failure(case)
        if failure is not None:  # the evidence of a computation that failed (store.py)
            return lines + [
                f"Its computation failed ({failure['when']}): {failure_words(failure)}; the "
                f"levels before it: n = {', '.join(map(str, failure['levels_done']))}, smallest "
                f"J {', '.join(f'{j:.3g}' for j in failure['levels_done_smallest_J'])}. "
                f"`tissuebench truth {case}` tries again (`all` does not).",
                "",
            ]
        return lines + [
            f"Not yet computed: `tissuebench truth {case}` takes about {minutes:.0f} min on "
            f"one quiet core of a machine like this one (levels "
            f"{', '.join(map(str, sizes))}, {300 * divisor} steps each "
            f"and {600 * divisor} at half the step on the finest).{measured}",
            "",
            *fallback_words(case, computed=False),
        ]
    inp, h, own = s["inputs"], s["hierarchy"], s["own_error"]
    levels = h["levels"]
    units = own["units"]
    probe = "tip" in h
    steps, dt = h["steps"], h["h"]
    div = inp.get("step_divisor", 1)
    half = f"h/{2 * div}"
    shown = [t for t in TIP_TIMES if round(t / dt) <= steps]
    head = "| level | dofs | wall (s) | E_i max to the next level (" + units + ") |"
    rule = "|---|---:|---:|---:|"
    jac = "min_jacobian" in h
    if jac:
        head += " smallest J (at t, X) |"
        rule += "---|"
    if probe:
        head += " static tip u_y (m) |" + "".join(f" tip u_y at {t:g} s (m) |" for t in shown)
        rule += "---:|" * (1 + len(shown))
    lines += [
        f"Element: {inp['element']}; {inp['time']}; {grid(case)}; "
        f"h = {dt:.6g} s, {steps} steps (T = {inp['end_time']:.6g} s){step_words(div)}. "
        "Sampled for grading on the finest level: "
        f"{s['vertices']:,} vertices, {s['cells']:,} cells, {s['points']:,} quadrature points.",
        "",
        head,
        rule,
    ]
    diffs = [max(d) for d in h["level_differences"]]
    for k, n in enumerate(levels):
        label = f"{n}" + (" (truth)" if k == len(levels) - 1 else "")
        row = f"| {label} | {h['dofs'][k]:,} | {h['wall'][k]:.1f} | "
        row += (fmt(diffs[k]) if k < len(diffs) else "") + " |"
        if jac:
            row += f" {jacobian_cell(h, k)} |"
        if probe:
            static = h["static_tip"][k][1]
            row += f" {static:.6g} |" if math.isfinite(static) else " not solved |"
            row += "".join(f" {np.asarray(h['tip'][k])[round(t / dt), 1]:.6g} |" for t in shown)
        lines.append(row)
    half_row = (
        f"| {levels[-1]}, {half} | {h['dofs'][-1]:,} | {h['half_wall']:.1f} | "
        f"{fmt(max(h['time_difference']))} ({'h' if div == 1 else f'h/{div}'} against {half}) |"
    )
    if jac:
        half_row += f" {fmt(min(h['half_min_jacobian']))} |" if "half_min_jacobian" in h else " |"
    if probe:
        half_row += " |" + "".join(
            f" {np.asarray(h['half_tip'])[2 * round(t / dt), 1]:.6g} |" for t in shown
        )
    lines += [half_row, ""]
    meets = "meets" if own["meets_target"] else "does not meet"
    lines += [
        f"Observed order p = {fmt(own['order'])} in space and q = "
        f"{fmt(h.get('time_order'))} in time ({time_words(h, div)}); "
        f"own E_i max: space {fmt(own['space'])}, "
        f"time {fmt(own['time'])}, "
        + (f"penalty {fmt(own['penalty'])}, " if "penalty" in own else "")
        + f"total **{fmt(own['interior_error_max'])} {units}**: "
        f"{meets} SPEC 10's target {fmt(own['target'])} {units} ({100 * TARGET_FRACTION:g} % "
        f"of its E_i against rest, {fmt(own['size'])}). Wall time in all "
        f"{h.get('total_wall', float('nan')):.0f} s.",
        "",
    ]
    if "penalty_difference" in h or "penalty_failed" in h:  # SPEC 12: the penalty's limit
        lines += [penalty_words(h, own, units), ""]
    if "newton_floor" in s["inputs"]:  # solvers/truth/floor.py
        lines += [floor_words(s["inputs"]["newton_floor"]["rtol"], h.get("newton_floor", [])), ""]
    space, step = own["space"], own["time"]
    if not math.isfinite(space) and len(diffs) > 1 and diffs[-1] >= diffs[-2]:
        lines += [
            "The E_i max between levels grows with refinement ("
            + ", then ".join(fmt(d) for d in diffs)
            + f" {units}): these levels do not converge, no order or own error can be stated, "
            "and this truth is not one yet (the leaderboard grades nothing against it).",
            "",
        ]
        lines += fallback_words(case)
    if jac:
        lines += jacobian_lines(case, h, diffs)
    if s.get("crease"):
        lines += crease_lines(s["crease"])
    if not own["meets_target"] and all(math.isfinite(x) for x in (space, step)):
        larger = "space (the levels)" if space >= step else f"time (the step against {half})"
        lines += [
            f"The larger part of the own error is in {larger}: {fmt(max(space, step))} "
            f"{units}, {max(space, step) / own['target']:.2g} x the target alone.",
            "",
        ]
    if probe:
        v, band = static_band(h)
        tips = [f"static {v:.6g} ± {fmt(band, 2)}" if math.isfinite(v) else "static: not solved"]
        for t in shown:
            v, band = tip_band(h, round(t / dt))
            tips.append(f"t = {t:g} s {v:.6g} ± {fmt(band, 2)}")
        lines += [f"Tip u_y (m) of the truth with its band: {'; '.join(tips)}.", ""]
    return lines


def computed_words(summaries: dict) -> list[str]:
    """When the cached cases were computed, from their files: each began its own wall time
    (`total_wall`) before its file was written. Where every case is there, the span from the
    first start to the last write is what `truth all` took to compute them all (with --jobs,
    N at a time), the time to write each file aside."""
    spans = [
        (s["cached_at"] - s["hierarchy"]["total_wall"], s["cached_at"])
        for s in summaries.values()
        if s.get("cached_at") and s["hierarchy"].get("total_wall")
    ]
    if len(spans) < len(CASES):
        return []
    start, end = min(a for a, _ in spans), max(b for _, b in spans)
    if end - start > 2 * sum(b - a for a, b in spans):  # computed at different times
        return []
    clock = lambda t: time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t))  # noqa: E731
    return [
        f"Every case of this cache was computed between {clock(start)} and {clock(end)}: "
        f"{end - start:.0f} s of wall time in all (their own wall times add up to "
        f"{sum(b - a for a, b in spans):.0f} s; a shorter span means cases ran side by side, "
        "each on one core: `truth all --jobs`).",
        "",
    ]


def markdown(summaries: dict, quick: bool, names: list[str], ranks: int, session: str) -> str:
    command = f"tissuebench truth {' '.join(names)}" + (" --quick" if quick else "")
    lines = [
        MARKER + (QUICK_NOTE if quick else ""),
        "",
        f"Written by `{command}` ({session}, {ranks} rank{'s' if ranks > 1 else ''}).",
        "",
        "The converged reference of each SPEC 10 case: Q2 displacement (Taylor-Hood Q2-Q1 "
        "for nu >= 0.45 and neo-Hookean), the trapezoidal rule with consistent mass, "
        "continuum Rayleigh damping, the needle on its segment; three refined levels (rod "
        "n = 2, 4, 8, uniform; block N = 20, 40, 80, the linear ones graded toward the "
        "needle's ends, where the displacement is singular, and nested) and, on the finest, "
        "the truth's step and "
        "its half (the step is h = 1/30 s, the linear blocks' h/4). Its own error is E_i "
        "(SPEC 6) estimated from them: space, the last two levels' E_i max difference "
        "d2 / (2^p - 1) with the observed order p = log2(d1 / d2); time, E_i max(step, "
        "step/2) 2^q / (2^q - 1) with the order q observed on the coarsest level from its "
        "step, half and quarter (at most the rule's 2; the needle's stop at t = 2 s, a kink "
        "in its motion, makes the blocks first order). Target (SPEC 10): own E_i max <= "
        f"{100 * TARGET_FRACTION:g} % of the truth's size, its own E_i against rest (u' = 0, "
        "the maximum over steps), so the target grows with the load and shrinks with a "
        "stiffer material. The point-needle block (w = 0) has no truth.",
        "",
        f"Cached outside git in `{cache_dir()}` (or $TISSUEBENCH_CACHE/truth), keyed by "
        "the fingerprint of every input (case, material, levels, h, steps, element, "
        "software versions, the truth's sources). A run is graded against it by "
        "`tissuebench compare truth:CASE CANDIDATE --out DIR` (the paper reference's own "
        "error against the truth included) and in the leaderboard.",
        "",
        "| case | finest level | dofs | wall (s) | order p (space) | q (time) | own E_i max: "
        "space | time | total (a contact truth's with its penalty part) | size (E_i against "
        "rest) | target | meets |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    lines[-2:-2] = computed_words(summaries)
    for case in CASES:
        s = summaries.get(case)
        if s is None:
            state = "not in this quick check" if quick else "not yet computed"
            lines.append(f"| {case} | {state} | | | | | | | | | | |")
            continue
        h, own = s["hierarchy"], s["own_error"]
        lines.append(
            f"| {case} | {h['levels'][-1]} | {h['dofs'][-1]:,} | "
            f"{h.get('total_wall', float('nan')):.0f} | {fmt(own['order'])} | "
            f"{fmt(h.get('time_order'))} | {fmt(own['space'])} | {fmt(own['time'])} | "
            f"{fmt(own['interior_error_max'])} "
            f"{own['units']} | {fmt(own['size'])} | {fmt(own['target'])} | "
            f"{'yes' if own['meets_target'] else 'no'} |"
        )
    lines.append("")
    lines += sweep_lines(summaries, sweep_failures(summaries))
    for case in CASES:
        lines += section(case, summaries.get(case), quick)
    return "\n".join(lines)


def reported(text: str) -> list[str]:
    """The cases a truth.md (markdown()'s text) reports as computed: those whose row in its
    table gives a finest level."""
    cells = (line.split("|") for line in text.splitlines() if line.startswith("| "))
    return [
        c[1].strip()
        for c in cells
        if len(c) > 2 and c[1].strip() in CASES and c[2].strip()[:1].isdigit()
    ]


def csv_rows(summaries: dict) -> list[list]:
    """case,level,dofs,time,u_x,u_y,u_z: the tip at whole seconds on every level of the cases
    with a probe, the finest labelled `truth`."""
    rows = []
    for case in CASES:
        s = summaries.get(case)
        if s is None or "tip" not in s["hierarchy"]:
            continue
        h = s["hierarchy"]
        dt, steps = h["h"], h["steps"]
        for k, n in enumerate(h["levels"]):
            label = "truth" if k == len(h["levels"]) - 1 else str(n)
            tip = np.asarray(h["tip"][k])
            for t in range(1, int(math.floor(steps * dt + 1e-9)) + 1):
                u = tip[round(t / dt)]
                rows.append([case, label, h["dofs"][k], t, *(f"{x:.10g}" for x in u)])
    return rows


def write_csv(path: Path, rows: list[list]) -> None:
    """truth.csv: COLUMNS, then the rows (io/tables.py)."""
    write_table(path, COLUMNS, rows)
