"""The speed-accuracy leaderboard (`tissuebench leaderboard`): for each case, our algorithms
and models (a study case, workflows/study.py), every outside simulator's variants that pose it
(workflows/simulators.py) and any run a user graded with `compare` into the case's `user/`
folder, in one table and one figure per case: accuracy (time-mean and maximum E_i) against
cost (wall time per simulated second), with the Pareto front marked.

Cost. Ours: M, K and f assembled (System), the integrator set up (factorisations) and its time
loop, in process, 1 rank. CalculiX: the `ccx` process, 1 thread, its file output included.
SfePy and Newton: their setup and time loop in process (see each entry's `timing`). All in
one session on one machine; a user's run carries the wall time they gave compare.

OUT/leaderboard/CASE/ours, OUT/leaderboard/CASE/SIMULATOR: the case's folders (ours);
OUT/leaderboard/CASE/user/NAME: compare folders a user put there (read only);
OUT/leaderboard.md, OUT/leaderboard.csv, OUT/leaderboard/CASE.png: the leaderboard.
"""

from __future__ import annotations

import csv
import math
import platform
import textwrap
from dataclasses import dataclass, field
from pathlib import Path


from tissuebench.metrics.errors import METRICS
from tissuebench.solvers import interrupt
from tissuebench.solvers.external import SIMULATORS
from tissuebench.workflows.output import read_summary

E_I = "interior_error"
E_N = "relative_error"


@dataclass
class Board:
    """One leaderboard case: a benchmark posed once (material, model, options at the
    benchmark's default mesh, h and T), our algorithms with `models`, and the simulators."""

    name: str
    benchmark: str
    material: str
    model: str  # the reference's model, and the model the simulators are given
    models: tuple[str, ...] = ("linear",)  # ours
    options: dict = field(default_factory=dict)
    simulators: tuple[str, ...] = tuple(SIMULATORS)
    description: str = ""
    mesh_size: int | None = None  # None: the benchmark's default
    end_time: float | None = None  # s; None: the benchmark's default


@dataclass
class Row:
    """One graded run of a case."""

    case: str
    label: str
    source: str  # "tissuebench", "CalculiX 2.20", ..., "user"
    description: str
    mesh: str
    dofs: int
    status: str
    reason: str | None
    errors: dict  # "<metric>_max" / "<metric>_mean" -> value or None
    wall_time_s: float | None  # s
    end_time: float  # s, simulated
    timing: str  # "this session" or "reported by the user"
    reference: bool = False
    pareto: dict = field(default_factory=dict)  # "mean" / "max" -> bool
    group: str | None = None  # its own legend entry and marker in the figure (default: source)

    @property
    def cost(self) -> float | None:
        """Wall time per simulated second (s/s)."""
        if self.wall_time_s is None or not self.end_time:
            return None
        return self.wall_time_s / self.end_time

    @property
    def cost_per_dof(self) -> float | None:
        """Wall time per simulated second and per dof (µs/s)."""
        return None if self.cost is None or not self.dofs else 1e6 * self.cost / self.dofs


def our_rows(case: str, summary: dict) -> list[Row]:
    """Rows of our runs from a study case's summary.json: the cost is the System's assembly,
    the integrator's setup and its time loop."""
    rows = []
    for label, run in summary["runs"].items():
        wall = run.get("wall_time_s")
        if wall is not None:
            wall += run.get("setup_time_s", 0.0) + summary.get("system_time_s", 0.0)
        rows.append(
            Row(
                case,
                label,
                "tissuebench",
                f"{run['algorithm']}, {run['model']} (SPEC 3, 8)",
                "reference",
                int(summary["num_dofs"]),
                run["status"],
                run.get("reason"),
                {k: run.get(k) for k in error_keys()},
                wall,
                float(summary["end_time"]),
                "this session",
                reference=label == summary["reference"],
            )
        )
    return rows


def external_rows(case: str, summary: dict) -> list[Row]:
    """Rows of a simulator folder's summary.json (workflows/simulators.py)."""
    rows = []
    for label, run in summary["runs"].items():
        version = run.get("version") or ""
        source = run["title"] if version in run["title"] else f"{run['title']} {version}"
        rows.append(
            Row(
                case,
                label,
                source,
                f"{run['description']}; timed: {run.get('timing') or 'around its run'}",
                run["mesh"],
                int(run["dofs"]),
                run["status"],
                run.get("reason"),
                {k: run.get(k) for k in error_keys()},
                run.get("wall_time_s"),
                float(summary["end_time"]),
                "this session",
            )
        )
    return rows


