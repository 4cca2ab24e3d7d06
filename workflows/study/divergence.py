"""Part 2 of results/README.md (SPEC section 8): which combinations of algorithm and elastic
model diverge, the reasons their summaries give, and what the data say about why (the
explicit schemes' linear critical step, the growth of the error, the smallest J = det F)."""

import re
from pathlib import Path
from typing import cast

import numpy as np

from tissuebench.workflows.io.summary import CaseSummary, RunSummary
from tissuebench.workflows.io.tables import read_curves
from tissuebench.workflows.study.common import (
    LARGE_DEFORMATION,
    LOSS_READING,
    Verdict,
    cases_text,
    loss,
    loss_runs,
    place,
)


def growth(curve: np.ndarray, steps: int = 10) -> tuple[float, int | None, int | None]:
    """(factor, first, last): how much a curve grew over its last `steps` finite values."""
    finite = np.flatnonzero(np.isfinite(curve))
    if len(finite) <= steps:
        return np.nan, None, None
    last = finite[-1]
    return float(curve[last] / curve[last - steps]), last - steps, last


def diverged_runs(large: dict[str, CaseSummary]) -> list[tuple[str, str, RunSummary]]:
    """[(case, label, run)] of every run of the large-deformation cases that diverged, by case
    and time."""
    result = []
    for name, s in large.items():
        runs = [(label, r) for label, r in s.runs.items() if r.status == "diverged"]
        result += [
            (name, label, r)
            for label, r in sorted(runs, key=lambda x: cast(float, x[1].diverged_time))
        ]
    return result


def j_text(s: CaseSummary, d: dict | None, label: str) -> str:
    """A run's smallest J at its last kept step, and where, from deformation.json."""
    j = d["smallest_J"].get(label) if d else None
    if not j:
        return "n/a"
    if j["last_step"] == 0:
        return "none kept after step 0"
    return (
        f"{j['J_last_step']:.3g} at t = {j['last_step'] * s.h:.3g} s, in the cell at "
        f"{place(s, j['cell_centre_last_step'])}"
    )


def divergences(
    out: Path, large: dict[str, CaseSummary], deformation: dict, limits: dict
) -> list[str]:
    """Which runs diverged, the reasons summary.json gives, and what the data say about why."""
    runs = diverged_runs(large)
    lines = ["### Which combinations diverge, and why", ""]
    if not runs:
        return lines + ["No run diverged.", ""]
    lines += [
        "Every run that diverged, with the reason its summary.json gives and the smallest J = det "
        "F "
        "(at the Gauss points, where the solver checks it) at the last step it kept, from the "
        "case's "
        "deformation.json:",
        "",
        "| case | run | diverged at | reason | smallest J at the last kept step |",
        "|---|---|---|---|---|",
    ]
    for name, label, r in runs:
        s = large[name]
        lines.append(
            f"| {name} | {label} | t = {r.diverged_time:.3g} s | {r.reason or 'n/a'} | "
            f"{j_text(s, deformation.get(name), label)} |"
        )
    lines.append("")
    models: dict[str, list[tuple[str, str, RunSummary]]] = {}
    for name, label, r in runs:
        models.setdefault(r.model, []).append((name, label, r))
    for model, items in models.items():
        if model == "svk":
            lines.append(why_svk(large, items, deformation))
        elif model == "neo-hookean":
            lines.append(why_explicit(out, large, items, deformation, limits))
        elif model == "corotational":
            lines.append(why_corotational(large, items, deformation))
        else:
            lines.append(
                f"- {model}: " + ", ".join(f"{label} on {name}" for name, label, _ in items) + "."
            )
    lines.append(linear_never(large, deformation))
    lines.append("")
    return lines


def count_text(large: dict[str, CaseSummary], model: str, items: list) -> str:
    per_case = []
    for name, s in large.items():
        total = [label for label, r in s.runs.items() if r.model == model]
        failed = [label for n, label, _ in items if n == name]
        if total:
            per_case.append(f"{len(failed)} of {len(total)} on {name}")
    return ", ".join(per_case)


