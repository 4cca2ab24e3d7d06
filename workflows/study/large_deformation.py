"""Part 2 of results/README.md, beyond the paper (SPEC section 8): what linearisation loses
against lumping and explicit stepping, how the loss grows with the load, the corotational
model, and each large-deformation case's section (figures, captions, table). Which runs
diverge and why is study/divergence.py."""

from pathlib import Path
from typing import Any

import numpy as np

from tissuebench.meshes import get_entry
from tissuebench.solvers import MODELS
from tissuebench.solvers.models import run_label
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.run.model_runs import SHAPE_ALGORITHM, SHAPE_MODELS
from tissuebench.workflows.run.tip_path import static_tips
from tissuebench.workflows.study.common import (
    LARGE_DEFORMATION,
    LOSS_READING,
    Verdict,
    loss,
    loss_runs,
    metric_table,
    place,
    ratio_text,
    read_deformation,
)
from tissuebench.workflows.study.divergence import divergences


def loss_text(summary: CaseSummary, label: str) -> str:
    v, status, t = loss(summary, label)
    if status is None:
        return "not run"
    if status != "ok":
        return f"diverged at t = {t:.3g} s"
    return f"{v:.3g}"


def load_text(summary: CaseSummary) -> str:
    text = f"s = {summary.option('load_scale', 1):g}"
    return text + get_entry(summary.benchmark).options_text(summary.option)


def times_text(a: float, b: float) -> str:
    """'12 times' for a / b, or '1/12 of'; a zero loss, which a run that is its case's
    reference has, is said as such instead of dividing by it."""
    if a == 0 or b == 0:
        return "the same as" if a == b else ("none of" if a == 0 else "infinitely many times")
    r = a / b
    return f"{ratio_text(r)} times" if r >= 1 else f"1/{ratio_text(1 / r)} of"


def large_deformation(
    out: Path, large: dict[str, CaseSummary], limits: dict | None = None
) -> list[str]:
    """Part 2 of the report: what linearisation loses against lumping and explicit stepping,
    and which combinations diverge and why, from the summaries of the large-deformation cases
    (and their deformation.json, metrics.csv, and the explicit schemes' linear critical steps
    `limits`: {case: {algorithm: h_c in s}})."""
    limits = limits or {}
    folder = Path(out) / LARGE_DEFORMATION
    first = next(iter(large.values()))
    references = list(dict.fromkeys(c.reference for c in large.values()))
    ref = f"`{first.reference}`"
    if len(references) > 1:  # SPEC 8: neo-Hookean at the paper's loads, the barrier at large ones
        ref = " or ".join(
            f"`{r}` ({', '.join(n for n, c in large.items() if c.reference == r)})"
            for r in references
        )
    present = {r.model for r in first.runs.values()}
    names = {"linear": "linear", "svk": "St Venant-Kirchhoff `svk`"}
    listed = ", ".join(names.get(m, f"`{m}`") for m in MODELS if m in present)
    lines = [
        "## Part 2, beyond the paper: large deformation (SPEC section 8)",
        "",
        "The paper assumes small strain. Here every algorithm runs with every elastic model "
        f"({listed}) against its case's reference, {ref}, at the paper's "
        "loads "
        "(load scale s = 1) and at large ones. The loss of realism of a run is its time-mean "
        "interior "
        "error E_i against that reference over steps 1..N (summary.json "
        f"`{LOSS_READING}_mean`; in m: the "
        "distance between the two displacement fields, averaged over the body and the run). A run "
        "that "
        "diverged has a mean over the steps it kept only; it is reported as diverged, not "
        "compared.",
        "",
        "### What linearisation loses, against lumping and explicit stepping",
        "",
    ]
    names = loss_runs(first)
    columns = ["linearisation", "corotational", "svk", "lumping", "explicit stepping"]
    columns += ["lumped explicit stepping", "inertia (quasi-static)"]
    lines += [
        "Time-mean E_i (m) against the reference of the run that differs from it in one respect: "
        "its model (linear, corotational or svk, with the reference's algorithm), its mass "
        "(lumped), its "
        "time stepping (explicit), both, or no inertia (quasi-static).",
        "",
        "| case | load | largest nodal displacement of the reference (m) | "
        + " | ".join(f"{c}: `{names[c]}`" for c in columns)
        + " |",
        "|" + "---|" * (3 + len(columns)),
    ]
    deformation = {name: read_deformation(folder / name) for name in large}
    for name, s in large.items():
        names = loss_runs(s)
        d = deformation[name]
        peak = (
            f"{d['largest_deflection']['u_max']:.3g} (t = {d['largest_deflection']['time']:.3g} s)"
            if d and d.get("largest_deflection")
            else "n/a"
        )
        lines.append(
            f"| {name} | {load_text(s)} | {peak} | "
            + " | ".join(loss_text(s, names[c]) for c in columns)
            + " |"
        )
    lines.append("")
    lines += static_tip_table(large)
    for name, s in large.items():
        lines.append(loss_bullet(name, s))
    lines += paper_loads(large)
    lines += load_growth(large)
    lines += corotational_bullets(large, deformation)
    lines.append("")
    lines += divergences(out, large, deformation, limits)
    return lines


