"""`tissuebench convergence`: the observed order of every error, in time and in space.

Time: every dynamic scheme with h, h/2, h/4, h/8 (h = 1/30 s) against `implicit` with h/64, on
the block (N = 20, MP1) and the rod (n = 3, MP3), up to a shorter end time than the
benchmarks' 10 s (default 1 s). Each metric's error is its maximum over the times t_j = j h
that all runs share.

Space: the block with a needle tip width w = 0.2 m on N = 10, 20, 40, 80 (MP1) and the rod on
n = 2, 3, 6, 12 (MP3), against the finest mesh, at t = 1 s: the quasi-static solution and
`implicit` with h = 1/30 s. Every solution is interpolated onto the finest mesh (the meshes are
nested, so this is exact) and measured there.

Observed orders: p = log(e_a / e_b) / log(s_b / s_a) between consecutive refinements s (1/h, or
cells per unit length); and, free of the reference's own error, from the differences between
consecutive solutions. Writes DIR/convergence.md, convergence_time.png and
convergence_space.png (rank 0 only). Units: h in s, errors dimensionless (E_n, E_s) or in m (E_i).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.core.errors import UserError
from tissuebench.meshes import BENCHMARKS, get_benchmark
from tissuebench.metrics import METRICS as ALL_METRICS
from tissuebench.solvers.stability import explicit_schemes, stability_limits
from tissuebench.solvers.system import System
from tissuebench.workflows.commands import HELP
from tissuebench.workflows.io.output import check_writable, collective, write_owned
from tissuebench.workflows.study.convergence import (
    LEVELS,
    METRICS,
    REFINEMENT,
    SPACE_TIME,
    difference_orders,
    orders,
    space_study,
    time_study,
)

# every benchmark at its defaults (time), and on its study meshes with its refinement options
# (space)
TIME_CASES = [(name, e.material, e.mesh_size) for name, e in BENCHMARKS.items() if e.studied]
SPACE_CASES = [
    (name, e.material, e.study_sizes, e.refinement_options)
    for name, e in BENCHMARKS.items()
    if e.studied
]


# --- output (rank 0) ----------------------------------------------------------------------------


def fmt(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:.3g}"


def fmt_order(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:.2f}".replace("-0.00", "0.00")


def order_table(
    title: str,
    label: Callable[[float], str],
    refinements: Sequence[float],
    results: dict[str, dict[str, list[dict[str, float]]]],
    fine_label: str,
) -> list[str]:
    """Markdown: per run and metric, the errors, the orders against the reference and from
    the differences."""
    n = len(next(iter(results.values()))["errors"])
    lines = [
        title,
        "",
        f"| run | metric | {' | '.join(label(s) for s in refinements[:n])} | order vs {fine_label} "
        "| order from differences |",
        "|---|---|" + "---|" * n + "---|---|",
    ]
    for run, r in results.items():
        for name in METRICS:
            e = [x[name] for x in r["errors"]]
            d = [x[name] for x in r["differences"]]
            p = orders(refinements[:n], e)
            q = difference_orders(refinements[: len(d) + 1], d)
            lines.append(
                f"| {run} | {ALL_METRICS[name].symbol} | {' | '.join(fmt(x) for x in e)} | "
                f"{', '.join(fmt_order(x) for x in p)} | {', '.join(fmt_order(x) for x in q)} |"
            )
    return lines + [""]


def plot(
    path: Path,
    title: str,
    panels: Sequence[tuple[str, Sequence[float], dict[str, dict[str, list[dict[str, float]]]]]],
    xlabel: str,
    guides: Sequence[float],
) -> None:
    """One row per benchmark, one column per metric: error against step or cell size, log-log,
    with dotted lines of the orders in `guides` for comparison."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    fig = Figure(figsize=(11, 3.4 * len(panels)), layout="constrained")
    axes = fig.subplots(len(panels), len(METRICS), squeeze=False)
    for row, (name_of_case, x, results) in zip(axes, panels, strict=True):
        n = len(next(iter(results.values()))["errors"])
        x = np.asarray(x[:n])
        for ax, name in zip(row, METRICS, strict=True):
            lowest = math.inf
            for run, r in results.items():
                e = np.array([v[name] for v in r["errors"]])
                ok = np.isfinite(e) & (e > 0)
                ax.plot(x[ok], e[ok], "o-", label=run)
                lowest = min(lowest, e[ok].min(initial=math.inf))
            ends = np.array([x.min(), x.max()])
            for p in guides:  # from half the smallest error, at the smallest x
                y = 0.5 * lowest * (ends / ends[0]) ** p
                ax.plot(ends, y, ":", color="0.4", lw=1)
                ax.annotate(
                    f"order {p}", (ends[1], y[1]), fontsize=7, color="0.3", ha="right", va="bottom"
                )
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xticks(sorted(x), [f"{v:.3g}" for v in sorted(x)])
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.set_title(f"{name_of_case}: {ALL_METRICS[name].symbol}", fontsize=10)
            ax.set_xlabel(xlabel)
            ax.grid(True, which="both", alpha=0.3)
        row[0].set_ylabel("error")
        row[0].legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, format="png", dpi=110)