def why_svk(large: dict[str, CaseSummary], items: list, deformation: dict) -> str:
    text = f"- **svk** diverged {count_text(large, 'svk', items)}."
    for name in dict.fromkeys(n for n, _, _ in items):
        s = large[name]
        case_items = [(label, r) for n, label, r in items if n == name]
        newton = [(label, r) for label, r in case_items if "Newton" in (r.reason or "")]
        inverted = [(label, r) for label, r in case_items if "inverted" in (r.reason or "")]
        text += f" On {name}"
        if newton:
            label, r = newton[0]
            text += (
                f" `{label}` found no static solution at t = {r.diverged_time:.3g} s "
                "(Newton failed)"
            )
            if inverted:
                later = sum(r.diverged_time < q.diverged_time for _, q in inverted)
                text += (
                    ", before any dynamic svk run stopped"
                    if later == len(inverted)
                    else f", before {later} of the {len(inverted)} dynamic svk runs stopped"
                )
        if inverted:
            t = [q.diverged_time for _, q in inverted]
            d = deformation.get(name)
            js = [d["smallest_J"][lab] for lab, _ in inverted if d and lab in d["smallest_J"]]
            where = {place(s, j["cell_centre_last_step"]) for j in js}
            text += ("; " if newton else " ") + (
                f"{len(inverted)} dynamic svk runs inverted a cell at t = {min(t):.3g} to "
                f"{max(t):.3g} s"
                if len(inverted) > 1
                else f"`{inverted[0][0]}` inverted a cell at t = {t[0]:.3g} s"
            )
            if js:
                text += (
                    ", after a last kept step with J down to "
                    f"{min(j['J_last_step'] for j in js):.2g}–"
                    f"{max(j['J_last_step'] for j in js):.2g} in the cell at "
                    f"{' or '.join(sorted(where))}"
                )
        text += "."
    ran = [
        n
        for n, s in large.items()
        if all(r.status == "ok" for r in s.runs.values() if r.model == "svk")
    ]
    if ran:
        text += f" Every svk run ran on {', '.join(ran)}."
    text += (
        " St Venant-Kirchhoff softens in compression: in 1D with ν = 0 its stress P = E λ(λ² − "
        "1)/2 peaks at "
        "the stretch λ = 1/√3 and falls back to 0 as λ → 0, so a cell compressed past the peak has "
        "no stiffness "
        "left against collapse, and beyond the largest load the material can carry there is no "
        "static "
        "solution. Newton failures of quasi-static svk and collapsing cells with J → 0 where the "
        "body is "
        "compressed most are what that predicts."
    )
    return text


