"""results/README.md: what was run, the figures with captions, the metric tables, SPEC
section 7's claims beside our numbers (study/claims.py), the paper against the truth
(study/truth_section.py) and part 2, large deformation (study/large_deformation.py)."""

from pathlib import Path

import numpy as np

from tissuebench.meshes import get_entry
from tissuebench.metrics.table import METRICS as TABLE
from tissuebench.workflows.io.summary import CaseSummary
from tissuebench.workflows.io.tables import read_curves, read_tips
from tissuebench.workflows.run.figures import shape_rows, shown_steps, static_label
from tissuebench.workflows.study.claims import claims
from tissuebench.workflows.study.common import (
    LARGE_DEFORMATION,
    METRICS,
    metric_table,
    tip_crossings,
)
from tissuebench.workflows.study.large_deformation import large_deformation, model_case_section
from tissuebench.workflows.study.truth import PaperTruth
from tissuebench.workflows.study.truth_section import truth_section
from tissuebench.workflows.truth.sweep import readme_section

MARKER = (
    "# tissuebench: the paper's study"  # the report's first line: a README.md the paper may replace
)


# --- captions ------------------------------------------------------------------------------


def caption_errors(out: Path, name: str, s: CaseSummary) -> str:
    ref = s.reference
    text = (
        f"*Errors of each run against {ref} at every step 1..{s.steps} (E_n, E_s, E_i; log axes "
        "where the "
        "values span a decade). Runs differ in colour, dash pattern, width and marker; a wider "
        "line lies "
        "under the narrower ones."
    )
    for label, run in s.runs.items():
        if run.status == "diverged" and label != ref:
            step = run.diverged_step
            assert step is not None  # a diverged run's
            text += (
                f" {label} diverged at step {step} (t = {run.diverged_time:.3g} s): its curve "
                "ends at step "
                f"{step - 1} (t = {(step - 1) * s.h:.3g} s), its last finite values, and the "
                "dotted vertical "
                "line in its colour marks the divergence, at the time its legend gives."
            )
    runs = s.runs
    group = [
        k
        for k, r in runs.items()
        if r.material != runs[ref].material and r.algorithm != "quasi-static"
    ]
    if len(group) > 1:
        times, curves = read_curves(out / name / "metrics.csv")
        spreads = []
        for m in METRICS:
            c = np.array([curves[k][m][1:] for k in group])
            with np.errstate(invalid="ignore", divide="ignore"):
                spread = (c.max(axis=0) - c.min(axis=0)) / c.mean(axis=0)
            spreads.append(f"{TABLE[m].symbol} {100 * np.nanmax(spread):.2g} %")
        mat = runs[group[0]].material
        text += (
            f" The {len(group)} dynamic {mat} runs ({', '.join(group)}) differ from one another by "
            "at most "
            f"{', '.join(spreads)} of their mean at any step: on these log axes their curves "
            "overlap; each is "
            "drawn with its own dash pattern, width and markers so that all of them can be seen."
        )
    return text + "*"


def caption_tip(out: Path, name: str, s: CaseSummary) -> str:
    ref = s.reference
    tips = read_tips(out / name / "tip.csv")
    text = (
        f"*Vertical displacement of the tip of every run. {ref}, the reference, is the wide pale "
        "line; the "
        "others are narrower, dashed or dotted lines on top of it."
    )
    static = static_label(s, ref)
    if static in tips:
        level, cross = tip_crossings(tips, s)
        text += (
            f" Black dashed: {static}, 0 at step 0 and the static deflection {level:.4g} m from "
            "step 1 on. "
            "Lower panel: each run's distance from the static deflection, on a symmetric log scale "
            "(linear "
            "in a narrow band about 0), where the oscillation about the static shape stays visible "
            "as it "
            f"decays. Dotted vertical lines and circles: {ref}'s crossings of the static "
            "deflection, "
            "interpolated linearly between steps, at t = "
            f"{', '.join(f'{c:#.3g}' for c in cross) or 'none'} s."
        )
    return text + "*"


def caption_deformed(out: Path, name: str, s: CaseSummary) -> str:
    from types import SimpleNamespace

    runs = s.runs
    rows = shape_rows(SimpleNamespace(reference=s.reference), s)
    times = np.arange(s.steps + 1) * s.h
    shown = ", ".join(f"{times[k]:.3g}" for k in shown_steps(times))
    view = (
        "seen from its long side (+z), a little from above and from the free end, the side to "
        "which it bends"
        if get_entry(s.benchmark).gdim == 3
        else "seen from +z"
    )
    which = " and ".join(f"{r} ({runs[r].material})" for r in rows)
    return (
        f"*Deformed shape of {which} at t = {shown} s, "
        f"{view}. Faces are coloured by |u| on one scale for all panels and are not shaded, so "
        "their colours "
        "read directly on the colour bar; grey: the undeformed outline, drawn behind the shape.*"
    )


