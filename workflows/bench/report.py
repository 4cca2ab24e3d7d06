"""The report of `tissuebench bench`: the figure of time per step against degrees of freedom and
DIR/performance.md, from the records of workflows/bench/measure.py (or the same records loaded
from performance.json) and the tables of workflows/bench/tables.py (targets.py: the targets).

Units: seconds, bytes (MiB in the tables), degrees of freedom.
"""

from collections.abc import Sequence
from pathlib import Path

from tissuebench.workflows.bench.machine import LOAD_LIMIT, machine_description, noisy
from tissuebench.workflows.bench.measure import (
    BLOCK,
    BLOCK_WARM,
    BUDGET,
    CAPACITY_CASES,
    DIRECT_TOL,
    MAIN_CASES,
    MODEL_CASES,
    ROUNDS,
    SAFETY,
    SHORT,
    STEPS,
    SWEPT,
    THREAD_VARS,
    WARMUP,
    get,
)
from tissuebench.workflows.bench.tables import (
    assembly_rows,
    bandwidth_rows,
    capacity,
    extra_peer_rows,
    fmt,
    markdown_table,
    model_cpu_rows,
    model_step_rows,
    newton_rows,
    step_rows,
)
from tissuebench.workflows.bench.targets import (
    MODEL_REAL_TIME_DOFS,
    MODEL_STEP_DOFS,
    MODEL_STEP_LIMIT,
    NEWTON_LIMIT,
    model_step_targets,
    targets,
)
from tissuebench.workflows.io.output import write_owned

# --- figure and report ----------------------------------------------------------------------------

MODEL_STEP_TEXT = (
    "Each nonlinear model's (and remedy's) explicit-lumped step ran in the same worker as the "
    "linear one, at the same h (the linear scheme's on the plain Q1 mesh: "
    f"{SAFETY} x 2/omega_max) and with the same steps; ratio = its median step time / the "
    "linear step's. The linear step is one fused pass over the assembled K "
    "(solvers/blockcsr.py). A nonlinear model's step evaluates f_int(u) and the smallest "
    "det F in one compiled element loop (solvers/compiled_forces.py: the UFL form's 2x2(x2) "
    "Gauss points, the model's P(F) in C, 8 cells per SIMD batch; corotational also finds R "
    "at every cell centre there), then one compiled pass for a and v. "
    "`MODEL@mean-dilatation` is SPEC 11's mean-dilatation scheme: F-bar with a nonlinear "
    "model (the cell's mean J in the same loop), B-bar with the linear one (`linear@...`: "
    "another K for the linear step's loop). "
    f"Target (issue 32): at most {MODEL_STEP_LIMIT:g} x the linear step at >= "
    f"{MODEL_STEP_DOFS:.0e} dofs, rod and block."
)

# (side, line style, marker, legend label): the rank count is in the label, the line and the
# marker; the colour is the case.
OURS_LINES = (
    ("ours1", "-", "o", "ours, 1 rank (solid, circles)"),
    ("ours2", "--", "^", "ours, 2 ranks (dashed, triangles)"),
)
PEER_LINE = (":", "s", "peer (dotted, squares)")