def why_explicit(
    out: Path, large: dict[str, CaseSummary], items: list, deformation: dict, limits: dict
) -> str:
    """The neo-Hookean runs that diverged (explicit ones, so far): the linear critical step of
    their scheme on the case's mesh against h, and how their error grew before they stopped."""
    model = "neo-hookean"
    by_algorithm: dict[str, dict[str, list[tuple[str, RunSummary]]]] = {}
    for name, s in large.items():
        for label, r in s.runs.items():
            if r.model == model and r.algorithm != "quasi-static":
                by_algorithm.setdefault(r.algorithm, {"diverged": [], "ok": []})
                key = "ok" if r.status == "ok" else "diverged"
                by_algorithm[r.algorithm][key].append((name, r))
    failed = {a: v for a, v in by_algorithm.items() if v["diverged"]}
    text = f"- **{model}**: " + "; ".join(
        f"`{a}+{model}` diverged on "
        + cases_text(f"{n} (t = {r.diverged_time:.3g} s)" for n, r in v["diverged"])
        + (f" and ran on {cases_text(n for n, _ in v['ok'])}" if v["ok"] else "")
        for a, v in failed.items()
    )
    ran = [a for a, v in by_algorithm.items() if not v["diverged"]]
    if ran:
        text += "; " + ", ".join(f"`{a}+{model}`" for a in ran) + " ran on every case"
    text += "."
    explicit = {
        name: {a: s.h / h for a, h in (limits.get(name) or {}).items() if np.isfinite(h)}
        for name, s in large.items()
    }
    explicit = {n: v for n, v in explicit.items() if v}
    if explicit:
        text += (
            " The linear critical step h_c of central differences on each case's mesh (SPEC "
            "section 3's "
            "analysis, as in stability.md) puts h at "
            + "; ".join(
                ", ".join(f"{r:.3g} h_c for {a}" for a, r in ratios.items()) + f" on {n}"
                for n, ratios in explicit.items()
            )
            + "."
        )
        margins = [
            f"{100 * (1 / explicit[n][r.algorithm] ** 2 - 1):.2g} % for {r.algorithm} on {n}"
            for n, label, r in items
            if r.algorithm in explicit.get(n, {})
        ]
        if margins:
            text += (
                " A tangent stiffer than the linear K₀ by (h_c/h)² − 1 anywhere puts the fastest "
                "mode beyond "
                "2/h: " + ", ".join(margins) + "."
            )
    grown = []
    for name, label, r in items:
        g = explicit_growth(out, name, label)
        if np.isfinite(g):
            collapse = [
                explicit_growth(out, name, other)
                for other, q in large[name].runs.items()
                if q.status == "diverged" and "inverted" in (q.reason or "") and q.model != model
            ]
            collapse = [c for c in collapse if np.isfinite(c)]
            grown.append(
                f"{g:.3g} times on {name}"
                + (
                    " (the runs of other models that inverted a cell there: at most "
                    f"{max(collapse):.2g} times)"
                    if collapse
                    else ""
                )
            )
    if grown:
        text += (
            " Over its last 10 kept steps the E_i of a diverged run grew " + "; ".join(grown) + "."
        )
    jumps = []
    for n, label, r in items:
        d = deformation.get(n)
        after = reason_j(r.reason)
        if d and label in d["smallest_J"] and after is not None:
            j = d["smallest_J"][label]
            jumps.append(
                f"from {j['J_last_step']:.3g} (in the cell at "
                f"{place(large[n], j['cell_centre_last_step'])}) to {after:.3g} on {n}"
            )
    if jumps:
        text += " In its last step the smallest J went " + "; ".join(jumps) + "."
    if judge_instability(out, large, items).holds:
        text += (
            " That is an instability of the step rather than a collapse of the material: the error "
            "grows "
            "geometrically before the run stops, and with the same model neither the reference "
            "(implicit, unconditionally stable) nor explicit-lumped, whose h_c is about twice as "
            "long, "
            "diverged. It is consistent with the tangent of the compressed neo-Hookean cells being "
            "stiffer than K₀, and with consistent mass, whose ω_max is the larger, leaving the "
            "smaller "
            "margin."
        )
    return text


INSTABILITY = "the explicit neo-Hookean runs diverged by an instability of the step"


def judge_instability(out: Path, large: dict[str, CaseSummary], items: list) -> Verdict:
    """Did the diverged runs `items` ([(case, label, run)]) stop by an instability of the
    step rather than a collapse of the material? It holds if, on their cases, the reference
    and explicit-lumped with the same model ran, and each run's E_i grew more than twice over
    its last 10 kept steps (geometric growth). `numbers["growth"]`: {(case, label): factor}."""
    cases = list(dict.fromkeys(n for n, _, _ in items))
    stable = all(
        getattr(large[n].runs.get(label), "status", None) == "ok"
        for n in cases
        for label in (large[n].reference, loss_runs(large[n])["lumped explicit stepping"])
    )
    grown = {(n, label): explicit_growth(out, n, label) for n, label, _ in items}
    checks = {
        "the reference and explicit-lumped ran": stable,
        "the error grew geometrically": all(g > 2 for g in grown.values()),
    }
    return Verdict(INSTABILITY, all(checks.values()), checks, {"growth": grown})


def reason_j(reason: str | None) -> float | None:
    """The J that an 'inverted element: J = ... <= 0' reason gives, or None."""
    found = re.search(r"J = (-?[0-9.eE+-]+) <= 0", reason or "")
    try:
        return float(found.group(1)) if found else None
    except ValueError:
        return None


def explicit_growth(out: Path, name: str, label: str) -> float:
    """The growth of a run's E_i over its last 10 kept steps, from metrics.csv (nan if unread)."""
    try:
        _, curves = read_curves(Path(out) / LARGE_DEFORMATION / name / "metrics.csv")
        return growth(curves[label][LOSS_READING])[0]
    except (OSError, KeyError):
        return np.nan


