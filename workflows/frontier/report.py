"""The real-time frontier's report (SPEC 11, workflows/frontier/runs.py): per case a figure of E_i
against cost with the frontier drawn and the truth's own error shaded, the best run of each
scheme and algorithm at a real-time cost, the paper's grid with and without the remedy, and
the paper's question (the penalty at h = 1/30 s against the material's own Poisson ratio
with sub-steps). Every number comes from frontier.csv."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

from tissuebench.meshes import get_entry
from tissuebench.solvers.truth.cases import CASES
from tissuebench.workflows.run.style import place_labels

MARKER = "# The real-time frontier"
PLAIN = {"quadrilateral": "Q1", "hexahedron": "Q1", "triangle": "P1", "tetrahedron": "P1"}
REAL_TIME = 1.0


def paper_size(benchmark: str) -> int:
    """The paper's grid of a benchmark: its default mesh size."""
    return get_entry(benchmark).mesh_size


def units_of(benchmark: str) -> str:
    """The units of E_i on a benchmark: m^gdim."""
    return f"m^{get_entry(benchmark).gdim}"


def scheme_name(row: dict) -> str:
    """The scheme as a reader knows it: Q1/P1 for the standard element, else its text."""
    return PLAIN[row["cell"]] if row["scheme"] == "standard" else row["scheme"]


def run_name(row: dict) -> str:
    """scheme + algorithm, with the sub-steps asked for (auto) where the algorithm took any."""
    steps = ", auto sub-steps" if row["requested"] == "auto" else ""
    return f"{scheme_name(row)} {row['algorithm']}{steps}"


def _ok(row: dict) -> bool:
    return row["status"] == "ok" and math.isfinite(row["interior_error_mean"])


def frontier(rows: list[dict], budget: float = REAL_TIME) -> list[dict]:
    """The best (smallest E_i mean) finished run of each scheme and algorithm at a cost of at
    most `budget` s per simulated s, best first."""
    best: dict[str, dict] = {}
    for r in rows:
        if _ok(r) and r["cost"] <= budget:
            name = run_name(r)
            if name not in best or r["interior_error_mean"] < best[name]["interior_error_mean"]:
                best[name] = r
    return sorted(best.values(), key=lambda r: r["interior_error_mean"])


def pareto(rows: list[dict]) -> list[dict]:
    """The finished runs that no other run beats in both cost and E_i mean, by cost."""
    done = sorted((r for r in rows if _ok(r)), key=lambda r: (r["cost"], r["interior_error_mean"]))
    front, best = [], math.inf
    for r in done:
        if r["interior_error_mean"] < best:
            front.append(r)
            best = r["interior_error_mean"]
    return front


def _find(rows, cell, scheme, algorithm, requested, size):
    for r in rows:
        if (r["cell"], r["scheme"], r["algorithm"], r["requested"], r["mesh_size"]) == (
            cell,
            scheme,
            algorithm,
            requested,
            size,
        ):
            return r
    return None


def _e(x: float) -> str:
    return "diverged" if not math.isfinite(x) else f"{x:.3g}"


def _reading(r: dict | None) -> str:
    if r is None:
        return "not run"
    if r["status"] != "ok":
        return f"diverged at t = {r['diverged_time']:.3g} s"
    return f"E_i mean {r['interior_error_mean']:.3g}, max {r['interior_error_max']:.3g}"