def plot(records: list[dict], path: Path) -> None:
    """Time per step against dofs, rod and block side by side, every case on a log-log line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, 2, figsize=(16, 5.5), sharey=True)
    styles = {
        ("explicit-lumped", "-"): "C0",
        ("implicit", "direct"): "C1",
        ("implicit", "cg"): "C2",
        ("implicit", "gamg"): "C6",
        ("implicit-lumped", "direct"): "C3",
        ("explicit", "direct"): "C4",
        ("quasi-static", "direct"): "C5",
        MODEL_CASES[0]: "C8",
        MODEL_CASES[1]: "C9",
    }
    peer_styles = {
        ("explicit-lumped", "-"): "C0",
        ("implicit", "pardiso"): "C1",
        ("implicit", "superlu"): "C7",
        ("implicit", "pyamg"): "C2",
    }
    for ax, bench in zip(axes, SWEPT, strict=True):
        recs = [r for r in records if r["benchmark"] == bench]
        for side, dash, marker, label in OURS_LINES:
            for case, color in styles.items():
                pts = [
                    (r["dofs"], get(r, side, case, "step_s"))
                    for r in recs
                    if get(r, side, case, "step_s")
                ]
                if pts and (side == "ours1" or case in MAIN_CASES):
                    ax.loglog(
                        *zip(*pts, strict=True),
                        dash,
                        color=color,
                        marker=marker,
                        ms=4,
                        label=f"{label}: {case[0]} {case[1] if case[1] != '-' else ''}",
                    )
        dash, marker, label = PEER_LINE
        for case, color in peer_styles.items():
            pts = [
                (r["dofs"], get(r, "peer", case, "step_s"))
                for r in recs
                if get(r, "peer", case, "step_s")
            ]
            if pts:
                ax.loglog(
                    *zip(*pts, strict=True),
                    dash,
                    color=color,
                    marker=marker,
                    ms=3,
                    label=f"{label}: {case[0]} {case[1] if case[1] != '-' else 'CSR'}",
                )
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(f"{bench}: time per step (median)")
        ax.set_xlabel("degrees of freedom")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("wall time per step (s)")
    # clear of the curves; long handles so that solid, dashed and dotted can be told apart
    axes[1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), handlelength=4)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def sizes_ran(records: list[dict]) -> dict[tuple[str, str, str], list[str]]:
    """{(bench, side, case): sizes that ran it}, a size marked * where it ran SHORT steps."""
    ran: dict[tuple[str, str, str], list[str]] = {}
    for rec in records:
        for side in ("ours1", "ours2", "peer"):
            for k, r in rec.get(side, {}).get("cases", {}).items():
                if "step_s" in r:
                    mark = "" if r.get("steps") == STEPS else "*"
                    ran.setdefault((rec["benchmark"], side, k), []).append(f"{rec['size']}{mark}")
    return ran


def failures(records: list[dict]) -> list[str]:
    """One markdown item per failed worker and per failed case."""
    sides = ("ours1", "ours2", "peer")
    errors = [
        f"- {r['benchmark']} {r['size']} {side}: {r[side]['error']}"
        for r in records
        for side in sides
        if "error" in r.get(side, {})
    ]
    errors += [
        f"- {r['benchmark']} {r['size']} {side} {k}: {c['error']}"
        for r in records
        for side in sides
        for k, c in r.get(side, {}).get("cases", {}).items()
        if "error" in c
    ]
    return errors


def paths_section(paths: dict | None) -> list[str]:
    """performance.md's section on the paths a user waits on (markdown lines)."""
    from tissuebench.workflows.bench.paths import outside_target, table

    head = ["## The paths a user waits on", ""]
    if paths is None:
        return head + [
            "Not timed in a quick run: a full run, or `tissuebench bench --only paths`, times "
            "them (performance-paths.md).",
            "",
        ]
    sentence = outside_target(paths)
    return [
        *head,
        "Each command whole, in a process of its own, timed in this run after the step "
        f"benchmarks ({paths['when']}; the machine's probe at {paths['slowdown']:.2f}); `run`'s "
        "phases and every printed estimate against the time it estimated are in "
        "performance-paths.md, which the same run wrote.",
        "",
        *table(paths),
        "",
        *([sentence, ""] if sentence is not None else []),
    ]


def load_text(records: list[dict]) -> str:
    """What the "others' load" columns mean, and how many of the records' measurements stayed
    noisy (machine.noisy) after their rerun."""
    sides = [rec[side] for rec in records for side in ("ours1", "ours2") if side in rec]
    loud = sum(noisy(side.get("load")) for side in sides)
    reruns = sum(bool(side.get("reruns")) for side in sides)
    return (
        "The machine is shared. others' load = the cores that other processes kept busy on "
        "average during each worker (all cores' busy time from /proc/stat less the worker's own "
        f"CPU time, over its wall time); above {LOAD_LIMIT:g} core a measurement is noisy and is "
        f"taken once more (the quieter kept, marked rerun). Here {reruns} of {len(sides)} "
        f"measurements were taken again, and {loud} stayed noisy"
        + (": their rows say so, and their times are not this code's alone." if loud else ".")
    )