def static_tip_table(large: dict[str, CaseSummary]) -> list[str]:
    """The static tip of each model (its quasi-static run at the end time; summary.json
    `tip_displacement_final`) on the cases with a probe point."""
    with_tip = {n: s for n, s in large.items() if any(r.has_probe for r in s.runs.values())}
    if not with_tip:
        return []
    present = {r.model for s in with_tip.values() for r in s.runs.values()}
    models = [m for m in MODELS if m in present] + sorted(present - set(MODELS))
    lines = [
        "The static tip (u_x, u_y) in m of each model: its quasi-static run at the end time "
        "(summary.json `tip_displacement_final`).",
        "",
        "| case | " + " | ".join(models) + " |",
        "|" + "---|" * (1 + len(models)),
    ]
    for name, s in with_tip.items():
        cells = []
        for m in models:
            run = s.runs.get(run_label("quasi-static", m))
            tip = run.tip_displacement_final if run else None
            if run is None:
                cells.append("not run")
            elif run.status != "ok":
                cells.append(f"diverged at t = {run.diverged_time:.3g} s")
            elif tip is None:
                cells.append("n/a")
            else:
                cells.append(f"({tip[0]:.4g}, {tip[1]:.4g})")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines + [""]


def loss_bullet(name: str, s: CaseSummary) -> str:
    """One case: linearisation against the other single losses, and the spread of the linear
    runs over the algorithms."""
    names = loss_runs(s)
    lin, lin_status, _ = loss(s, names["linearisation"])
    if lin_status != "ok":
        lin_label = names["linearisation"]
        return f"- **{name}**, {load_text(s)}: `{lin_label}` {loss_text(s, lin_label)}."
    parts = []
    for what in ("lumping", "explicit stepping", "lumped explicit stepping"):
        v, status, t = loss(s, names[what])
        if status is None:
            continue
        if status != "ok":
            parts.append(f"{what} (`{names[what]}`) diverged at t = {t:.3g} s")
        else:
            parts.append(f"{times_text(lin, v)} the loss from {what} (`{names[what]}`, {v:.3g} m)")
    text = (
        f"- **{name}**, {load_text(s)}: linearisation loses E_i = {lin:.3g} m, "
        + "; ".join(parts)
        + "."
    )
    linear = [
        label
        for label, run in s.runs.items()
        if run.model == "linear" and run.algorithm != "quasi-static" and run.status == "ok"
    ]
    values = [loss(s, label)[0] for label in linear]
    if len(values) > 1:
        spread = (max(values) - min(values)) / min(values)
        text += (
            f" With the linear model the {len(values)} dynamic algorithms lose {min(values):.3g} "
            "to "
            f"{max(values):.3g} m, within {100 * spread:.2g} % of each other"
            + (": once the model is linear, the algorithm hardly matters." if spread < 0.1 else ".")
        )
    return text


LINEARISATION_LARGEST = "linearisation is the largest single loss at the paper's loads (s = 1)"


def judge_paper_loads(large: dict[str, CaseSummary]) -> Verdict | None:
    """At s = 1: is linearisation the largest single loss (time-mean E_i against the reference)
    on every case? `checks` {case: linearisation above lumping, explicit and lumped explicit
    stepping}, `numbers` {case: (linearisation / the largest other loss, which one)}; None if
    no case at s = 1 has the runs to judge."""
    checks, numbers = {}, {}
    for name, s in large.items():
        if s.option("load_scale", 1) != 1:
            continue
        names = loss_runs(s)
        lin = loss(s, names["linearisation"])
        others = {
            w: loss(s, names[w])
            for w in ("lumping", "explicit stepping", "lumped explicit stepping")
            if loss(s, names[w])[1] == "ok"
        }
        if lin[1] != "ok" or not others:
            continue
        larger = [w for w, v in others.items() if lin[0] > v[0]]
        worst = max(others, key=lambda w: others[w][0])
        checks[name] = len(larger) == len(others)
        numbers[name] = (lin[0] / others[worst][0], worst)
    if not checks:
        return None
    return Verdict(LINEARISATION_LARGEST, all(checks.values()), checks, numbers)


