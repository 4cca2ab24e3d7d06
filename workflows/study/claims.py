"""SPEC section 7's claims on the paper's study (part 1 of results/README.md): each claim is
judged by a function that returns a Verdict (whether it holds, on which readings, and the
numbers it rests on), and written out afterwards by a render function, so that a verdict can
be checked without its sentence.

Where the time-mean and the maximum over steps 1..N disagree, both are given, and the verdict
says which one it rests on and why."""

from collections.abc import Callable
from pathlib import Path
from typing import Any, cast

import numpy as np

from tissuebench.metrics.series import InputError
from tissuebench.metrics.table import METRICS as TABLE
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.tables import read_curves, read_tips
from tissuebench.workflows.run.figures import static_label
from tissuebench.workflows.study.common import (
    ABOUT,
    FAR,
    METRICS,
    PAPER_CROSSING,
    READINGS,
    ROUGHLY,
    SETTLED,
    Verdict,
    excursions,
    first_steps,
    fmt,
    mean,
    peak_from,
    plain,
    settled,
    tip_crossings,
    value,
    verdict,
)

ORDER = ("explicit", "implicit-lumped", "explicit-lumped", "quasi-static")
READING_ORDER = ("mean", "max")


def ordered(e: float, il: float, el: float, qs: float) -> bool:
    """Claim 1 on one metric and reading: explicit < both lumped schemes < quasi-static."""
    return bool(e < min(il, el) and max(il, el) < qs)


def roughly(ratio: float) -> bool:
    """Claim 2's 'roughly': within a factor ROUGHLY."""
    return bool(1 / ROUGHLY <= ratio <= ROUGHLY)


# --- claim 1 -------------------------------------------------------------------------------


def judge_order(b1: CaseSummary, times: np.ndarray, curves: dict) -> Verdict:
    """Claim 1 on each metric and both readings: explicit < both lumped < quasi-static. Holds
    if it holds on the time-mean of every metric. `numbers`: per (metric, reading) the four
    values, and where the maxima over steps 1..N are out of order each run's peak step and the
    first step k from which the maxima over steps k..N are in order (`starts`) with them."""
    rows, checks, starts = {}, {}, {}
    for m in METRICS:
        for reading in READING_ORDER:
            values = {a: value(b1, a, m, reading) for a in ORDER}
            ok = ordered(*values.values())
            checks[m, reading] = ok
            row: dict[str, Any] = {"values": values}
            if not ok and reading == "max":
                row["peak_steps"] = {a: peak_from(curves[a][m], 1)[1] for a in ORDER}
                start = next(
                    (
                        k
                        for k in range(2, len(times))
                        if ordered(*(peak_from(curves[a][m], k)[0] for a in ORDER))
                    ),
                    None,
                )
                starts[m] = start
                if start is not None:
                    row["tail"] = {a: peak_from(curves[a][m], start)[0] for a in ORDER}
            rows[m, reading] = row
    ratios = {
        r: [
            value(b1, "quasi-static", m, r)
            / max(value(b1, "implicit-lumped", m, r), value(b1, "explicit-lumped", m, r))
            for m in METRICS
        ]
        for r in READING_ORDER
    }
    numbers = {
        "rows": rows,
        "starts": starts,
        "ratios": ratios,
        "times": times,
        "steps": b1.steps,
        "end_time": b1.end_time,
    }
    return Verdict(1, all(checks[m, "mean"] for m in METRICS), checks, numbers)