FORBIDS_TEXT = (
    "'The triad forbids it' (the explicit-lumped step's targets): at each size that misses the "
    "target, a step at its memory-bandwidth limit (its bytes read once at the triad measured "
    "beside it: the bandwidth table below) would miss it too. Ours/peer: 0.7 x the peer's step "
    "is shorter than our step's own limit there (its bytes at the triad sampled between its "
    "steps). The 2-rank speed-up: the 2-rank triad was less than 1.7 x the 1-rank one; a step "
    "at its limit on 1 and on 2 ranks moves the same bytes, so it speeds up by the triads' ratio."
)


def write_report(
    records: list[dict],
    probes: list[dict],
    paper: dict[str, float | None],
    mode: str,
    wall: float,
    out: Path,
    newton: Sequence[dict] = (),
    paths: dict | None = None,
) -> None:
    """Write out/performance.md (it shows performance.png beside it); `paths`: the user's
    paths timed in the same run (paths.measure_into's result), or None (a quick run)."""
    sizes = {b: [r["size"] for r in records if r["benchmark"] == b] for b in SWEPT}
    ran = sizes_ran(records)
    probe_text = ", ".join(
        f"{p['case']} {p['ranks']}r n={p['n']}: "
        + (fmt(p["step_s"] / p["h"]) if p.get("step_s") else "failed")
        for p in probes
    )
    budget = BUDGET[mode]
    parts = [
        "# Performance",
        "",
        f"`tissuebench bench{' --quick' if mode == 'quick' else ''}`: {mode} mode, {wall:.0f} s "
        f"wall. Machine: {machine_description()}. Every worker process ran with "
        f"{', '.join(THREAD_VARS)} = 1 (one BLAS/OpenMP thread per MPI rank); the 2-rank column "
        "ran under `mpiexec -n 2`. The machine is shared: timings are noisy, and every ratio "
        "below comes from measurements taken in this one run.",
        "",
        f"Sizes: rod n = {sizes['rod']}; block N = {sizes['block']} (the dofs closest to the "
        f"rod's). Per step: median of steps {WARMUP[STEPS] + 1}..{STEPS} of {STEPS} (or, where "
        f"{STEPS} steps would exceed the case's budget, of steps {WARMUP[SHORT] + 1}..{SHORT} of "
        f"{SHORT}, without the displacement check). Setup: everything before "
        "the first step (step matrix, factorisation or preconditioner, initial acceleration). "
        f"Explicit schemes run at {SAFETY} x their critical step 2/omega_max (at most 1/30 s; "
        "omega_max by SLEPc as in solvers/stability.py), the others at h = 1/30 s. Peak memory: "
        "the peak resident set during that case, summed over ranks (the whole process: mesh, "
        "matrices and all).",
        "",
        "Peer: scikit-fem assembly (2x2(x2) Gauss points), SciPy CSR; direct = SuperLU (splu, "
        "MMD_AT_PLUS_A, symmetric mode) or MKL PARDISO (pypardiso, SPD Cholesky, solve phase "
        "called directly), iterative = SciPy CG + pyamg smoothed aggregation with rigid-body "
        "modes, relative residual 1e-12, warm start. Ours: the defaults of `tissuebench run` "
        "(matrix-vector products by the block-CSR loop of solvers/blockcsr.py, compiled here with "
        "-O3 -march=native; factorisations, solves and preconditioners by the wheel's PETSc and "
        "MUMPS, built -O2 for a generic x86-64). "
        "'u diff': relative difference of all nodal displacements after "
        f"{STEPS} steps, nodes matched by coordinates (peer against ours on 1 rank; "
        f"direct solvers must agree to {DIRECT_TOL:g}).",
        "",
        "## Targets",
        "",
        markdown_table(*targets(records, probes, paper, newton)),
        "",
        FORBIDS_TEXT,
        "",
        *paths_section(paths),
        "## Real-time capacity (rod)",
        "",
        "The largest rod mesh measured whose time per step is at most its step h (one simulated "
        "second in at most one wall second); 'wall/simulated' is step time / h there. For "
        + ", ".join(f"{a} {s}" if s != "-" else a for a, s in CAPACITY_CASES)
        + " (the cases with a target), the rod size n is also "
        "bisected between the sweep's last size in real time and the next one, with runs of "
        f"{SHORT} steps: " + (probe_text or "no probe was needed") + ".",
        "",
        markdown_table(*capacity(records, probes)),
        "",
        "## Elastic models (SPEC 8)",
        "",
        "### The explicit-lumped step with a nonlinear model or a remedy",
        "",
        MODEL_STEP_TEXT,
        "",
        load_text(records),
        "",
        markdown_table(*model_step_rows(records)),
        "",
        "### Newton iterations per implicit step at the paper's loads",
        "",
        "`implicit` with each nonlinear model on each benchmark's default material and mesh "
        "(block MP1 N = 20 with a point needle, rod MP3 n = 3), load scale s = 1, h = 1/30 s "
        "to T = 10 s, 1 rank. Newton as SPEC 8 (PETSc SNES newtonls with backtracking, "
        "relative residual 1e-10, MUMPS LU of the Jacobian at every iteration). Mean and max "
        "over the steps that converged: a run that diverges (Newton fails, or some J <= 0 at a "
        "quadrature point) stops at that step, and its mean covers the steps before. "
        f"Target: a mean of at most {NEWTON_LIMIT:g}.",
        "",
        markdown_table(*newton_rows(newton)),
        "",
        "### Real-time capacity with a nonlinear model (rod)",
        "",
        "As in the real-time capacity section above (step time <= h, h = the linear "
        "scheme's stable step, at most 1/30 s); the size of "
        f"{MODEL_CASES[0][0]} is also bisected. Target: >= {MODEL_REAL_TIME_DOFS:.0e} dofs "
        "on 1 or 2 ranks.",
        "",
        markdown_table(*capacity(records, probes, MODEL_CASES)),
        "",
        "## Explicit-lumped step against the memory-bandwidth limit",
        "",
        "limit = bytes / triad bandwidth; bytes (MiB moved, and per dof) = the stiffness matrix "
        "as the step reads it (the compiled block-CSR loop of solvers/blockcsr.py: gdim x gdim "
        "blocks of values, one 4-byte column index per block, row starts) + 9 vectors (u, f, "
        "1 / S, alpha M_L, v and a read; v, a and the next step's u written: the step is one "
        "pass, solvers/explicit_lumped.py), a lower bound for any implementation with this "
        "storage. step GB/s = bytes / step time, the bandwidth the step achieved, beside the "
        "triad's. Where a row gives the triad's spread, the triad was sampled between the "
        "steps (before the first and after every 5th, each sample the best of 3) and the limit "
        "uses the median of these samples: step and triad are then measured under the same "
        "conditions, which a shared machine's bandwidth, swinging within minutes, would not "
        "otherwise give. Where it gives none ('-'), the triad is the worker's one, taken before "
        "its cases. The peer is held against its CSR bytes and its own triad samples where it "
        "has them (else ours' 1-rank triad); "
        "ours/peer at equal triad = (our step x our triad) / (the peer's step x its triad), the "
        "ratio the two would have at one bandwidth.",
        "",
        load_text(records),
        "",
        markdown_table(*bandwidth_rows(records)),
        "",
        "## Steps: ours against the peer, 1 rank against 2",
        "",
        "The peer column is its fastest solver of the same kind (direct: PARDISO or SuperLU; "
        "cg and gamg: pyamg).",
        "",
        markdown_table(*step_rows(records)),
        "",
        "## Assembly of K and M",
        "",
        markdown_table(*assembly_rows(records)),
        "",
        "## Every peer solver",
        "",
        markdown_table(*extra_peer_rows(records)),
        "",
        "## Which sizes ran",
        "",
        "A case stops at the first size whose predicted cost exceeds its budget "
        f"({budget['main']:.0f} s for the targets' cases, {budget['iterative']:.0f} s for "
        f"the implicit step's iterative solvers, {budget['other']:.0f} s for the others; the "
        "peer's pyamg runs, if only for a short run, wherever one of our iterative solvers ran); "
        f"the peer stops when its assembly would exceed {budget['assembly']:.0f} s. "
        f"Sizes marked * ran {SHORT} steps instead of {STEPS}.",
        "",
        markdown_table(
            ["bench", "side", "case", "sizes"],
            [[b, s, k, ", ".join(map(str, v))] for (b, s, k), v in sorted(ran.items())],
        ),
        "",
    ]
    errors = failures(records)
    if errors:
        parts += ["## Failures", ""] + errors + [""]
    parts += ["![time per step](performance.png)", ""]
    write_owned(out / "performance.md", lambda tmp: tmp.write_text("\n".join(parts)))