def paper_report(
    out: Path,
    summaries: dict[str, CaseSummary],
    large: dict[str, CaseSummary] | None = None,
    limits: dict | None = None,
    truth: PaperTruth | None = None,
) -> str:
    """README.md: part 1, the paper's study (summaries: {case: summary}); the paper against the
    truth (truth: a paper_truth.PaperTruth, SPEC section 10); part 2, the large-deformation
    cases (large, in OUT/large-deformation/) with the explicit schemes' linear critical steps on
    their meshes (limits: {case: {algorithm: h_c}})."""
    out = Path(out)
    first = next(iter(summaries.values()))
    v = first.versions
    parts = [
        MARKER,
        "",
        "Written by `tissuebench paper` (do not edit by hand). The study of Alterovitz and "
        "Goldberg, "
        "*Comparing Algorithms for Soft Tissue Deformation*, as tissuebench poses it (README): Q1 "
        "elements, "
        "five integrators, three metrics against the `implicit` reference on the same mesh."
        + (
            " Part 2 goes beyond the paper (SPEC section 8): large deformation, every integrator "
            "with "
            f"every elastic model against `{next(iter(large.values())).reference}` "
            f"([{LARGE_DEFORMATION}/]({LARGE_DEFORMATION}/))."
            if large
            else ""
        ),
        "",
        f"Software: tissuebench {v['tissuebench']}, DOLFINx {v['dolfinx']}, petsc4py "
        f"{v['petsc4py']}, "
        f"gmsh {v['gmsh']}, shapely {v['shapely']}, manifold3d {v['manifold3d']}, Python "
        f"{v['python']}, "
        f"{v['mpi_ranks']} MPI rank(s).",
        "",
        "## SPEC section 7, claim by claim",
        "",
        "Summaries (SPEC section 6, as in each case's summary.json): the time-mean and the maximum "
        "of a metric "
        "over steps 1..N. Each verdict names the reading it rests on.",
        "",
        claims(out, summaries),
        "",
    ]
    if truth is not None:
        parts += truth_section(truth)
    for name, s in summaries.items():
        parts += [
            f"## {name}",
            "",
            f"{s.description}. Mesh size {s.mesh_size} ({s.num_dofs} dofs), h = "
            f"{s.h:.6g} s, "
            f"T = {s.end_time:.4g} s ({s.steps} steps), solver {s.solver}. Files: "
            f"[metrics.csv]({name}/metrics.csv), [summary.json]({name}/summary.json)"
            + (f", [tip.csv]({name}/tip.csv)" if "tip.csv" in s.files else "")
            + "; the XDMF series (not committed) open in ParaView.",
            "",
        ]
        if "errors.png" in s.files:  # a case written without figures claims none
            parts += [f"![errors]({name}/errors.png)", "", caption_errors(out, name, s), ""]
        if "tip.png" in s.files:
            parts += [f"![tip]({name}/tip.png)", "", caption_tip(out, name, s), ""]
        if "deformed.png" in s.files:
            parts += [
                f"![deformed shape]({name}/deformed.png)",
                "",
                caption_deformed(out, name, s),
                "",
                f"Animation of the run(s) shown: [reference.gif]({name}/reference.gif)",
                "",
            ]
        parts += [
            metric_table(s),
            "",
        ]
    if large:
        parts += large_deformation(out, large, limits)
        for name, s in large.items():
            parts += model_case_section(out, name, s)
    if (out / "frontier" / "frontier.csv").is_file():  # SPEC 11, tissuebench frontier
        from tissuebench.workflows.frontier.report import answer
        from tissuebench.workflows.frontier.runs import read_rows

        parts += answer(read_rows(out / "frontier" / "frontier.csv"))
    parts += readme_section(out / "crease" / "crease.json")  # SPEC 10, tissuebench truth
    if (out / "contact").is_dir():  # SPEC 12, tissuebench hertz and tissuebench contact
        from tissuebench.workflows.contact.report import paper_section

        parts += paper_section(out / "contact")
    from tissuebench.workflows.contact import report3d  # SPEC 13: hertz --dim 3, leaderboard

    parts += report3d.paper_section(out)
    for extra, title in [
        ("stability.md", "Stability"),
        ("convergence.md", "Convergence"),
        ("performance.md", "Performance"),
    ]:
        if (out / extra).is_file():
            parts += [f"## {title}", "", f"See [{extra}]({extra}).", ""]
    return "\n".join(parts)