def render_order(v: Verdict) -> list[str]:
    """Claim 1's statement, one line per metric, and the verdict (markdown)."""
    n, ok = v.numbers, v.checks
    times, starts, ratios = n["times"], n["starts"], n["ratios"]
    rows = []
    for m in METRICS:
        parts = []
        for reading in READING_ORDER:
            row = n["rows"][m, reading]
            e, il, el, qs = row["values"].values()
            text = (
                f"{READINGS[reading]} explicit {e:.3g}, implicit-lumped {il:.3g}, "
                f"explicit-lumped {el:.3g}, quasi-static {qs:.3g} (quasi-static / worst lumped = "
                f"{qs / max(il, el):.3g}): {plain(ok[m, reading])}"
            )
            if "peak_steps" in row:
                steps = row["peak_steps"]
                where = ", ".join(
                    f"{a} step {steps[a]} (t = {times[steps[a]]:.3g} s)" for a in ORDER
                )
                text += f"; each run's maximum is at: {where}"
                start = starts[m]
                if start is not None:
                    tail = ", ".join(f"{a} {row['tail'][a]:.3g}" for a in ORDER)
                    text += (
                        f"; the maxima over steps {start}..{len(times) - 1} (from t = "
                        f"{times[start]:.3g} s) are in order: {tail}"
                    )
            parts.append(text)
        rows.append(f"   - {TABLE[m].symbol}: " + "; ".join(parts) + ".")
    by_mean = v.holds
    fail_max = [TABLE[m].symbol for m in METRICS if not ok[m, "max"]]
    hold_max = [TABLE[m].symbol for m in METRICS if ok[m, "max"]]
    if fail_max:
        early = [
            (TABLE[m].symbol, starts[m]) for m in METRICS if not ok[m, "max"] and starts.get(m)
        ]
        where = "; ".join(
            f"for {name} only {first_steps(k - 1)} (to t = {times[k - 1]:.3g} s) "
            f"{'breaks' if k == 2 else 'break'} it: the maxima over steps {k}..{n['steps']} "
            "are in order"
            for name, k in early
        )
        reading = (
            f"On the maximum it holds for {', '.join(hold_max) or 'no metric'} and does not hold "
            f"for {', '.join(fail_max)}"
            + (f"; {where}" if where else "")
            + ". The verdict rests on the "
            f"time-mean: the claim compares the runs over the whole {n['end_time']:.3g} s (the "
            "paper's Figures 5-7 are curves over time), which the time-mean summarises, while a "
            "maximum that comes from the start-up, when the needle has moved a few millimetres "
            "and E_n divides by the reference's smallest displacements, says how the schemes "
            "start, not how close they stay."
        )
    else:
        reading = (
            "On the maximum it holds for every metric too; the verdict stands on both readings."
        )
    return [
        "1. *Block, MP1: explicit (consistent mass) is the closest to the reference, then the "
        "lumped schemes; quasi-static is the worst by far.* Explicit < implicit-lumped, "
        "explicit-lumped < quasi-static, on each metric and on both summaries over steps "
        f"1..{n['steps']} (time-mean and maximum):",
        *rows,
        f"   - Verdict: the ordering {verdict(by_mean)} on the time-mean for "
        f"{'every metric' if by_mean else 'some metrics only'}. {reading} 'By far': quasi-static "
        f"/ worst lumped is {min(ratios['mean']):.3g} to {max(ratios['mean']):.3g} by time-mean "
        f"and {min(ratios['max']):.3g} to {max(ratios['max']):.3g} by maximum over the three "
        "metrics.",
    ]


# --- claim 2 -------------------------------------------------------------------------------


def judge_sum(b1: CaseSummary) -> Verdict:
    """Claim 2: explicit-lumped's E_n against explicit + implicit-lumped, as a ratio, on the
    time-mean (the verdict) and the maximum."""
    e, il, el = (mean(b1, a) for a in ("explicit", "implicit-lumped", "explicit-lumped"))
    em, ilm, elm = (
        value(b1, a, reading="max") for a in ("explicit", "implicit-lumped", "explicit-lumped")
    )
    ratio, ratio_max = el / (e + il), elm / (em + ilm)
    checks = {
        ("relative_error", "mean"): roughly(ratio),
        ("relative_error", "max"): roughly(ratio_max),
    }
    numbers = {"mean": (e, il, el), "max": (em, ilm, elm), "ratio": ratio, "ratio_max": ratio_max}
    return Verdict(2, checks["relative_error", "mean"], checks, numbers)


def render_sum(v: Verdict) -> list[str]:
    """Claim 2's sentence (markdown)."""
    n = v.numbers
    (e, il, el), (em, ilm, elm) = n["mean"], n["max"]
    return [
        "2. *The error of explicit-lumped is roughly the sum of the errors of explicit alone and "
        "of lumping alone.* Time-mean E_n: explicit-lumped "
        f"{el:.3g} against explicit + implicit-lumped = {e + il:.3g}, a ratio of {n['ratio']:.3g}; "
        f"taking 'roughly' as within a factor {ROUGHLY}, it {verdict(v.holds)}. On the maximum of "
        f"E_n the ratio is {elm:.3g} / ({em:.3g} + {ilm:.3g}) = {n['ratio_max']:.3g}: it "
        f"{plain(v.checks['relative_error', 'max'])} there either. Our explicit-lumped also drops "
        "the beta K damping (SPEC section 2: C = alpha M_L), an error that neither explicit nor "
        "implicit-lumped makes."
    ]


