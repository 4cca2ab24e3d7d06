"""The tables of `tissuebench bench` (as markdown and as text), from the records of
workflows/bench/measure.py (or the same records loaded from performance.json); its SPEC 8
targets are targets.py's.

Units: seconds, bytes (MiB in the tables), degrees of freedom.
"""

import math
from collections.abc import Iterable

from tissuebench.workflows.bench.machine import LOAD_LIMIT, noisy
from tissuebench.workflows.bench.measure import (
    MODEL_CASES,
    NEWTON_MODELS,
    OURS_CASES,
    OURS_ITERATIVE,
    case_scheme,
    get,
    key,
    rod_points,
    split_case_label,
)

Table = tuple[list[str], list[list]]  # header, rows

# --- tables -------------------------------------------------------------------------------------


def fmt(x: float | str | None, digits: int = 3) -> str:
    """A table cell: '-' for None and non-finite numbers, 3 significant digits."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if isinstance(x, str):
        return x
    if x == 0:
        return "0"
    if abs(x) >= 1000 or abs(x) < 1e-3:
        return f"{x:.2e}"
    return f"{x:.{digits}g}"


def ratio(a: float | None, b: float | None) -> float | None:
    """a / b, or None if either is missing or b is not positive."""
    return a / b if a is not None and b is not None and b > 0 else None


def best_peer_direct(rec: dict, algorithm: str) -> tuple[str, dict] | None:
    """(solver, record) of the peer's fastest direct solver per step for `algorithm`."""
    best = None
    for solver in ("pardiso", "superlu"):
        r = rec.get("peer", {}).get("cases", {}).get(key((algorithm, solver)))
        if r and "step_s" in r and (best is None or r["step_s"] < best[1]["step_s"]):
            best = (solver, r)
    return best


def peer_for(rec: dict, case: tuple[str, str]) -> tuple[str, str]:
    """The peer case compared with our `case`: the same step, its best solver of that kind."""
    algorithm, solver = case
    if solver == "-":
        return ("explicit-lumped", "-")
    if solver in OURS_ITERATIVE:
        return (algorithm, "pyamg")
    best = best_peer_direct(rec, algorithm)
    return (algorithm, best[0]) if best else (algorithm, "superlu")