def user_rows(case: str, folder: Path) -> list[Row]:
    """Rows of the compare folders in folder (CASE/user/NAME/summary.json, kind "compare")."""
    rows = []
    for sub in sorted(p for p in Path(folder).glob("*") if p.is_dir()):
        summary = read_summary(sub)
        if not summary or summary.get("kind") != "compare":
            continue
        for label, run in summary["runs"].items():
            rows.append(
                Row(
                    case,
                    label,
                    "user",
                    f"graded by compare ({sub.name})",
                    "?",
                    0,
                    run["status"],
                    None,
                    {k: run.get(k) for k in error_keys()},
                    run.get("wall_time_s"),
                    float(summary["end_time"]),
                    "reported by the user",
                )
            )
    return rows


def error_keys() -> list[str]:
    return [f"{name}_{kind}" for name in METRICS for kind in ("max", "mean")]


def pareto(points: list[tuple[float, float]]) -> list[bool]:
    """For each (cost, error): True when no other point is at most as costly and at most as
    wrong, and better in one of the two (the non-dominated set)."""
    flags = []
    for i, (c, e) in enumerate(points):
        dominated = any(
            c2 <= c and e2 <= e and (c2 < c or e2 < e)
            for j, (c2, e2) in enumerate(points)
            if j != i
        )
        flags.append(not dominated)
    return flags


def mark_pareto(rows: list[Row]) -> None:
    """Set row.pareto["mean"|"max"] on the runs that finished, the reference left out (its
    error is zero by definition)."""
    for kind in ("mean", "max"):
        ranked = [
            r
            for r in rows
            if r.status == "ok"
            and not r.reference
            and r.cost is not None
            and r.errors.get(f"{E_I}_{kind}") is not None
        ]
        flags = pareto([(r.cost, r.errors[f"{E_I}_{kind}"]) for r in ranked])
        for r, flag in zip(ranked, flags):
            r.pareto[kind] = flag


# --- files ------------------------------------------------------------------------------------


def fmt(x: float | None, spec: str = ".3g") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def write_csv(path: Path, rows: list[Row]) -> None:
    names = ["case", "label", "source", "description", "mesh", "dofs", "status", "reason"]
    names += error_keys() + ["wall_time_s", "wall_per_simulated_s", "us_per_dof_per_simulated_s"]
    names += ["timing", "reference", "pareto_mean", "pareto_max"]
    with open(path, "w", newline="") as f:
        out = csv.writer(f)
        out.writerow(names)
        for r in rows:
            out.writerow(
                [r.case, r.label, r.source, r.description, r.mesh, r.dofs, r.status, r.reason or ""]
                + ["" if r.errors[k] is None else repr(r.errors[k]) for k in error_keys()]
                + ["" if x is None else repr(x) for x in (r.wall_time_s, r.cost, r.cost_per_dof)]
                + [r.timing, r.reference, r.pareto.get("mean", False), r.pareto.get("max", False)]
            )


LABELLED = 24  # a case with more runs shown labels its Pareto front only