# --- claim 3 -------------------------------------------------------------------------------


def judge_settle(out: Path, b1: CaseSummary, curves: dict, long: CaseSummary | None) -> Verdict:
    """Claim 3: E_n at the reported end time, and on the same mesh run on until the motion
    has died out (block-MP1-40s), every scheme against quasi-static. Not judged (holds None)
    without the long run or its XDMF output (`numbers["unread"]` then says why)."""
    ref, last = b1.reference, b1.steps
    final = {k: c["relative_error"][last] for k, c in curves.items() if k != ref}
    first = {k: c["relative_error"][1] for k, c in curves.items() if k != ref}
    shrink = all(final[k] < first[k] for k in final)
    numbers: dict[str, Any] = {
        "reference": ref,
        "end_time": b1.end_time,
        "mesh_size": b1.mesh_size,
        "final": final,
        "long": bool(long),
    }
    checks = {"shrinks by the end time": shrink}
    if not long:
        return Verdict(3, None, checks, numbers)
    ten = int(round(b1.end_time / long.h))
    try:
        diffs = settled(out / "block-MP1-40s", long, [ten, long.steps])
    except (OSError, InputError) as err:  # the XDMF series are not committed: only a fresh run
        numbers["unread"] = str(err)
        return Verdict(3, None, checks, numbers)
    end = {k: d[long.steps] for k, d in diffs.items()}
    at_ten = {k: d[ten] for k, d in diffs.items()}
    worst = max(end.values())
    checks["settled"] = worst < SETTLED
    checks["shrinking"] = all(end[k] < at_ten[k] for k in end)
    numbers.update(
        long_mesh_size=long.mesh_size,
        long_end_time=long.end_time,
        time_ten=long.h * ten,
        at_ten=at_ten,
        end=end,
        worst=worst,
    )
    return Verdict(3, checks["settled"] and checks["shrinking"], checks, numbers)


def render_settle(v: Verdict) -> list[str]:
    """Claim 3's lines (markdown)."""
    n = v.numbers
    lines = [
        "3. *All schemes approach the same static solution as the motion dies out.*",
        f"   - At t = {n['end_time']:.3g} s (block-MP1, mesh size {n['mesh_size']}): E_n against "
        f"{n['reference']}: "
        + ", ".join(f"{k} {x:.2g}" for k, x in n["final"].items())
        + f"; each is below its value at step 1 ({plain(v.checks['shrinks by the end time'])}), "
        f"but at {n['end_time']:.3g} s the motion has not yet died out.",
    ]
    if not n["long"]:
        lines.append("   - Verdict: not judged: the long run (block-MP1-40s) is not in this study.")
        return lines
    if "unread" in n:
        lines.append(
            "   - Verdict: not judged: the 40 s runs' XDMF output could not be read "
            f"({n['unread']})."
        )
        return lines
    end, at_ten = n["end"], n["at_ten"]
    lines.append(
        f"   - The same runs on the same {n['long_mesh_size']} × {n['long_mesh_size']} mesh, run "
        f"on to t = {n['long_end_time']:.3g} s (block-MP1-40s): each scheme against the "
        "quasi-static solution, ||u - u_qs|| / ||u_qs|| over all nodal displacements, at t = "
        f"{n['time_ten']:.3g} s and t = {n['long_end_time']:.3g} s: "
        + ", ".join(f"{k} {at_ten[k]:.2g} -> {end[k]:.2g}" for k in end)
        + "."
    )
    lines.append(
        f"   - Verdict: {verdict(v.holds)}: at t = {n['long_end_time']:.3g} s every scheme agrees "
        f"with the quasi-static (static) solution within {n['worst']:.2g} (taking 'the same' as "
        f"within {SETTLED:g}), and each difference has shrunk since t = {n['time_ten']:.3g} s."
    )
    return lines


# --- claim 4 -------------------------------------------------------------------------------


def judge_diverge(b2: CaseSummary) -> Verdict:
    """Claim 4: on block-MP2 the explicit schemes diverge, implicit and quasi-static run.
    `numbers["runs"]`: {label: (status, divergence step, divergence time in s)}."""
    runs = b2.runs
    checks = {a: runs[a].status == "diverged" for a in ("explicit", "explicit-lumped")}
    checks |= {a: runs[a].status == "ok" for a in ("implicit", "quasi-static")}
    numbers = {"runs": {a: (r.status, r.diverged_step, r.diverged_time) for a, r in runs.items()}}
    return Verdict(4, all(checks.values()), checks, numbers)


