"""`tissuebench bench --only contact` (SPEC 12): the explicit-lumped step with the needle as
contact against the same step with the needle glued (the block with w = 0.2 m), measured side
by side in one process, for the linear and the neo-Hookean model.

Both run at the contact case's stable step (its critical step counts the penalty, so it is
the smaller), on the same N x N grid. Every integrator is built and started first; then ROUNDS
rounds in which each takes BLOCK steps in a row, the last BLOCK - WARM of them timed, so that
a change of the machine's load weighs on both alike. Step times in s (the median of the timed
steps); the ratio is contact / glued.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from tissuebench.workflows.bench.tables import text_table

SIZES = {"full": (20, 80, 320), "quick": (10, 20)}
MODELS = ("linear", "neo-hookean")
ROUNDS, BLOCK, WARM = 5, 6, 1  # 30 steps: the glued neo-Hookean block inverts at N = 10 after 60


def side_by_side(systems: dict, step: float, model: str) -> dict[str, float]:
    """{name: the median explicit-lumped step time (s)} of each system's integrator at the step
    `step` (s) with `model`: all built and started first, then ROUNDS rounds in which each takes
    BLOCK steps in a row, the last BLOCK - WARM of them timed."""
    from tissuebench.solvers import get_integrator

    running = {}
    for name, system in systems.items():
        integrator = get_integrator("explicit-lumped", system, step, model=model)
        running[name] = (integrator, integrator.start())
    times: dict[str, list[float]] = {name: [] for name in running}
    for _ in range(ROUNDS):
        for name, (integrator, state) in running.items():
            for i in range(BLOCK):
                start = time.perf_counter()
                state = integrator.step(state)
                if i >= WARM:
                    times[name].append(time.perf_counter() - start)
            running[name] = (integrator, state)
    for integrator, _ in running.values():
        integrator.destroy()
    return {name: statistics.median(t) for name, t in times.items()}


def measure(mode: str, log=print) -> list[dict]:
    """One record per size and model: N, dofs, model, h (s), the glued and contact step
    times (s) and their ratio."""
    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers.stability import stability_limits
    from tissuebench.solvers.system import System

    records = []
    for size in SIZES[mode]:
        systems = {
            "glued": System(get_benchmark("block", mesh_size=size, needle_width=0.2)),
            "contact": System(get_benchmark("contact", mesh_size=size)),
        }
        h = stability_limits(systems["contact"], ["explicit-lumped"])["explicit-lumped"]
        step = 0.9 * h.critical_dt
        for model in MODELS:
            medians = side_by_side(systems, step, model)
            glued, contact = medians["glued"], medians["contact"]
            record = {
                "N": size,
                "dofs": systems["contact"].num_dofs(),
                "model": model,
                "h": step,
                "glued_step_s": glued,
                "contact_step_s": contact,
                "ratio": contact / glued,
            }
            records.append(record)
            log(
                f"N = {size:4d} {model:12s} glued {glued * 1e3:8.3f} ms  contact "
                f"{contact * 1e3:8.3f} ms  ratio {contact / glued:5.2f}"
            )
    return records


def table(records: list[dict]) -> str:
    """The records as a text table."""
    header = ["N", "dofs", "model", "glued step (ms)", "contact step (ms)", "contact / glued"]
    rows = [
        [
            str(r["N"]),
            f"{r['dofs']:,}",
            r["model"],
            f"{r['glued_step_s'] * 1e3:.3f}",
            f"{r['contact_step_s'] * 1e3:.3f}",
            f"{r['ratio']:.2f}",
        ]
        for r in records
    ]
    return text_table(header, rows)


def report(records: list[dict], mode: str, wall: float) -> str:
    """results/performance-contact.md."""
    rows = "\n".join(
        f"| {r['N']} | {r['dofs']:,} | {r['model']} | {r['glued_step_s'] * 1e3:.3f} | "
        f"{r['contact_step_s'] * 1e3:.3f} | {r['ratio']:.2f} |"
        for r in records
    )
    return (
        "# The explicit step with contact (SPEC 12)\n\n"
        f"Written by `tissuebench bench --only contact` ({mode} mode, {wall:.0f} s, one "
        "process). The explicit-lumped step of the block with the needle as contact (the "
        "penalty's force facet by facet beside K u or the compiled element loop) against the "
        "same step with the needle glued (w = 0.2 m), side by side at the contact case's "
        "stable step (see the module's docstring, workflows/bench/contact.py).\n\n"
        "| N | dofs | model | glued step (ms) | contact step (ms) | contact / glued |\n"
        "|---:|---:|---|---:|---:|---:|\n"
        f"{rows}\n"
    )


def write(out: Path, records: list[dict], mode: str, wall: float) -> None:
    """out/performance-contact.md and .json."""
    import json

    from tissuebench.workflows.io.output import write_owned

    data = {"mode": mode, "wall_s": wall, "records": records}
    write_owned(out / "performance-contact.json", lambda tmp: tmp.write_text(json.dumps(data)))
    write_owned(
        out / "performance-contact.md", lambda tmp: tmp.write_text(report(records, mode, wall))
    )