def case_section(
    case: str, rows: list[dict], figure: str, timing: Sequence[dict] = ()
) -> list[str]:
    """The markdown of one case; `timing`: its rows of frontier.side_by_side."""
    benchmark, material, model, scale, width = CASES[case]
    entry = get_entry(benchmark)
    units = units_of(benchmark)
    own = rows[0]["truth_own_error"] if rows else math.nan
    hex_cell = {2: "quadrilateral", 3: "hexahedron"}[entry.gdim]
    tet_cell = {2: "triangle", 3: "tetrahedron"}[entry.gdim]
    paper = paper_size(benchmark)
    where = f", needle width {width} m" if width else ""
    out = [f"## {case}", ""]
    out.append(
        f"{benchmark}, {material}{where}, {model} model; the truth's own E_i max "
        f"{own:.3g} {units} (no difference below it is a finding). E_i against the truth in "
        f"{units}; cost in s of wall time per simulated second (the time loop, every sub-step, "
        "one core; whole: the whole run's, its set-up of assembly, factorisations and critical "
        "step included, the cost the leaderboard ranks)."
    )
    out += ["", f"![{case}]({figure})", ""]
    best = frontier(rows)
    if best:
        top = best[0]
        out.append(
            f"**At <= {REAL_TIME:g} s per simulated second the closest run is {run_name(top)} "
            f"on the size-{top['mesh_size']} mesh ({top['dofs']:,} dofs{_k(top)}): E_i mean "
            f"{top['interior_error_mean']:.3g} {units}, max {top['interior_error_max']:.3g}, "
            f"{top['cost']:.3g} s per simulated s.**"
        )
    q1 = _find(rows, hex_cell, "standard", "implicit", "1", paper)
    md = _find(rows, hex_cell, "mean-dilatation", "implicit", "1", paper)
    if q1 and md and _ok(q1) and _ok(md):
        out += [
            "",
            f"On the paper's grid (size {paper}), implicit: Q1 {_reading(q1)}, "
            f"{q1['cost']:.3g} s per simulated s; mean-dilatation {_reading(md)}, "
            f"{md['cost']:.3g} s per simulated s: "
            f"{q1['interior_error_mean'] / md['interior_error_mean']:.2g} times closer to the "
            f"truth (E_i mean) at {md['cost'] / q1['cost']:.2g} times the cost of the loop.",
        ]
    if timing:
        measured = "; ".join(_timing_words(t) for t in timing)
        out += [
            "",
            "Mean-dilatation's cost against Q1's on the paper's grid, measured side by side "
            f"(the median of {timing[0]['repeats']} runs of each, taken in turn): {measured}.",
        ]
    out += [
        "",
        "| run | size | dofs | sub-steps | E_i mean | E_i max | cost (s/s) | whole (s/s) |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in best:
        out.append(
            f"| {run_name(r)} | {r['mesh_size']} | {r['dofs']:,} | {r['substeps']} | "
            f"{r['interior_error_mean']:.3g} | {r['interior_error_max']:.3g} | {r['cost']:.3g} | "
            f"{r['whole_cost']:.3g} |"
        )
    out += ["", "The paper's question, on its grid: the penalty at h = 1/30 s against the "
            "material's own Poisson ratio with sub-steps (explicit-lumped):", ""]  # fmt: skip
    for scheme in sorted({r["scheme"] for r in rows if r["scheme"].startswith("penalty")}):
        r = _find(rows, tet_cell, scheme, "explicit-lumped", "1", paper)
        if r is not None:
            out.append(f"- {scheme}, h = 1/30 s: {_reading(r)}, {r['cost']:.3g} s per simulated s")
    for scheme in ("standard", "anp"):
        r = _find(rows, tet_cell, scheme, "explicit-lumped", "auto", paper)
        if r is not None:
            out.append(
                f"- {scheme_name(r)}, {r['substeps']} sub-steps: {_reading(r)}, "
                f"{r['cost']:.3g} s per simulated s"
            )
    measured = sorted(
        (r for r in rows if r["requested"] == "auto" and math.isfinite(r["critical_dt_s"])),
        key=lambda r: (r["algorithm"], r["cell"], r["scheme"], r["mesh_size"]),
    )
    if measured:
        out += [
            "",
            "The critical step of each explicit algorithm and scheme, measured on each mesh (the "
            "largest eigenvalue of the free dofs, as `tissuebench stability` does), and the "
            "sub-steps auto took for h = 1/30 s (h/k <= 0.9 x the critical step):",
            "",
            "| algorithm | cell | scheme | size | critical step (s) | sub-steps |",
            "|---|---|---|---:|---:|---:|",
        ]
        out += [
            f"| {r['algorithm']} | {r['cell']} | {r['scheme']} | {r['mesh_size']} | "
            f"{r['critical_dt_s']:.3g} | {r['substeps']} |"
            for r in measured
        ]
    out += ["", "<details><summary>Every run</summary>", ""]
    out.append(
        "| cell | scheme | algorithm | size | sub-steps | status | E_i mean | E_i max | cost | "
        "whole |"
    )
    out.append("|---|---|---|---:|---:|---|---:|---:|---:|---:|")
    for r in sorted(
        rows, key=lambda r: (r["cell"], r["scheme"], r["algorithm"], r["requested"], r["mesh_size"])
    ):
        out.append(
            f"| {r['cell']} | {r['scheme']} | {r['algorithm']} ({r['requested']}) | "
            f"{r['mesh_size']} | {r['substeps']} | {r['status']} | "
            f"{_e(r['interior_error_mean'])} | {_e(r['interior_error_max'])} | {r['cost']:.3g} | "
            f"{r['whole_cost']:.3g} |"
        )
    out += ["", "</details>", ""]
    return out


def _timing_words(t: dict) -> str:
    """One algorithm's side-by-side timing in words."""
    steps = ""
    if t["algorithm"] != "implicit":
        steps = f" (auto sub-steps: {t['substeps_q1']} and {t['substeps_remedy']})"
    return (
        f"{t['algorithm']}{steps} {t['cost_remedy']:.3g} against {t['cost_q1']:.3g} s per "
        f"simulated s, ratio {t['ratio']:.2f}"
    )


def _k(r: dict) -> str:
    return f", {r['substeps']} sub-steps of h/{r['substeps']}" if r["substeps"] > 1 else ""


def colour(row: dict) -> str:
    """The colour of a run's scheme on its cell shape (Scheme.colour, or a spare one)."""
    from tissuebench.solvers.schemes import colour_of

    return colour_of(row["scheme"].partition(":")[0], row["cell"])


def colours() -> dict[str, str]:
    """{name as a reader knows it (scheme_name): colour} of every registered scheme on every
    cell shape it takes, the quadrilateral and hexahedral ones first: the figures' legend."""
    from tissuebench.solvers.schemes import SCHEMES, STANDARD, colour_of

    out: dict[str, str] = {}
    for cell, plain in PLAIN.items():
        for name, scheme in SCHEMES.items():
            if cell in scheme.cells:
                out.setdefault(plain if name == STANDARD else name, colour_of(name, cell))
    return out


MARKERS = {
    ("implicit", "1"): "o",
    ("explicit-lumped", "1"): "^",
    ("explicit-lumped", "auto"): "s",
    ("explicit", "auto"): "D",
}


def plot(path: Path, case: str, rows: list[dict]) -> None:
    """E_i mean against cost for every finished run of a case: colour by scheme, marker by
    algorithm, the frontier (Pareto) drawn, the real-time budget and the truth's own error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    benchmark = CASES[case][0]
    fig, ax = plt.subplots(figsize=(10.5, 5.5), constrained_layout=True)
    done = [r for r in rows if _ok(r)]
    for r in done:
        ax.scatter(
            r["cost"],
            r["interior_error_mean"],
            c=colour(r),
            marker=MARKERS[(r["algorithm"], r["requested"])],
            s=20
            + 12
            * {s: i for i, s in enumerate(sorted({x["mesh_size"] for x in rows}))}[r["mesh_size"]]
            ** 2,
            alpha=0.8,
            edgecolors="k",
            linewidths=0.4,
        )
    front = pareto(done)
    if front:
        ax.step(
            [r["cost"] for r in front],
            [r["interior_error_mean"] for r in front],
            where="post",
            color="k",
            lw=1.2,
            label="frontier (no run is both cheaper and closer)",
        )
        labels = [
            (f"{scheme_name(r)} n={r['mesh_size']}", (r["cost"], r["interior_error_mean"]))
            for r in front
        ]
    else:
        labels = []
    own = rows[0]["truth_own_error"] if rows else math.nan
    values = [r["interior_error_mean"] for r in done]
    if values and math.isfinite(own):
        low = min(min(values), own) / 3
        ax.axhspan(low, own, color="0.85", label=f"below the truth's own error ({own:.2g})")
        ax.set_ylim(low, max(values) * 2)
    ax.axvline(REAL_TIME, color="tab:red", ls="--", lw=1, label="real time: 1 s per simulated s")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall s per simulated s (time loop, one core)")
    ax.set_ylabel(f"E_i time-mean against the truth ({units_of(benchmark)})")
    ax.set_title(f"{case}: error against cost (size of marker: mesh size)")
    for family, drawn in colours().items():
        ax.scatter([], [], c=drawn, marker="o", label=family)
    for (algorithm, requested), marker in MARKERS.items():
        steps = ", auto sub-steps" if requested == "auto" else ", h = 1/30 s"
        ax.scatter([], [], c="w", edgecolors="k", marker=marker, label=algorithm + steps)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.grid(True, which="both", alpha=0.3)
    place_labels(fig, ax, labels)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def markdown(
    rows: list[dict], cases: tuple[str, ...], header: str, timing: Sequence[dict] = ()
) -> str:
    """The whole report: its header (how and when it was made), then each case; `timing`:
    the rows of frontier.side_by_side."""
    out = [MARKER, "", header, ""]
    for case in cases:
        mine = [r for r in rows if r["case"] == case]
        if mine:
            pairs = [t for t in timing if t["case"] == case]
            out += case_section(case, mine, f"frontier-{case}.png", pairs)
    return "\n".join(out) + "\n"


__all__ = ["frontier", "markdown", "pareto", "plot"]


def _share(r: dict) -> str:
    """A run's E_i max as a share of the truth's size (its E_i against rest)."""
    return f"{100 * r['interior_error_max'] / r['truth_size']:.2g} %"


def answer(rows: list[dict], link: str = "frontier/frontier.md") -> list[str]:
    """The section of results/README.md that answers SPEC 11's question from the frontier's
    rows: per case, the closest run at a real-time cost and how far from the physics it
    stays, the paper's grid with and without the remedy, and the paper's own question (the
    penalty at h = 1/30 s against the material's Poisson ratio with sub-steps)."""
    out = [
        "## Nearly incompressible tissue at real-time cost (SPEC 11)",
        "",
        "Every scheme of SPEC 11 with `implicit`, `explicit-lumped` and `explicit` (consistent "
        "mass, sub-steps) on four mesh sizes, graded "
        f"against the truth and timed on one core ([{link}]({link}): the tables, the figures "
        "and how they were measured). How far from the physics: a run's E_i max as a share of "
        "the truth's size, its E_i against rest.",
        "",
    ]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    cases.sort(key=lambda c: (CASES[c][1] != "MP2", c))  # the nearly incompressible first
    for case in cases:
        mine = [r for r in rows if r["case"] == case]
        benchmark, material = CASES[case][0], CASES[case][1]
        units = units_of(benchmark)
        gdim = get_entry(benchmark).gdim
        hexes, tets = {2: ("quadrilateral", "triangle"), 3: ("hexahedron", "tetrahedron")}[gdim]
        paper = paper_size(benchmark)
        best = frontier(mine)
        lines = [f"**{case}** ({material}):"]
        if best:
            top = best[0]
            lines.append(
                f"at <= {REAL_TIME:g} s per simulated s the closest run is {run_name(top)} on "
                f"the size-{top['mesh_size']} mesh ({top['dofs']:,} dofs{_k(top)}, "
                f"{top['cost']:.2g} s per simulated s): E_i mean {top['interior_error_mean']:.3g}"
                f" {units}, max {top['interior_error_max']:.3g}, {_share(top)} of the truth's "
                "size."
            )
        q1 = _find(mine, hexes, "standard", "implicit", "1", paper)
        md = _find(mine, hexes, "mean-dilatation", "implicit", "1", paper)
        if q1 and md and _ok(q1) and _ok(md):
            lines.append(
                f"On the paper's grid, implicit, Q1 is {_share(q1)} off (E_i mean "
                f"{q1['interior_error_mean']:.3g}) and mean-dilatation {_share(md)} (E_i mean "
                f"{md['interior_error_mean']:.3g}): "
                f"{q1['interior_error_mean'] / md['interior_error_mean']:.2g} times closer."
            )
        plain = _find(mine, tets, "standard", "explicit-lumped", "auto", paper)
        at_h = [
            r
            for r in mine
            if r["scheme"].startswith("penalty")
            and (r["cell"], r["algorithm"], r["requested"], r["mesh_size"])
            == (tets, "explicit-lumped", "1", paper)
        ]
        if material == "MP2" and plain is not None and at_h:
            said = "; ".join(f"{r['scheme']} {_reading(r)}" for r in at_h)
            lines.append(
                f"The paper's question (P1 on the paper's grid, explicit-lumped): the penalty at "
                f"h = 1/30 s: {said}; against the material's own nu with {plain['substeps']} "
                f"sub-steps: {_reading(plain)} at {plain['cost']:.2g} s per simulated s."
            )
        out += [" ".join(lines), ""]
    out += _verdict(rows, [c for c in cases if CASES[c][1] == "MP2"])
    out += _damping(rows, [c for c in cases if CASES[c][1] == "MP2"])
    return out


def _verdict(rows: list[dict], cases: list[str]) -> list[str]:
    """For prostate-like tissue: the closest real-time run of each nearly incompressible case,
    and the closest with an explicit algorithm (what a surgical simulator's loop runs), in one
    paragraph; the scheme named where every case agrees."""
    if not cases:
        return []
    best, explicit = {}, {}
    for case in cases:
        mine = frontier([r for r in rows if r["case"] == case])
        if mine:
            best[case] = mine[0]
        fast = [r for r in mine if r["algorithm"] != "implicit"]
        if fast:
            explicit[case] = fast[0]
    if not best:
        return []
    families = {scheme_name(r).split(":")[0] for r in best.values()}
    said = "; ".join(
        f"{case}: {run_name(r)}, n = {r['mesh_size']}, {_share(r)} of the truth's size"
        for case, r in best.items()
    )
    text = f"**For prostate-like tissue (MP2) at real-time cost**, the closest runs are: {said}."
    if len(families) == 1:
        text += f" Both cases agree on the scheme: {families.pop()}."
    if explicit:
        text += (
            " With an explicit loop (sub-steps included): "
            + "; ".join(
                f"{case}: {run_name(r)}, n = {r['mesh_size']}, {r['substeps']} sub-steps, "
                f"{_share(r)}, {r['cost']:.2g} s per simulated s"
                for case, r in explicit.items()
            )
            + "."
        )
    return [text, ""]


# the lumped mass is not the cause, measured once here (not a frontier run): the commands below
LUMPED_MASS = (
    "implicit-lumped (M_L, damping alpha M_L + beta K_0) on rod-MP2's paper grid with "
    "mean-dilatation has E_i max 6.83e-06 m^3 against implicit's 7.49e-06 and "
    "explicit-lumped's 4.48e-05 (`tissuebench run rod --material MP2 --scheme mean-dilatation "
    "--algorithms implicit-lumped,explicit-lumped,explicit --substeps auto --out DIR`, then "
    "`tissuebench compare truth:rod-MP2 DIR/implicit-lumped.xdmf --out CMP`)."
)


def _damping(rows: list[dict], cases: list[str]) -> list[str]:
    """Why explicit-lumped loses on the damped nearly incompressible cases, measured: on the
    paper's grid with mean-dilatation (its hexahedral/quadrilateral cell), auto sub-steps,
    explicit-lumped (damping alpha M_L only, SPEC 2) against explicit (alpha M + beta K_0, the
    truth's damping) and implicit, each E_i max as a share of the truth's size and its cost."""
    from tissuebench.solvers.materials import MATERIALS

    said = []
    for case in cases:
        mine = [r for r in rows if r["case"] == case]
        benchmark, material = CASES[case][0], CASES[case][1]
        cell = {2: "quadrilateral", 3: "hexahedron"}[get_entry(benchmark).gdim]
        paper = paper_size(benchmark)
        runs = [
            _find(mine, cell, "mean-dilatation", algorithm, requested, paper)
            for algorithm, requested in (
                ("explicit-lumped", "auto"),
                ("explicit", "auto"),
                ("implicit", "1"),
            )
        ]
        if any(r is None or not _ok(r) for r in runs):
            continue
        lumped, consistent, implicit = runs
        m = MATERIALS[material]
        said.append(
            f"{case} (alpha = {m.alpha:g} 1/s, beta = {m.beta:g} s): explicit-lumped "
            f"({lumped['substeps']} sub-steps) E_i max "
            f"{lumped['interior_error_max']:.3g}, {_share(lumped)} of the truth's size, "
            f"{lumped['whole_cost']:.2g} s per simulated s; explicit ({consistent['substeps']} "
            f"sub-steps) {consistent['interior_error_max']:.3g}, {_share(consistent)}, "
            f"{consistent['whole_cost']:.2g} s per simulated s; implicit "
            f"{implicit['interior_error_max']:.3g}, {_share(implicit)}"
        )
    if not said:
        return []
    return [
        "**Explicit-lumped against explicit on the damped MP2 cases** (mean-dilatation on the "
        "paper's grid, auto sub-steps, E_i max and its share of the truth's size, whole-run "
        "costs): "
        + "; ".join(said)
        + ". Explicit-lumped's damping is alpha M_L only (SPEC 2: the paper requires a multiple "
        "of the lumped mass), while the truth, implicit and explicit damp with alpha M + beta "
        "K_0, whose stiffness term damps each mode with the ratio beta omega / 2, growing with "
        "its frequency omega; sub-steps make explicit-lumped stable, not damped. Where it "
        "loses, the damping is the cause, not the lumped mass: " + LUMPED_MASS,
        "",
    ]