def why_corotational(large: dict[str, CaseSummary], items: list, deformation: dict) -> str:
    text = "- **corotational** diverged " + count_text(large, "corotational", items) + ":"
    for name in dict.fromkeys(n for n, _, _ in items):
        s = large[name]
        case_items = [(label, r) for n, label, r in items if n == name]
        t = [r.diverged_time for _, r in case_items]
        text += f" on {name} " + ", ".join(f"`{label}`" for label, _ in case_items)
        text += f" inverted a cell at t = {min(t):.3g} to {max(t):.3g} s"
        d = deformation.get(name)
        if d:
            where = {
                place(s, d["smallest_J"][label]["cell_centre_last_step"])
                for label, _ in case_items
                if label in d["smallest_J"]
            }
            text += f" (at {' or '.join(sorted(where))})"
        ok = [
            label for label, r in s.runs.items() if r.model == "corotational" and r.status == "ok"
        ]
        if ok:
            text += "; " + ", ".join(f"`{label}`" for label in ok) + " ran"
            if d and ok[0] in d["smallest_J"]:
                text += f" (smallest J {d['smallest_J'][ok[0]]['J']:.3g})"
        text += "."
    for name, s in large.items():
        d = deformation.get(name)
        label = loss_runs(s)["corotational"]
        if name in {n for n, _, _ in items} or not d or label not in d["smallest_J"]:
            continue
        jc, jr = d["smallest_J"][label], d["smallest_J"].get(s.reference)
        if jr:
            text += (
                f" On {name}, where it ran, `{label}` reaches J = {jc['J']:.3g} against the "
                "reference's "
                f"{jr['J']:.3g}."
            )
    smaller = [
        n
        for n, s in large.items()
        if loss(s, loss_runs(s)["corotational"])[1] == "ok"
        and deformation.get(n)
        and loss_runs(s)["corotational"] in deformation[n]["smallest_J"]
        and s.reference in deformation[n]["smallest_J"]
        and deformation[n]["smallest_J"][loss_runs(s)["corotational"]]["J"]
        < deformation[n]["smallest_J"][s.reference]["J"]
    ]
    text += (
        " The corotational element is linear elasticity in a rotated frame: it corrects "
        "rotations, not large volume changes"
    )
    if smaller:
        text += (
            f"; on {cases_text(smaller)} its most compressed cell keeps less of its volume (a "
            "smaller J) than "
            "the neo-Hookean reference's"
        )
    return text + "."


LINEAR_NEVER = "no linear run diverged or inverted a cell"


def judge_linear(large: dict[str, CaseSummary], deformation: dict) -> Verdict:
    """The linear model: no run diverged, and none inverted a cell (its smallest J, from
    deformation.json, which the solver does not check). `numbers`: the linear runs that
    diverged, and {case: the smallest J of its linear runs}."""
    failed = [
        label
        for s in large.values()
        for label, r in s.runs.items()
        if r.model == "linear" and r.status != "ok"
    ]
    js = {}
    for name, s in large.items():
        d = deformation.get(name)
        if not d:
            continue
        values = [
            d["smallest_J"][label]["J"]
            for label, r in s.runs.items()
            if r.model == "linear" and label in d["smallest_J"]
        ]
        if values:
            js[name] = min(values)
    checks = {"no run diverged": not failed}
    if js:
        checks["no cell inverted"] = min(js.values()) > 0
    return Verdict(LINEAR_NEVER, all(checks.values()), checks, {"diverged": failed, "J": js})


def render_linear(v: Verdict) -> str:
    """The linear model's bullet (markdown)."""
    failed, js = v.numbers["diverged"], v.numbers["J"]
    text = (
        "- **linear**: "
        + ("no run diverged" if not failed else f"{', '.join(failed)} diverged")
        + "; the solver checks no linear run for inverted elements"
    )
    if js:
        text += (
            (", and none had one" if v.checks["no cell inverted"] else ", but some had one")
            + ": the smallest J of the linear runs is "
            + ", ".join(f"{x:.3g} on {n}" for n, x in js.items())
        )
    return text + "."


def linear_never(large: dict[str, CaseSummary], deformation: dict) -> str:
    """The linear model: no run diverged, and its smallest J, which the solver does not check."""
    return render_linear(judge_linear(large, deformation))