def write_explicit_report(records: list[dict], mode: str, wall: float, out: Path) -> None:
    """Write out/performance-explicit.md: `tissuebench bench --only explicit-models`, the
    explicit-lumped step with each model or remedy against the linear one, 1 rank."""
    sizes = {b: [r["size"] for r in records if r["benchmark"] == b] for b in SWEPT}
    header = ["target", "sizes", "measured (worst)", "target", "status"]
    parts = [
        "# Explicit steps with a model or a remedy",
        "",
        f"`tissuebench bench --only explicit-models{' --quick' if mode == 'quick' else ''}`: "
        f"{mode} mode, {wall:.0f} s wall. Machine: {machine_description()}. One worker process "
        f"per size, 1 rank, {', '.join(THREAD_VARS)} = 1. The machine is shared: timings are "
        "noisy, so the cases of a size run side by side in their worker "
        "(workflows/bench/workers.py explicit_worker): every integrator is built and started, "
        f"then in each of {ROUNDS} rounds every case takes {BLOCK} steps in a row, the last "
        f"{BLOCK - BLOCK_WARM} timed (the first {BLOCK_WARM} bring its own data back into the "
        "caches); a change of load during the run weighs on every case alike.",
        "",
        f"Sizes: rod n = {sizes['rod']}; block N = {sizes['block']} (the dofs closest to the "
        f"rod's). Per step: the median of a case's {ROUNDS * (BLOCK - BLOCK_WARM)} timed steps. "
        "A case that diverges (an inverted element: the block's point needle at the linear "
        "scheme's step) keeps the median of its timed steps before (see Failures).",
        "",
        "## Targets",
        "",
        markdown_table(
            header, model_step_targets(records) + model_step_targets(records, "cpu_step_s")
        ),
        "",
        "## Explicit step with a model or a remedy / the linear explicit-lumped step",
        "",
        MODEL_STEP_TEXT,
        "",
        load_text(records),
        "",
        markdown_table(*model_step_rows(records)),
        "",
        "### The same in CPU time",
        "",
        "The CPU time of each timed step (time.process_time), median: the step's cost without "
        "the time the process waited for a core. On a shared machine the wall times above "
        "include that wait; both sides of each ratio ran in the same rounds.",
        "",
        markdown_table(*model_cpu_rows(records)),
        "",
    ]
    errors = failures(records)
    if errors:
        parts += ["## Failures", ""] + errors + [""]
    write_owned(out / "performance-explicit.md", lambda tmp: tmp.write_text("\n".join(parts)))