def render_diverge(v: Verdict) -> list[str]:
    """Claim 4's sentence (markdown)."""
    detail = ", ".join(
        f"{a} {status}" + (f" at step {step} (t = {t:.3g} s)" if status == "diverged" else "")
        for a, (status, step, t) in v.numbers["runs"].items()
    )
    return [
        "4. *Block, MP2 at h = 1/30: the explicit schemes diverge; implicit and quasi-static "
        f"run.* {detail}: {verdict(v.holds)}."
    ]


# --- claim 5 -------------------------------------------------------------------------------


def judge_material(vs: CaseSummary, times: np.ndarray, curves: dict) -> Verdict:
    """Claim 5 on each metric and both readings: quasi-static MP2 against the smallest MP1
    error, 'far less' as FAR times less. Holds if it holds on the time-mean of every metric.
    `numbers`: per (metric, reading) the values and ratio, and where the maxima fail, the step
    of quasi-static MP2's maximum and the first step from which the maxima clear the margin
    (`starts`)."""
    mp1 = [k for k in vs.runs if k.endswith("-MP1")]
    qs = "quasi-static-MP2"
    rows, checks, starts = {}, {}, {}
    for m in METRICS:
        for reading in READING_ORDER:
            q = value(vs, qs, m, reading)
            smallest = min(mp1, key=lambda k: value(vs, k, m, reading))
            ratio = value(vs, smallest, m, reading) / q
            checks[m, reading] = ratio > FAR
            row: dict[str, Any] = {
                "quasi-static": q,
                "smallest": smallest,
                "value": value(vs, smallest, m, reading),
                "ratio": ratio,
            }
            if reading == "max" and ratio <= FAR:
                q_step = peak_from(curves[qs][m], 1)[1]
                start = next(
                    (
                        k
                        for k in range(2, len(times))
                        if min(peak_from(curves[a][m], k)[0] for a in mp1)
                        > FAR * peak_from(curves[qs][m], k)[0]
                    ),
                    None,
                )
                starts[m] = (q_step, start)
                if start is not None:
                    row["tail"] = (
                        peak_from(curves[qs][m], start)[0],
                        min(peak_from(curves[a][m], start)[0] for a in mp1),
                    )
            rows[m, reading] = row
    numbers: dict[str, Any] = {
        "rows": rows,
        "starts": starts,
        "mp1": mp1,
        "times": times,
        "steps": vs.steps,
    }
    if not all(checks[m, "max"] for m in METRICS):
        smallest = np.nanmin([curves[a]["relative_error"][1:] for a in mp1], axis=0)
        numbers["smallest_range"] = (smallest.min(), smallest.max())
    return Verdict(5, all(checks[m, "mean"] for m in METRICS), checks, numbers)