def markdown_table(header: list[str], rows: list[list]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def text_table(header: list[str], rows: list[list]) -> str:
    cells = [header] + [[fmt(c) for c in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells)


def assembly_rows(records: list[dict]) -> Table:
    """Assembly times of K, M and the block-CSR copies: ours on 1 and 2 ranks, the peer."""
    rows = []
    for rec in records:
        o1, o2, p = (rec.get(s, {}).get("assembly_s") for s in ("ours1", "ours2", "peer"))
        t1 = sum(o1.values()) if o1 else None
        t2 = sum(o2.values()) if o2 else None
        tp = sum(p.values()) if p else None
        rows.append(
            [
                rec["benchmark"],
                rec["size"],
                rec["dofs"],
                o1 and o1["K"],
                o1 and o1["M"],
                o1 and o1.get("block CSR"),
                p and p["K"],
                p and p["M"],
                ratio(t1, tp),
                t2,
                ratio(t1, t2),
            ]
        )
    return [
        "bench",
        "size",
        "dofs",
        "K ours s",
        "M ours s",
        "block CSR copies s",
        "K peer s",
        "M peer s",
        "ours/peer (all)",
        "all 2r s",
        "1r/2r",
    ], rows


def step_rows(records: list[dict]) -> Table:
    """Setup, step and peak memory of every ours case against its peer and on 2 ranks."""
    rows = []
    for rec in records:
        for case in OURS_CASES:
            s1 = get(rec, "ours1", case, "step_s")
            if s1 is None:
                continue
            pc = peer_for(rec, case)
            sp = get(rec, "peer", pc, "step_s")
            s2 = get(rec, "ours2", case, "step_s")
            diff = rec.get("diff_peer", {}).get(key(pc))
            rows.append(
                [
                    rec["benchmark"],
                    rec["size"],
                    rec["dofs"],
                    case[0],
                    f"{case[1]}|{pc[1]}" if case[1] != "-" else "-",
                    get(rec, "ours1", case, "setup_s"),
                    get(rec, "peer", pc, "setup_s"),
                    ratio(get(rec, "ours1", case, "setup_s"), get(rec, "peer", pc, "setup_s")),
                    s1,
                    s2,
                    sp,
                    ratio(s1, sp),
                    ratio(s1, s2),
                    (get(rec, "ours1", case, "peak_bytes") or 0) / 2**20,
                    (get(rec, "ours2", case, "peak_bytes") or 0) / 2**20,
                    (get(rec, "peer", pc, "peak_bytes") or 0) / 2**20 if sp else None,
                    diff,
                ]
            )
    return [
        "bench",
        "size",
        "dofs",
        "algorithm",
        "solver ours|peer",
        "setup ours s",
        "setup peer s",
        "ours/peer",
        "step 1r s",
        "step 2r s",
        "step peer s",
        "ours/peer",
        "1r/2r",
        "peak 1r MiB",
        "peak 2r MiB",
        "peak peer MiB",
        "u diff",
    ], rows


def extra_peer_rows(records: list[dict]) -> Table:
    """Every peer solver at every size (SuperLU and PARDISO both), with CG iterations."""
    rows = []
    for rec in records:
        for k, r in rec.get("peer", {}).get("cases", {}).items():
            if "step_s" in r:
                rows.append(
                    [
                        rec["benchmark"],
                        rec["size"],
                        rec["dofs"],
                        k,
                        r["setup_s"],
                        r["step_s"],
                        r.get("iterations"),
                        r["peak_bytes"] / 2**20,
                        rec.get("diff_peer", {}).get(k),
                    ]
                )
    return [
        "bench",
        "size",
        "dofs",
        "peer case",
        "setup s",
        "step s",
        "CG its",
        "peak MiB",
        "u diff vs ours",
    ], rows


def load_cell(side: dict) -> str:
    """A worker's load in a table cell: the cores other processes kept busy during it
    (machine.LoadMeter), then "> LIMIT" where that exceeded machine.LOAD_LIMIT (noisy) and
    "rerun" where it was measured twice (measure.run_quiet: the quieter kept); "-" unknown."""
    load = side.get("load")
    if not load or not math.isfinite(load.get("others_cores", math.nan)):
        return "-"
    cell = f"{load['others_cores']:.2f}"
    if noisy(load):
        cell += f" (> {LOAD_LIMIT:g}: noisy)"
    if side.get("reruns"):
        cell += " rerun"
    return cell


def step_triad(rec: dict, side: str, case: tuple[str, str] = ("explicit-lumped", "-")) -> float:
    """The triad bandwidth (bytes/s) a side's step is held against: the median of the samples
    taken between its steps (triad.timed_steps) where it has them, else its worker's one
    triad (the peer's: the 1-rank worker's)."""
    own = get(rec, side, case, "triad_Bps")
    if own:
        return own
    return rec.get("ours1" if side == "peer" else side, {}).get("triad_Bps") or math.nan


def spread(rec: dict, side: str, case: tuple[str, str] = ("explicit-lumped", "-")) -> str:
    """The lowest and highest triad sample between a side's steps, GB/s ("-" without them)."""
    samples = get(rec, side, case, "triad_samples_Bps")
    return f"{min(samples) / 1e9:.1f}-{max(samples) / 1e9:.1f}" if samples else "-"


def bandwidth_rows(records: list[dict]) -> Table:
    """The explicit-lumped step against its memory-bandwidth limit (bytes / triad bandwidth,
    the triad sampled between the steps: step_triad): per size its bytes, the bandwidth it
    achieved (bytes / step time) next to the triad's and the triad's spread, ours against the
    peer both as measured and at equal bandwidth (each step times its own triad), and the
    load of other processes during each side's measurement (load_cell)."""
    rows = []
    case = ("explicit-lumped", "-")
    for rec in records:
        o1, o2, p = rec.get("ours1", {}), rec.get("ours2", {}), rec.get("peer", {})
        s1, s2, sp = (get(rec, side, case, "step_s") for side in ("ours1", "ours2", "peer"))
        if s1 is None:
            continue
        b = get(rec, "ours1", case, "bytes")
        t1, tp = step_triad(rec, "ours1"), step_triad(rec, "peer")
        t2 = step_triad(rec, "ours2") if o2 else math.nan
        lim1 = b / t1
        lim2 = b / t2 if math.isfinite(t2) else None
        limp = p["explicit_lumped_bytes"] / tp if p.get("explicit_lumped_bytes") else None
        rows.append(
            [
                rec["benchmark"],
                rec["size"],
                rec["dofs"],
                get(rec, "ours1", case, "matrix_type"),
                b / 2**20,
                b / rec["dofs"],
                t1 / 1e9,
                spread(rec, "ours1"),
                b / s1 / 1e9,
                t2 / 1e9 if math.isfinite(t2) else 0,
                b / s2 / 1e9 if s2 else None,
                lim1,
                s1,
                ratio(s1, lim1),
                s2,
                ratio(s2, lim2),
                sp,
                ratio(sp, limp),
                ratio(s1, sp),
                ratio(s1 * t1, sp * tp) if sp and math.isfinite(tp) else None,
                load_cell(o1),
                load_cell(o2) if o2 else "-",
            ]
        )
    return [
        "bench",
        "size",
        "dofs",
        "matrix",
        "MiB moved",
        "bytes/dof",
        "triad 1r GB/s",
        "triad 1r spread GB/s",
        "step 1r GB/s",
        "triad 2r GB/s",
        "step 2r GB/s",
        "limit 1r s",
        "step 1r s",
        "meas/limit 1r",
        "step 2r s",
        "meas/limit 2r",
        "peer step s",
        "peer meas/limit (CSR)",
        "ours/peer",
        "ours/peer at equal triad",
        "others' load 1r (cores)",
        "others' load 2r (cores)",
    ], rows


def capacity(
    records: list[dict], probes: Iterable[dict] = (), cases: Iterable[tuple] = OURS_CASES
) -> Table:
    """Per case (ours, by default OURS_CASES) and rank count: the largest rod size with step
    time <= h (one simulated second in at most one wall second), over the sweep and the
    capacity probes, and whether the largest size measured still passed."""
    probes = list(probes)
    rows = []
    for case in cases:
        row = [case[0], case[1]]
        for side in ("ours1", "ours2"):
            points = rod_points(records, probes, case, side)
            passing = [p for p in points if p[2] <= p[3]]
            if not passing:
                row += ["none" if points else "not run", None, None]
                continue
            n, dofs, step, h = passing[-1]
            more = " (largest run)" if passing[-1] is points[-1] else ""
            row += [f"n={n}{more}", dofs, step / h]
        rows.append(row)
    return [
        "algorithm",
        "solver",
        "1 rank: largest rod",
        "dofs",
        "wall/simulated",
        "2 ranks: largest rod",
        "dofs",
        "wall/simulated",
    ], rows


def model_name(case: tuple) -> str:
    """The model of a case, with its SPEC 11 scheme if any: 'neo-hookean' of
    'explicit-lumped+neo-hookean', 'neo-hookean@mean-dilatation' (F-bar),
    'linear@mean-dilatation' (B-bar)."""
    scheme = case_scheme(case[0])
    model = split_case_label(case[0])[1]
    return model if scheme == "standard" else f"{model}@{scheme}"


def model_step_rows(records: list[dict]) -> Table:
    """The explicit-lumped step with each nonlinear model or remedy (MODEL_CASES) against the
    linear one of the same worker at the same h, on 1 rank and (where the records have them)
    2 ranks."""
    el = ("explicit-lumped", "-")
    two = any(get(rec, "ours2", el, "step_s") for rec in records)
    rows = []
    for rec in records:
        lin1, lin2 = get(rec, "ours1", el, "step_s"), get(rec, "ours2", el, "step_s")
        if lin1 is None or not any(get(rec, "ours1", c, "step_s") for c in MODEL_CASES):
            continue
        row = [rec["benchmark"], rec["size"], rec["dofs"], get(rec, "ours1", el, "h"), lin1]
        for c in MODEL_CASES:
            step = get(rec, "ours1", c, "step_s")
            row += [step, ratio(step, lin1)]
        if two:
            row += [lin2] + [ratio(get(rec, "ours2", c, "step_s"), lin2) for c in MODEL_CASES]
            diffs = [rec.get("diff_2ranks", {}).get(key(c)) for c in MODEL_CASES]
            diffs = [d for d in diffs if d is not None and math.isfinite(d)]
            row += [max(diffs) if diffs else None]
        row += [load_cell(rec.get("ours1", {}))]
        rows.append(row)
    header = ["bench", "size", "dofs", "h s", "linear 1r s"]
    for c in MODEL_CASES:
        header += [f"{model_name(c)} 1r s", f"{model_name(c)}/linear 1r"]
    if two:
        header += ["linear 2r s"] + [f"{model_name(c)}/linear 2r" for c in MODEL_CASES]
        header += ["u diff 2r vs 1r (models)"]
    header += ["others' load 1r (cores)"]
    return header, rows


def model_cpu_rows(records: list[dict]) -> Table:
    """As model_step_rows on 1 rank, with the CPU time of each step (the records of
    `bench --only explicit-models`: cpu_step_s) in place of its wall time."""
    el = ("explicit-lumped", "-")
    rows = []
    for rec in records:
        lin = get(rec, "ours1", el, "cpu_step_s")
        if lin is None:
            continue
        row = [rec["benchmark"], rec["size"], rec["dofs"], lin]
        for c in MODEL_CASES:
            step = get(rec, "ours1", c, "cpu_step_s")
            row += [step, ratio(step, lin)]
        rows.append(row)
    header = ["bench", "size", "dofs", "linear cpu s"]
    for c in MODEL_CASES:
        header += [f"{model_name(c)} cpu s", f"{model_name(c)}/linear cpu"]
    return header, rows


def newton_case(run: dict, model: str) -> dict:
    """The record of `implicit` with `model` in one run of newton_iterations ({} if none)."""
    return run.get("result", {}).get("cases", {}).get(key((f"implicit+{model}", "direct")), {})


def newton_status(run: dict, model: str) -> str:
    """'ok', or why and where the run stopped."""
    r = newton_case(run, model)
    if "error" in r:  # the message says where (t) and why
        return ("diverged: " if "diverged_t" in r else "failed: ") + r["error"][:80]
    if not r:
        return "not run: " + run.get("result", {}).get("error", "no result")[:80]
    return "ok"


def newton_rows(newton: Iterable[dict]) -> Table:
    """Newton iterations per implicit step of each nonlinear model at the paper's loads."""
    rows = []
    for run in newton:
        for model in NEWTON_MODELS:
            r = newton_case(run, model)
            its = r.get("newton_iterations") or []
            rows.append(
                [
                    run["benchmark"],
                    run["material"],
                    run["size"],
                    run.get("result", {}).get("dofs"),
                    f"implicit+{model}",
                    f"{len(its)}/{run['steps']}",
                    sum(its) / len(its) if its else None,
                    max(its) if its else None,
                    r.get("step_s"),
                    newton_status(run, model),
                ]
            )
    return [
        "bench",
        "material",
        "size",
        "dofs",
        "run",
        "steps converged",
        "Newton its mean",
        "max",
        "step s (median)",
        "status",
    ], rows