def markdown(
    time_results: dict[tuple[str, str, int], dict[str, dict[str, list[dict[str, float]]]]],
    ratios: dict[tuple[str, str, int], dict[str, float]],
    space_results: dict[tuple, dict[str, dict[str, list[dict[str, float]]]]],
    h: float,
    end_time: float,
    wall: float,
) -> str:
    lines = [
        "## Convergence: observed orders in time and space",
        "",
        f"### Time (h = {h:.4g} s down to h/8, against implicit with h/{REFINEMENT})",
        "",
        f"Runs end at T = {end_time:g} s, not the benchmarks' 10 s, to keep the h/{REFINEMENT} "
        "reference affordable. Error: each metric's maximum over the times t_j = j h that all "
        "runs share. Orders: between consecutive halvings of h; 'from differences' uses the "
        "differences between a scheme's own runs at consecutive steps, so it measures the "
        "scheme's order even where its error against the consistent-mass reference stops falling "
        "(the lumped schemes converge to the lumped-mass solution, not to the reference). '—': a "
        "run diverged.",
        "",
    ]
    for case, results in time_results.items():
        bench, material, size = case
        lines += order_table(
            f"#### {bench}, mesh size {size}, {material}",
            lambda s: f"h/{s:g}" if s > 1 else "h",
            [2**k for k in range(LEVELS)],
            results,
            f"h/{REFINEMENT}",
        )
        critical = " and ".join(
            f"{r:.2f} × the critical step of {name}" for name, r in ratios[case].items()
        )
        lines += [
            f"On this mesh h = {h:.4g} s is {critical} (`tissuebench stability`).",
            "",
        ]
    lines += [
        "![time convergence](convergence_time.png)",
        "",
        f"### Space (solutions at t = {SPACE_TIME:g} s, against the finest mesh)",
        "",
        "Every solution is interpolated onto the finest mesh (nested meshes: exact) with "
        "Function.interpolate_nonmatching and measured there. Quasi-static: one solve of K u = f "
        f"at t = {SPACE_TIME:g} s; implicit: h = {h:.4g} s from t = 0. The block uses a needle "
        "tip width w = 0.2 m (the nodes with |y − 0.5| ≤ 0.1 on x = 1 move with the needle), so "
        "that every mesh has the same load. Orders: between consecutive meshes, against the "
        "finest one (the last one is biased by the finest mesh's own error) and from consecutive "
        "differences.",
        "",
        "Orders below 2 are what the singular points of these problems allow: at the ends of the "
        "block's needle segment the prescribed motion meets the traction-free right edge (a "
        "displacement ∼ r^(1/2)), and the fixed edges meet the free edge at corners; the rod's "
        "clamped face meets its free faces along edges.",
        "",
    ]
    for (bench, material, sizes), results in space_results.items():
        lines += order_table(
            f"#### {bench}, {material}, mesh sizes {', '.join(map(str, sizes))}",
            lambda s: str(s),
            list(sizes),
            results,
            f"{sizes[-1]}",
        )
    lines += [
        "![space convergence](convergence_space.png)",
        "",
        f"Wall time: {wall:.1f} s on {MPI.COMM_WORLD.size} process(es).",
        "",
    ]
    return "\n".join(lines)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "convergence",
        help=HELP["convergence"],
        description=__doc__.split("\n\n")[0],
    )
    p.add_argument("--out", default="results", help="output directory (default: results)")
    p.add_argument(
        "--end-time", type=float, default=1.0, help="end time of the time study, s (default 1)"
    )
    p.set_defaults(func=main)


FILES = ("convergence.md", "convergence_time.png", "convergence_space.png")


def main(args: argparse.Namespace) -> int:
    comm = MPI.COMM_WORLD
    h = 1 / 30
    ratio = args.end_time / h
    n = round(ratio) if math.isfinite(ratio) else 0
    if n < 1 or not math.isclose(n * h, args.end_time, rel_tol=1e-9):
        raise UserError(
            f"--end-time must be a positive multiple of h = 1/30 s, got {args.end_time}"
        )
    check_writable(args.out, comm, owned=[*FILES])
    start = time.perf_counter()
    time_results, ratios = {}, {}
    for bench, material, size in TIME_CASES:
        system = System(get_benchmark(bench, mesh_size=size, comm=comm), material)
        time_results[(bench, material, size)] = time_study(system, h, args.end_time)
        limits = stability_limits(system, explicit_schemes())
        ratios[(bench, material, size)] = {
            name: h / lim.critical_dt for name, lim in limits.items()
        }
    space_results = {
        (bench, material, sizes): space_study(bench, material, sizes, comm=comm, **options)
        for bench, material, sizes, options in SPACE_CASES
    }
    wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    out = Path(args.out)

    def write():
        write_owned(
            out / "convergence_time.png",
            lambda tmp: plot(
                tmp,
                f"Time: each metric's maximum over t ≤ {args.end_time:g} s, "
                f"against implicit with h/{REFINEMENT}",
                [
                    (f"{b} {m}", [h / 2**k for k in range(LEVELS)], r)
                    for (b, m, _), r in time_results.items()
                ],
                "time step h (s)",
                guides=[2],
            ),
        )
        write_owned(
            out / "convergence_space.png",
            lambda tmp: plot(
                tmp,
                f"Space: at t = {SPACE_TIME:g} s, against the finest mesh",
                [
                    (f"{b} {m}", [BENCHMARKS[b].cell_size(s) for s in sizes], r)
                    for (b, m, sizes), r in space_results.items()
                ],
                "cell size (m)",
                guides=[1, 2],
            ),
        )
        text = markdown(time_results, ratios, space_results, h, args.end_time, wall)
        write_owned(out / "convergence.md", lambda tmp: tmp.write_text(text))

    collective(comm, write, out)  # rank 0 writes; its failure is raised on every rank
    if comm.rank == 0:
        print(
            f"wrote {out / 'convergence.md'}, convergence_time.png, convergence_space.png "
            f"({wall:.1f} s)"
        )
    return 0