def render_material(v: Verdict) -> list[str]:
    """Claim 5's lines (markdown)."""
    n, ok = v.numbers, v.checks
    times, starts, mp1 = n["times"], n["starts"], n["mp1"]
    parts = []
    for m in METRICS:
        row_text = []
        for reading in READING_ORDER:
            row = n["rows"][m, reading]
            text = (
                f"{READINGS[reading]} quasi-static MP2 {row['quasi-static']:.3g}, smallest MP1 "
                f"{row['smallest']} {row['value']:.3g}: {row['ratio']:.3g} times larger, "
                f"{plain(ok[m, reading])}"
            )
            if reading == "max" and m in starts:
                q_step, start = starts[m]
                text += (
                    f"; quasi-static MP2's maximum is at step {q_step} (t = {times[q_step]:.3g} s)"
                )
                if start is not None:
                    q2, s2 = row["tail"]
                    text += (
                        f"; over steps {start}..{len(times) - 1} the maxima are {q2:.3g} and "
                        f"{s2:.3g}, {s2 / q2:.3g} times larger"
                    )
            row_text.append(text)
        parts.append(f"   - {TABLE[m].symbol}: " + "; ".join(row_text) + ".")
    by_mean = v.holds
    fail_max = [TABLE[m].symbol for m in METRICS if not ok[m, "max"]]
    if fail_max:
        hold = [TABLE[m].symbol for m in METRICS if ok[m, "max"]]
        low, high = n["smallest_range"]
        early = "; ".join(
            f"for {TABLE[m].symbol} quasi-static MP2's maximum is at step {q} (t = "
            f"{times[q]:.3g} s) and "
            + (
                f"from step {k} on the maxima are more than {FAR} times apart"
                if k
                else "no later start clears the margin"
            )
            for m, (q, k) in starts.items()
        )
        reading = (
            f"On the maximum it holds for {', '.join(hold) or 'no metric'} and does not hold for "
            f"{', '.join(fail_max)}: {early}. The verdict rests on the time-mean: the claim is "
            "that material data matter more than the solver over the run; the smallest MP1 E_n "
            f"stays between {low:.2g} and {high:.2g} at every step, while quasi-static MP2's "
            "largest E_n comes from the start, where quasi-static ignores the inertia of a "
            "needle that has just started moving."
        )
    else:
        reading = (
            "On the maximum it holds for every metric too; the verdict stands on both readings."
        )
    return [
        "5. *Quasi-static MP2 against implicit MP2 has far less error than any MP1 run against "
        f"the MP2 reference.* Taking 'far less' as {FAR} times less, on each metric and on both "
        f"summaries over steps 1..{n['steps']} (MP1 runs: {', '.join(mp1)}):",
        *parts,
        f"   - Verdict: the claim {verdict(by_mean)} on the time-mean for "
        f"{'every metric' if by_mean else 'some metrics only'}. {reading}",
    ]


# --- claim 6 -------------------------------------------------------------------------------


def judge_rod(out: Path, rod: CaseSummary, long: CaseSummary | None) -> Verdict:
    """Claim 6 on the reported 10 s run (first crossing, the quasi-static minimum) and on the
    30 s run (the oscillation). Holds if the tip overshoots, first crosses within ABOUT of the
    paper's 4.2 s, the quasi-static E_n is smallest within a step of that, and (30 s run) the
    tip oscillates about the static deflection."""
    tips = read_tips(out / "rod-MP3" / "tip.csv")
    level, cross = tip_crossings(tips, rod)
    t, y = tips[rod.reference]
    overshoot = (level - y.min()) / abs(level)
    times, curves = read_curves(out / "rod-MP3" / "metrics.csv")
    # the rod has its quasi-static run (tip_crossings read its tip above)
    qs = curves[cast(str, static_label(rod, rod.reference))]["relative_error"]
    interior = np.flatnonzero((qs[1:-1] < qs[:-2]) & (qs[1:-1] < qs[2:])) + 1
    minimum = int(interior[0]) if len(interior) else None
    tmin = times[minimum] if minimum is not None else None
    first = cross[0] if cross else None
    numbers: dict[str, Any] = {
        "level": level,
        "crossings": cross,
        "overshoot": overshoot,
        "lowest_time": t[np.argmin(y)],
        "end_time": rod.end_time,
        "minimum_step": minimum,
        "minimum_time": tmin,
        "minimum": qs[minimum] if minimum is not None else np.nan,
        "first": first,
    }
    oscillates = None
    if long:
        ltips = read_tips(out / "rod-MP3-30s" / "tip.csv")
        llevel, lcross = tip_crossings(ltips, long)
        lt, ly = ltips[long.reference]
        ext = excursions(lt, ly, llevel, lcross)
        pairs = list(zip(ext[:-1], ext[1:], strict=True))
        oscillates = len(lcross) >= 2 and all(a[1] * b[1] < 0 for a, b in pairs)
        numbers["long"] = {
            "end_time": long.end_time,
            "level": llevel,
            "crossings": lcross,
            "half_periods": np.diff(lcross),
            "excursions": ext,
            "decays": all(abs(b[1]) < abs(a[1]) for a, b in pairs),
        }
    checks = {
        "overshoots": bool(overshoot > 0),
        "near 4.2 s": first is not None and abs(first - PAPER_CROSSING) <= ABOUT * PAPER_CROSSING,
        "at the minimum": first is not None and tmin is not None and abs(tmin - first) <= rod.h,
        "oscillates": bool(oscillates),
    }
    return Verdict(6, all(checks.values()), checks, numbers)