def render_paper_loads(v: Verdict) -> list[str]:
    """The paragraph on the paper's loads (markdown)."""
    text = (
        f"- At the paper's loads (s = 1) linearisation {'is' if v.holds else 'is not'} the largest "
        "of these losses on every case: "
        + "; ".join(
            f"on {n} it is {ratio_text(r)} times the largest of the others ({w})"
            for n, (r, w) in v.numbers.items()
        )
        + "."
    )
    if v.holds:
        text += (
            " The paper's question, which algorithm comes closest to the reference, is then second "
            "to which model it runs: an implicit linear simulation is further from the neo-Hookean "
            "one than every lumped or explicit neo-Hookean simulation that ran."
        )
    return [text]


def paper_loads(large: dict[str, CaseSummary]) -> list[str]:
    """At s = 1: is linearisation the largest single loss on every case? (markdown lines)"""
    v = judge_paper_loads(large)
    return [] if v is None else render_paper_loads(v)


def load_growth(large: dict[str, CaseSummary]) -> list[str]:
    """How the linear model's loss grows with the load scale, per benchmark."""
    lines = []
    by_bench: dict[str, list[tuple[Any, str, CaseSummary]]] = {}
    for name, s in large.items():
        by_bench.setdefault(s.benchmark, []).append((s.option("load_scale", 1), name, s))
    for bench, items in by_bench.items():
        if len(items) < 2:
            continue
        (s1, n1, a), (s2, n2, b) = min(items, key=lambda i: i[0]), max(items, key=lambda i: i[0])
        la, lb = (loss(x, loss_runs(x)["linearisation"]) for x in (a, b))
        if s2 == s1 or la[1] != "ok" or lb[1] != "ok":
            continue
        ratio = lb[0] / la[0]
        exponent = np.log(ratio) / np.log(s2 / s1)
        other = (
            " (the needle width changes too)"
            if a.option("needle_width", 0) != b.option("needle_width", 0)
            else ""
        )
        lines.append(
            f"- {bench}: the linear model's loss grows from {la[0]:.3g} m ({n1}) to {lb[0]:.3g} m "
            f"({n2}), "
            f"{ratio:.3g} times for {s2 / s1:g} times the load{other}: as s^{exponent:.3g}. To "
            "leading "
            "order the difference between a linear and a nonlinear solution grows as the square of "
            "the "
            "load (the strain's quadratic term)."
        )
    return lines


COROTATIONAL_BETTER = "the corotational model loses less than the linear one"


def judge_corotational(large: dict[str, CaseSummary]) -> Verdict:
    """On each case where the corotational run ran: does it lose less (time-mean E_i against
    the reference) than the linear model? `checks` {case: bool}; `numbers` the cases where it
    does (`better`) and where it does not (`worse`)."""
    checks = {}
    for n, s in large.items():
        names = loss_runs(s)
        corot = loss(s, names["corotational"])
        if corot[1] == "ok":
            checks[n] = bool(corot[0] < loss(s, names["linearisation"])[0])
    better = [n for n, ok in checks.items() if ok]
    worse = [n for n, ok in checks.items() if not ok]
    return Verdict(
        COROTATIONAL_BETTER, all(checks.values()), checks, {"better": better, "worse": worse}
    )


def corotational_bullets(large: dict[str, CaseSummary], deformation: dict) -> list[str]:
    """The corotational model against the linear one, case by case."""
    parts = []
    for name, s in large.items():
        names = loss_runs(s)
        lin, corot = loss(s, names["linearisation"]), loss(s, names["corotational"])
        if corot[1] is None or lin[1] != "ok":
            continue
        if corot[1] != "ok":
            parts.append(f"on {name} `{names['corotational']}` diverged at t = {corot[2]:.3g} s")
            continue
        r = corot[0] / lin[0]
        text = (
            f"on {name} {corot[0]:.3g} m, "
            + (f"{ratio_text(1 / r)} times less than" if r < 1 else f"{ratio_text(r)} times")
            + f" the linear model's {lin[0]:.3g} m"
        )
        d = deformation.get(name)
        if r > 1 and d:
            jc = d["smallest_J"].get(names["corotational"])
            jr = d["smallest_J"].get(s.reference)
            if jc and jr:
                text += (
                    f" (its most compressed cell, at {place(s, jc['cell_centre'])}, reaches J = "
                    f"{jc['J']:.3g} at t = {jc['time']:.3g} s; the reference's smallest J is "
                    f"{jr['J']:.3g})"
                )
        parts.append(text)
    if not parts:
        return []
    v = judge_corotational(large)
    better, worse = v.numbers["better"], v.numbers["worse"]
    summary = (
        "it removes much of the linear model's loss on "
        + (", ".join(better) or "no case")
        + ("; but not on " + ", ".join(worse) if worse else "")
    )
    return [
        "- The corotational model, the real-time codes' repair of linear elasticity, loses "
        + "; ".join(parts)
        + f": {summary}."
    ]


