"""The tables of `tissuebench bench` (as markdown and as text) and its SPEC 8 targets, from the
records of workflows/bench/measure.py (or the same records loaded from performance.json).

Units: seconds, bytes (MiB in the tables), degrees of freedom.
"""

import math
from collections.abc import Iterable, Sequence
from typing import cast

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

# SPEC 8 targets: a nonlinear model's (or a SPEC 11 remedy's) explicit-lumped step costs at
# most MODEL_STEP_LIMIT x the linear one at >= MODEL_STEP_DOFS dofs (rod and block, issue 32);
# Newton needs at most NEWTON_LIMIT iterations per implicit step on average at the paper's
# loads; explicit-lumped+neo-hookean runs in real time up to at least MODEL_REAL_TIME_DOFS dofs.
MODEL_STEP_LIMIT = 4.0
MODEL_STEP_DOFS = 1e5
NEWTON_LIMIT = 4.0
MODEL_REAL_TIME_DOFS = 3e4

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


def bandwidth_rows(records: list[dict]) -> Table:
    """The explicit-lumped step against its memory-bandwidth limit (bytes / triad bandwidth)."""
    rows = []
    case = ("explicit-lumped", "-")
    for rec in records:
        o1, o2, p = rec.get("ours1", {}), rec.get("ours2", {}), rec.get("peer", {})
        s1, s2, sp = (get(rec, side, case, "step_s") for side in ("ours1", "ours2", "peer"))
        if s1 is None:
            continue
        b = get(rec, "ours1", case, "bytes")
        lim1 = b / o1["triad_Bps"]
        lim2 = b / o2["triad_Bps"] if o2.get("triad_Bps") else None
        limp = (
            p["explicit_lumped_bytes"] / o1["triad_Bps"] if p.get("explicit_lumped_bytes") else None
        )
        rows.append(
            [
                rec["benchmark"],
                rec["size"],
                rec["dofs"],
                get(rec, "ours1", case, "matrix_type"),
                b / rec["dofs"],
                o1["triad_Bps"] / 1e9,
                o2.get("triad_Bps", 0) / 1e9,
                lim1,
                s1,
                ratio(s1, lim1),
                s2,
                ratio(s2, lim2),
                sp,
                ratio(sp, limp),
            ]
        )
    return [
        "bench",
        "size",
        "dofs",
        "matrix",
        "bytes/dof",
        "triad 1r GB/s",
        "triad 2r GB/s",
        "limit 1r s",
        "step 1r s",
        "meas/limit 1r",
        "step 2r s",
        "meas/limit 2r",
        "peer step s",
        "peer meas/limit (CSR)",
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
        rows.append(row)
    header = ["bench", "size", "dofs", "h s", "linear 1r s"]
    for c in MODEL_CASES:
        header += [f"{model_name(c)} 1r s", f"{model_name(c)}/linear 1r"]
    if two:
        header += ["linear 2r s"] + [f"{model_name(c)}/linear 2r" for c in MODEL_CASES]
        header += ["u diff 2r vs 1r (models)"]
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


def model_step_targets(records: list[dict], field: str = "step_s") -> list[list]:
    """Target rows: for each case of MODEL_CASES, the largest ratio of its explicit-lumped step
    to the linear one (1 rank, same worker, same h) over the sizes with >= MODEL_STEP_DOFS
    dofs, rod and block, against MODEL_STEP_LIMIT; of the steps' `field` (wall time, or
    cpu_step_s)."""
    el = ("explicit-lumped", "-")
    big = [r for r in records if r["dofs"] >= MODEL_STEP_DOFS]
    rows = []
    for case in MODEL_CASES:
        ran = [r for r in big if get(r, "ours1", case, field) and get(r, "ours1", el, field)]
        values = [ratio(get(r, "ours1", case, field), get(r, "ours1", el, field)) for r in ran]
        values = [v for v in values if v is not None and math.isfinite(v)]
        where = f"dofs >= {MODEL_STEP_DOFS:.0e}: " + (
            ", ".join(f"{r['benchmark']} {r['size']}" for r in ran) or "none ran"
        )
        cpu = " (CPU time)" if field == "cpu_step_s" else ""
        name = f"{case[0]} step / explicit-lumped step (1 rank){cpu}"
        if not values:
            rows.append([name, where, "not measured", fmt(MODEL_STEP_LIMIT), "not measured"])
            continue
        worst = max(values)
        met = "met" if worst <= MODEL_STEP_LIMIT else "NOT met"
        rows.append([name, where, fmt(worst), fmt(MODEL_STEP_LIMIT), met])
    return rows


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


def targets(
    records: list[dict],
    probes: Iterable[dict] = (),
    paper: dict[str, float | None] | None = None,
    newton: Iterable[dict] = (),
) -> Table:
    """The issue's targets, each with the measured worst case over the sizes it covers."""
    probes = list(probes)
    rows = []

    def worst(values, larger_is_worse=True):
        values = [v for v in values if v is not None and math.isfinite(v)]
        if not values:
            return None
        return max(values) if larger_is_worse else min(values)

    def check(name, value, limit, larger_is_worse=True, where=""):
        if value is None:
            rows.append([name, where, "not measured", fmt(limit), "not measured"])
            return
        met = value <= limit if larger_is_worse else value >= limit
        rows.append([name, where, fmt(value), fmt(limit), "met" if met else "NOT met"])

    def names(recs):
        return ", ".join(f"{r['benchmark']} {r['size']}" for r in recs)

    el = ("explicit-lumped", "-")
    big = [r for r in records if r["dofs"] >= 2e5]
    meas_lim = []
    for rec in big:
        s, o = get(rec, "ours1", el, "step_s"), rec.get("ours1", {})
        if s is not None:
            meas_lim.append(s / (get(rec, "ours1", el, "bytes") / o["triad_Bps"]))
    where = "dofs >= 2e5: " + names(r for r in big if get(r, "ours1", el, "step_s"))
    check("explicit-lumped step: measured/limit (1 rank)", worst(meas_lim), 1.3, where=where)
    check(
        "explicit-lumped step: ours/peer",
        worst(ratio(get(r, "ours1", el, "step_s"), get(r, "peer", el, "step_s")) for r in big),
        0.7,
        where=where,
    )
    imp = ("implicit", "direct")
    mid = [
        r
        for r in records
        if r["dofs"] >= 1e5 and get(r, "ours1", imp, "step_s") and best_peer_direct(r, "implicit")
    ]
    where = "dofs >= 1e5: " + names(mid)
    check(
        "implicit direct step: ours/best peer direct",
        worst(
            ratio(
                get(r, "ours1", imp, "step_s"),
                cast(tuple[str, dict], best_peer_direct(r, "implicit"))[1]["step_s"],  # mid's
            )
            for r in mid
        ),
        0.7,
        where=where,
    )

    def best_peer_setup(r):
        return min(
            get(r, "peer", ("implicit", s), "setup_s") or math.inf for s in ("pardiso", "superlu")
        )

    check(
        "implicit direct setup: ours/best peer direct",
        worst(ratio(get(r, "ours1", imp, "setup_s"), best_peer_setup(r)) for r in mid),
        1.0,
        where=where,
    )
    pyamg = ("implicit", "pyamg")
    for cg in (("implicit", s) for s in OURS_ITERATIVE):
        largest = [
            r
            for r in records
            if r["dofs"] >= 6e5
            and get(r, "ours1", cg, "step_s")
            and get(r, "peer", pyamg, "step_s")
        ]
        where = names(largest) or "7e5 dofs not reached by both"
        check(
            f"implicit {cg[1]} step: ours/pyamg at 7e5 dofs",
            worst(
                ratio(get(r, "ours1", cg, "step_s"), get(r, "peer", pyamg, "step_s"))
                for r in largest
            ),
            0.8,
            where=where,
        )
    for case in OURS_CASES:
        sp = [
            ratio(get(r, "ours1", case, "step_s"), get(r, "ours2", case, "step_s"))
            for r in records
            if r["dofs"] >= 1e5
        ]
        check(
            f"2 ranks vs 1: {case[0]} {case[1]} step speed-up",
            worst(sp, larger_is_worse=False),
            1.7,
            larger_is_worse=False,
            where="dofs >= 1e5",
        )
    _, cap = capacity(records, probes)
    for row in cap:
        if row[0] in ("explicit-lumped", "implicit"):
            need = 1e5 if row[0] == "explicit-lumped" else 3e4
            dofs = [d for d in (row[3], row[6]) if d is not None]
            value = max(dofs) if dofs else None
            rows.append(
                [
                    f"real time: {row[0]} {row[1]} (best of 1, 2 ranks)",
                    "rod",
                    fmt(value),
                    fmt(need),
                    "met" if value is not None and value >= need else "NOT met",
                ]
            )
    # SPEC 8: the elastic models (and SPEC 11's remedies)
    rows += model_step_targets(records)
    for model in NEWTON_MODELS:
        means, where = [], []
        for run in newton:
            its = newton_case(run, model).get("newton_iterations")
            if its:
                means.append(sum(its) / len(its))
                stopped = "" if newton_status(run, model) == "ok" else ", diverged"
                where.append(
                    f"{run['benchmark']} {run['material']} {fmt(means[-1])} "
                    f"({len(its)}/{run['steps']} steps{stopped})"
                )
        check(
            f"implicit+{model}: Newton iterations per step, mean (paper loads, s = 1)",
            worst(means),
            NEWTON_LIMIT,
            where="; ".join(where),
        )
    for row in capacity(records, probes, MODEL_CASES[:1])[1]:
        dofs = [d for d in (row[3], row[6]) if d is not None]
        value = max(dofs) if dofs else None
        if row[2] == row[5] == "not run":
            status = "not measured"
        else:
            status = "met" if value is not None and value >= MODEL_REAL_TIME_DOFS else "NOT met"
        rows.append(
            [
                f"real time: {row[0]} (best of 1, 2 ranks)",
                "rod",
                fmt(value) if value is not None else "none",
                fmt(MODEL_REAL_TIME_DOFS),
                status,
            ]
        )
    if paper:  # serial and 2 ranks, warm form cache: the faster of the two is what a user gets
        warm = [t for name, t in paper.items() if name != "serial, cold" and t is not None]
        check(
            "tissuebench paper, wall s (best of serial, 2 ranks; warm cache)",
            min(warm) if warm else None,
            60.0,
            where=", ".join(f"{name} {fmt(t)}" for name, t in paper.items()),
        )
    return ["target", "sizes", "measured (worst)", "target", "status"], rows


def summary_tables(
    records: list[dict],
    probes: list[dict],
    paper: dict[str, float | None],
    newton: Sequence[dict] = (),
) -> list[tuple[str, Table]]:
    """(title, table) of the tables the command prints at the end."""
    return [
        ("targets", targets(records, probes, paper, newton)),
        ("explicit-lumped vs bandwidth", bandwidth_rows(records)),
        ("steps", step_rows(records)),
        ("assembly", assembly_rows(records)),
        ("real-time capacity (rod)", capacity(records, probes)),
        ("elastic models: explicit-lumped step against the linear one", model_step_rows(records)),
        ("elastic models: Newton iterations per implicit step", newton_rows(newton)),
        ("elastic models: real-time capacity (rod)", capacity(records, probes, MODEL_CASES)),
    ]