def render_rod(v: Verdict) -> list[str]:
    """Claim 6's lines (markdown)."""
    n = v.numbers
    level, cross, overshoot, first = n["level"], n["crossings"], n["overshoot"], n["first"]
    tmin = n["minimum_time"]
    lines = [
        "6. *Rod, MP3: the rod overshoots its static shape and oscillates about it; it drops below "
        "the static shape at about t = 4.2 s, where the quasi-static error nears 0.* Tip u_y of "
        f"implicit against the static deflection {level:.4g} m (the quasi-static tip); crossing "
        "times are interpolated linearly between the two steps around each crossing."
    ]
    lines.append(
        f"   - Reported run (rod-MP3, {n['end_time']:.3g} s): the tip crosses the static "
        "deflection "
        f"at t = {', '.join(f'{c:#.3g}' for c in cross) or 'never'} s; it goes "
        f"{100 * overshoot:.3g} % beyond it (at t = {n['lowest_time']:.3g} s). The quasi-static "
        f"E_n has its first minimum at step {fmt_step(n['minimum_step'])} (t = {fmt(tmin)} s, "
        f"E_n = {n['minimum']:.2g})"
        + (
            f", {abs(tmin - first):.2g} s from the first crossing."
            if first is not None and tmin is not None
            else "."
        )
    )
    long = n.get("long")
    if long:
        llevel = long["level"]
        lines.append(
            f"   - Run on to {long['end_time']:.3g} s (rod-MP3-30s): crossings at t = "
            f"{', '.join(f'{c:#.3g}' for c in long['crossings'])} s (half-periods "
            f"{', '.join(f'{h:.3g}' for h in long['half_periods'])} s); between them the tip's "
            "farthest excursions beyond the static deflection are "
            + ", ".join(
                f"{100 * d / abs(llevel):+.3g} % (t = {tt:.3g} s)" for tt, d in long["excursions"]
            )
            + f" of |{llevel:.4g}| m (negative: below): alternately below and above"
            f"{', each smaller than the one before' if long['decays'] else ''}."
        )
    lines.append(
        f"   - Verdict: {verdict(v.holds)}: the tip overshoots by {100 * overshoot:.3g} %"
        + (
            f", oscillates about the static deflection ({len(long['crossings'])} crossings in "
            f"{long['end_time']:.3g} s)"
            if long
            else ", the oscillation is not judged (the 30 s run is not in this study)"
        )
        + (
            f", first drops below it at t = {first:.3g} s, {abs(first - PAPER_CROSSING):.2g} s "
            f"from the paper's {PAPER_CROSSING} s (taking 'about' as within {100 * ABOUT:g} %)"
            if first
            else ""
        )
        + (
            f", and the quasi-static E_n is smallest within one step of that ({tmin:.3g} s)."
            if v.checks["at the minimum"]
            else "."
        )
    )
    return lines


def fmt_step(step: int | None) -> str:
    """A step number, or n/a."""
    return "n/a" if step is None else str(step)


# --- all claims ----------------------------------------------------------------------------


def judge_claims(out: Path, s: dict[str, CaseSummary]) -> list[Verdict]:
    """The verdicts of the claims of SPEC section 7 that the study's cases `s` ({case:
    summary}) and their files in `out` let us judge, in the claims' order."""
    out = Path(out)
    result = []
    b1, b2, rod, vs = (s.get(k) for k in ("block-MP1", "block-MP2", "rod-MP3", "block-MP2-vs-MP1"))
    if b1:
        times, curves = read_curves(out / "block-MP1" / "metrics.csv")
        result += [judge_order(b1, times, curves), judge_sum(b1)]
        result.append(judge_settle(out, b1, curves, s.get("block-MP1-40s")))
    if b2:
        result.append(judge_diverge(b2))
    if vs:
        result.append(judge_material(vs, *read_curves(out / "block-MP2-vs-MP1" / "metrics.csv")))
    if rod:
        result.append(judge_rod(out, rod, s.get("rod-MP3-30s")))
    return result


RENDER: dict[int | str, Callable[[Verdict], list[str]]] = {
    1: render_order,
    2: render_sum,
    3: render_settle,
    4: render_diverge,
    5: render_material,
    6: render_rod,
}


def render_claims(verdicts: list[Verdict]) -> str:
    """The claims, each with our numbers and a plain verdict (markdown)."""
    return "\n".join(line for v in verdicts for line in RENDER[v.claim](v))


def claims(out: Path, s: dict[str, CaseSummary]) -> str:
    """Each claim of SPEC section 7 with our numbers and a plain verdict (markdown)."""
    return render_claims(judge_claims(out, s))