def model_case_section(out: Path, name: str, s: CaseSummary) -> list[str]:
    """A large-deformation case: its figures with captions and its table."""
    rel = f"{LARGE_DEFORMATION}/{name}"
    ref = s.reference
    files = s.files
    d = read_deformation(Path(out) / rel)
    parts = [
        f"### {name}",
        "",
        f"{s.description}. Mesh size {s.mesh_size} ({s.num_dofs} dofs), h = {s.h:.6g} "
        "s, "
        f"T = {s.end_time:.4g} s ({s.steps} steps), solver {s.solver}. Files: "
        f"[metrics.csv]({rel}/metrics.csv), [summary.json]({rel}/summary.json)"
        + (f", [tip.csv]({rel}/tip.csv)" if "tip.csv" in files else "")
        + (f", [deformation.json]({rel}/deformation.json)" if "deformation.json" in files else "")
        + "; the XDMF series (not committed) open in ParaView.",
        "",
    ]
    if "realism.png" in files:
        parts += [
            f"![loss of realism]({rel}/realism.png)",
            "",
            "*Loss of realism: the time-mean E_i (m) of every algorithm (rows) with every model "
            "(columns) "
            f"against {ref} over steps 1..{s.steps}, on a log colour scale (light: close to the "
            "reference). Hatched grey: a run that diverged, with its divergence time and its mean "
            "over the "
            "steps it kept, which is not comparable with the others.*",
            "",
        ]
    if "errors.png" in files:
        diverged = [
            f"{label} (t = {r.diverged_time:.3g} s)"
            for label, r in s.runs.items()
            if r.status == "diverged"
        ]
        parts += [
            f"![errors]({rel}/errors.png)",
            "",
            f"*Errors against {ref} at every step: one row of panels per model, one column per "
            "metric "
            "(E_n, E_s, E_i), one line per algorithm, drawn alike in every row (colour, dash "
            "pattern, marker); "
            "log axes where the values span a decade, one y range per column. A cross at a curve's "
            "last "
            "finite value and a dotted line in its colour mark a run that diverged"
            + (": " + ", ".join(diverged) if diverged else " (none here)")
            + ".*",
            "",
        ]
    if "shapes.png" in files and d and d.get("largest_deflection"):
        big = d["largest_deflection"]
        view = (
            "the boundary polygon of the deformed domain (SPEC section 6)"
            if get_entry(s.benchmark).gdim == 2
            else "the side view: the deformed mesh projected on the x-y plane (the union of the "
            "projected cells)"
        )
        drawn = [f"`{SHAPE_ALGORITHM}+{m}`".replace("+linear", "") for m in SHAPE_MODELS]
        parts += [
            f"![deformed shapes]({rel}/shapes.png)",
            "",
            f"*Deformed shape of {', '.join(drawn)} at t = {big['time']:.3g} s, the step at which "
            "the "
            f"reference's largest nodal displacement ({big['u_max']:.3g} m) is largest: {view}, "
            "over the "
            "undeformed outline (dotted); the reference wide and pale under the others. Where the "
            "outlines "
            "differ only locally, the right panel enlarges the square about the boundary nodes "
            "farthest "
            "apart. A run that diverged before that time is listed, not drawn.*",
            "",
        ]
    if "tip_path.png" in files:
        static = static_tips(s)
        tips = ", ".join(f"{m} ({v[0]:.4g}, {v[1]:.4g}) m" for m, v in static.items())
        missing = [
            r.model for r in s.runs.values() if r.algorithm == "quasi-static" and r.status != "ok"
        ]
        parts += [
            f"![tip path]({rel}/tip_path.png)",
            "",
            "*The tip of the implicit run with each model: its path in the x-y plane (left; the "
            "axes are "
            "not to the same scale) and its u_y against time (right). Stars and thin dashed lines: "
            "each "
            f"model's static tip, its quasi-static run at t = {s.end_time:.3g} s, (u_x, u_y): "
            f"{tips}"
            + (
                f"; {', '.join(missing)}: its quasi-static run diverged, no static tip"
                if missing
                else ""
            )
            + ".*",
            "",
        ]
    parts += [metric_table(s), ""]
    return parts