@interrupt.drawing  # a signal while drawing: raised once drawn (solvers/interrupt.py)
def plot_case(path: Path, board: Board, rows: list[Row]) -> None:
    """Two panels, time-mean and maximum E_i against wall time per simulated second (log-log),
    one marker per source, the Pareto front as a dashed staircase, the reference's cost as a
    dotted line (in the legend); labels on every point, or on the front's when more than
    LABELLED are shown; a group of rows (our runs on simplices) has its own marker, and labels
    on the front only."""
    from matplotlib.figure import Figure

    markers = {"tissuebench": "o", "CalculiX": "s", "SfePy": "^", "Newton": "D", "user": "*"}
    fig = Figure(figsize=(12, 5.2), layout="constrained")
    axes = fig.subplots(1, 2)
    reference = next((r for r in rows if r.reference), None)
    not_shown = [r for r in rows if not r.reference and (r.status != "ok" or r.cost is None)]
    for ax, kind in zip(axes, ("mean", "max")):
        shown = [
            r
            for r in rows
            if not r.reference
            and r.status == "ok"
            and r.cost is not None
            and r.errors.get(f"{E_I}_{kind}")
        ]
        placed = []
        crowded = sum(r.group is None for r in shown) > LABELLED
        for source in dict.fromkeys(r.group or r.source for r in shown):
            group = [r for r in shown if (r.group or r.source) == source]
            marker = "v" if group[0].group else markers.get(source.split()[0], "P")
            ax.scatter(
                [r.cost for r in group],
                [r.errors[f"{E_I}_{kind}"] for r in group],
                marker=marker,
                s=46,
                label=source,
                zorder=3,
            )
            for r in group:
                if (crowded or r.group) and not r.pareto.get(kind):
                    continue  # a crowd, or a group: only its front is labelled (the table has all)
                xy = (r.cost, r.errors[f"{E_I}_{kind}"])
                near = sum(  # labels already placed next to this point go above it
                    abs(math.log(xy[0] / p[0])) < 0.25 and abs(math.log(xy[1] / p[1])) < 0.25
                    for p in placed
                )
                placed.append(xy)
                ax.annotate(
                    r.label.split(":", 1)[-1],
                    xy,
                    textcoords="offset points",
                    xytext=(4, 3 + 9 * near),
                    fontsize=7,
                )
        front = sorted((r for r in shown if r.pareto.get(kind)), key=lambda r: r.cost)
        if front:
            xs = [r.cost for r in front]
            ys = [r.errors[f"{E_I}_{kind}"] for r in front]
            ax.step(
                xs, ys, where="post", ls="--", color="0.3", lw=1, label="Pareto front", zorder=2
            )
        if reference is not None and reference.cost is not None:
            ax.axvline(
                reference.cost,
                ls=":",
                color="0.5",
                lw=1,
                label=f"cost of the reference {reference.label} (E = 0)",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("wall time per simulated second (s/s), this machine")
        ax.set_ylabel(f"{'time-mean' if kind == 'mean' else 'maximum'} interior error E_i")
        ax.grid(True, which="both", alpha=0.25)
        ax.legend(fontsize=8, loc="best")
    title = textwrap.wrap(f"{board.name}: {board.description}", 150)
    if not_shown:
        title += textwrap.wrap(
            f"not shown (failed or diverged): {', '.join(r.label for r in not_shown)}", 150
        )
    fig.suptitle("\n".join(title), fontsize=10)
    fig.savefig(path, format="png", dpi=110)


def table(rows: list[Row]) -> list[str]:
    """The markdown table of one case's rows, the best time-mean E_i first."""
    head = (
        "| run | source | mesh, dofs | status | E_i mean | E_i max | E_n max | wall (s) "
        "| s per simulated s | µs per dof per simulated s | Pareto (mean/max) |"
    )
    lines = [head, "|" + "---|" * 11]

    def key(r: Row):
        mean = r.errors.get(f"{E_I}_mean")
        return (not r.reference, r.status != "ok", mean if mean is not None else math.inf)

    for r in sorted(rows, key=key):
        status = r.status if not r.reason else f"{r.status}: {r.reason}"
        front = "/".join("yes" if r.pareto.get(k) else "-" for k in ("mean", "max"))
        lines.append(
            f"| {r.label}{' (reference)' if r.reference else ''} | {r.source} | {r.mesh}, "
            f"{r.dofs} | {status} | {fmt(r.errors.get(f'{E_I}_mean'))} | "
            f"{fmt(r.errors.get(f'{E_I}_max'))} | {fmt(r.errors.get(f'{E_N}_max'))} | "
            f"{fmt(r.wall_time_s)} | {fmt(r.cost)} | {fmt(r.cost_per_dof)} | {front} |"
        )
    return lines


def machine() -> str:
    """One line on where the wall times were measured."""
    import os

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{platform.node() or 'this machine'}, {cpu}, {os.cpu_count()} cores, {platform.system()}"
    )


def markdown(
    boards: list[Board], rows: dict[str, list[Row]], notes: dict[str, list[str]], session: str
) -> str:
    """leaderboard.md."""
    out = [
        "# Leaderboard: accuracy against cost",
        "",
        "Written by `tissuebench leaderboard --out results`. Every run of a case is graded "
        "against the same reference (our `implicit`, with the case's model) by the same code "
        "as `tissuebench compare`: E_i is the interior error (SPEC 6), E_n the relative nodal "
        "error; time-mean and maximum over steps 1..N. Cost is the wall time per simulated "
        "second, and per dof.",
        "",
        f"Wall times: measured in one session ({session}) on {machine()}; serial (1 rank, 1 "
        "thread). Ours: assembly of M, K and f, the integrator's setup (factorisations) and "
        "its time loop, in process. CalculiX: the whole `ccx` process, including its reading "
        "of the deck and writing of .frd and .dat. SfePy and Newton: their setup and time "
        "loop in process (Newton's kernel compilation excluded). A user's run (`user/`) "
        "carries the wall time given to compare. The runs are small (the paper's meshes): "
        "fixed costs weigh heavily, and single timings of runs under 0.2 s vary by tens of "
        "per cent between sessions.",
        "",
        "Pareto: a run is on the front when no other finished run is at most as costly and "
        "at most as wrong (better in one); the reference is left out (its error is 0).",
        "",
    ]
    for board in boards:
        out += [
            f"## {board.name}",
            "",
            board.description,
            "",
            f"![{board.name}](leaderboard/{board.name}.png)",
            "",
        ]
        out += table(rows[board.name])
        outside = [r for r in rows[board.name] if r.source != "tissuebench"]
        if outside:
            out += ["", "What each outside run is:", ""]
            out += [
                f"- `{r.label}`: {r.description}; mesh: {r.mesh}; timing: {r.timing}"
                for r in outside
            ]
        if notes.get(board.name):
            out += ["", *[f"- {n}" for n in notes[board.name]]]
        out.append("")
    return "\n".join(out)
