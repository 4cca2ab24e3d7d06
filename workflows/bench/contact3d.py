"""`tissuebench bench --only contact-3d` (SPEC 13): the explicit-lumped step of the cylinder with
the capsule in contact (the penalty's force facet by facet over the top face, beside K u or the
compiled element loop: solvers/edge_penalty.py FacetPenalty) against the same step of the same
cylinder with no tool, measured side by side in one process (bench/contact.py's rounds), for the
linear and the neo-Hookean model, at a step h = H_STEP (the cost of a step does not depend on
it). Step times in s; the ratio is contact / free (SPEC 13's issue aims at most 1.3 at 1e5
dofs)."""

from __future__ import annotations

from pathlib import Path

from tissuebench.workflows.bench.contact import MODELS, side_by_side
from tissuebench.workflows.bench.tables import text_table

SIZES = {"full": (8, 16), "quick": (4,)}  # n: 16 is about 1e5 dofs on the O-grid
H_STEP = 1e-4  # s


def measure(mode: str, log=print) -> list[dict]:
    """One record per size and model: n, dofs, model, the free and contact step times (s)
    and their ratio."""
    from tissuebench.meshes import get_benchmark
    from tissuebench.solvers.system import System

    records = []
    for size in SIZES[mode]:
        free = get_benchmark("cylinder", mesh_size=size)
        free.contact = None  # the same mesh and constraints, no tool
        systems = {
            "free": System(free),
            "contact": System(get_benchmark("cylinder", mesh_size=size)),
        }
        for model in MODELS:
            medians = side_by_side(systems, H_STEP, model)
            record = {
                "n": size,
                "dofs": systems["contact"].num_dofs(),
                "model": model,
                "free_step_s": medians["free"],
                "contact_step_s": medians["contact"],
                "ratio": medians["contact"] / medians["free"],
            }
            records.append(record)
            log(
                f"n = {size:3d} {model:12s} free {medians['free'] * 1e3:8.3f} ms  contact "
                f"{medians['contact'] * 1e3:8.3f} ms  ratio {record['ratio']:5.2f}"
            )
    return records


def rows(records: list[dict]) -> list[list[str]]:
    return [
        [
            str(r["n"]),
            f"{r['dofs']:,}",
            r["model"],
            f"{r['free_step_s'] * 1e3:.3f}",
            f"{r['contact_step_s'] * 1e3:.3f}",
            f"{r['ratio']:.2f}",
        ]
        for r in records
    ]


HEADER = ["n", "dofs", "model", "free step (ms)", "contact step (ms)", "contact / free"]


def table(records: list[dict]) -> str:
    """The records as a text table."""
    return text_table(HEADER, rows(records))


def report(records: list[dict], mode: str, wall: float, machine: str) -> str:
    """results/performance-contact-3d.md."""
    lines = "\n".join("| " + " | ".join(r) + " |" for r in rows(records))
    return (
        "# The explicit step with the 3D tool (SPEC 13)\n\n"
        f"Written by `tissuebench bench --only contact-3d` ({mode} mode, {wall:.0f} s, one "
        f"process; {machine}). The explicit-lumped step of the cylinder with the capsule in "
        "contact (the penalty's force facet by facet over the top face beside the compiled "
        "element loop) against the same cylinder's step with no tool, side by side (see "
        "workflows/bench/contact3d.py).\n\n"
        "| " + " | ".join(HEADER) + " |\n|---:|---:|---|---:|---:|---:|\n"
        f"{lines}\n"
    )


def write(out: Path, records: list[dict], mode: str, wall: float) -> None:
    """out/performance-contact-3d.md and .json."""
    import json

    from tissuebench.workflows.bench.machine import machine_description
    from tissuebench.workflows.io.output import write_owned

    machine = machine_description()
    data = {"mode": mode, "wall_s": wall, "machine": machine, "records": records}
    write_owned(out / "performance-contact-3d.json", lambda tmp: tmp.write_text(json.dumps(data)))
    text = report(records, mode, wall, machine)
    write_owned(out / "performance-contact-3d.md", lambda tmp: tmp.write_text(text))
