"""Outside simulators run end to end and graded (`tissuebench external`, the leaderboard):
the benchmark is exported (workflows/io/exported.py), our reference runs beside it, each
variant of each simulator (workflows/simulators/) runs in a folder of its own, and its output
is graded by `compare`'s code (workflows/compare/grading.py) against the reference.

A simulator folder (one per `external` run; one per simulator and case in the leaderboard):
- `benchmark.json`: the export that every variant poses (schema tissuebench.benchmark);
- `reference.xdmf` (+ .h5): our reference's history (implicit, with the export's model);
- `VARIANT/`: compare's metrics.csv, metrics.png and summary.json of that variant, its
  simulator's own files in `VARIANT/work/`;
- `summary.json`: `kind` "external", the simulator, the case's inputs and `runs` {label:
  entry}, each entry a compare entry (status, steps, wall_time_s, metric max and mean) with
  the simulator, its version, the variant and its description, the mesh, dofs and timing.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType
from typing import cast

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.core.fingerprint import fingerprint
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.compare.posing import REFERENCE_FIELD, build, run_reference
from tissuebench.workflows.io.exported import Exported
from tissuebench.workflows.io.output import RunFolder, collective
from tissuebench.workflows.io.summary import (
    SCHEMA_VERSION,
    SUMMARY,
    CompareSummary,
    ExternalSummary,
    VariantRun,
    read_compare_summary,
    read_external_summary,
    write_summary,
)
from tissuebench.workflows.run.case import versions
from tissuebench.workflows.simulators import ExternalRun, get_simulator
from tissuebench.workflows.simulators.contact import ADAPTERS, adapter


class SimulatorError(UserError):
    """A simulator or variant that cannot run here or does not pose the benchmark."""


# a simulator without a contact adapter, unless its module says why in its CONTACT_NOTE
NO_CONTACT = "cannot pose a rigid tool in contact here"


def tool_kind(data: Exported | None) -> str | None:
    """The kind of the export's rigid tool (its contact.shape.kind), None without contact."""
    contact = getattr(data, "contact", None)
    if contact is None:
        return None
    return str((contact.get("shape") or {}).get("kind", ""))


def poses_contact(simulator: str, kind: str = "half-stadium") -> bool:
    """Whether a simulator poses an export with a rigid tool of `kind` in contact (SPEC 12,
    13): it has an adapter for it (workflows/simulators/contact/). One that has none is never
    run on such an export, lest it pose it as if the tool were absent."""
    return kind in ADAPTERS.get(simulator, {})


def posing(simulator: str, data: Exported | None) -> ModuleType:
    """The module that poses `data` for `simulator`: its contact adapter for an export with a
    rigid tool in contact, else the simulator's own module (SimulatorError, one line, for a
    contact export that it cannot pose)."""
    sim = get_simulator(simulator)
    kind = tool_kind(data)
    if kind is None:
        return sim
    found = adapter(simulator, kind)
    if found is None:
        raise SimulatorError(f"{simulator}: {getattr(sim, 'CONTACT_NOTE', NO_CONTACT)}")
    return found


def label_of(simulator: str, variant: str) -> str:
    """How tables name a variant: SIMULATOR:VARIANT."""
    return f"{simulator}:{variant}"


def choose_variants(simulator: str, data: Exported, wanted: list[str] | None) -> dict[str, str]:
    """The variants to run (all that pose the export when wanted is None); refuses a variant
    that the simulator does not have for this export, with the ones it has."""
    sim = posing(simulator, data)
    offered = sim.variants(data)
    if wanted is None:
        return offered
    unknown = [v for v in wanted if v not in offered]
    if unknown:
        why = sim.skipped(data)
        said = "; ".join(f"{k}: {v}" for k, v in why.items())
        raise SimulatorError(
            f"{simulator} has no variant {', '.join(unknown)} for this benchmark: use "
            f"{', '.join(offered) or '(none)'}" + (f" (not posed: {said})" if said else "")
        )
    return {v: offered[v] for v in wanted}


def run_variant(
    simulator: str,
    data: Exported | None,
    variant: str,
    description: str,
    reference: Path,
    folder: Path,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> VariantRun:
    """Run one variant in folder/work (rank 0; outside simulators run serially), grade its
    output against reference into folder, and return its entry (see the module docstring).
    A failed run or an output that compare refuses is an entry with status "failed"."""
    sim = posing(simulator, data) if comm.rank == 0 else get_simulator(simulator)
    contact = None
    if comm.rank == 0 and data is not None and getattr(data, "contact", None) is not None:
        from tissuebench.workflows.compare.contact import exported_reference

        contact = exported_reference(data)  # its force: our reference's, as the export holds

    def run():
        work = folder / "work"
        work.mkdir(parents=True)
        try:
            return sim.run(data, variant, work)
        except Exception as exc:  # a simulator's own crash is a result, not ours
            return ExternalRun(
                None,
                None,
                data.nodes.size,
                status="failed",
                reason=f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}",
            )

    result = collective(comm, run, folder)  # rank 0; a fault of ours is raised on every rank
    interrupt.checkpoint(comm)  # a signal stopped the simulator: the job ends, not the variant
    label = label_of(simulator, variant)
    entry: VariantRun = {
        "simulator": simulator,
        "title": get_simulator(simulator).TITLE,
        "version": result.version,
        "variant": variant,
        "description": description,
        "mesh": result.mesh,
        "dofs": result.dofs,
        "timing": result.timing,
        "status": result.status,
        "reason": result.reason,
        "wall_time_s": result.wall_time_s,
    }
    graded: CompareSummary | None = None
    if result.series is not None:
        try:
            compare(
                reference,
                result.series,
                folder,
                comm=comm,
                reference_field=REFERENCE_FIELD,
                candidate_field=result.field,
                label=label,
                wall_time=result.wall_time_s,
                folder_of_ours=True,
                needle_force=result.force,
                contact=contact,
            )
            graded = comm.bcast(read_compare_summary(folder) if comm.rank == 0 else None, root=0)
        except UserError as exc:
            entry["status"] = "failed"
            entry["reason"] = entry["reason"] or f"not graded: {exc}"
    if graded is not None:
        graded_run = graded["runs"][label]
        kept = {k: v for k, v in graded_run.items() if k not in ("status", "wall_time_s")}
        entry.update(kept)  # type: ignore[typeddict-item]
        # the simulator's own words on why it failed ("diverged at step 3 (t = 0.1 s): 12
        # tetrahedra inverted") say more than compare's reading of its series
        entry["reason"] = result.reason or graded_run.get("reason")
        if graded_run["status"] != "ok" and entry["status"] == "ok":
            entry["status"] = (
                "diverged" if graded_run["diverged_step"] is not None else graded_run["status"]
            )
    if comm.rank == 0:
        state = entry["status"] + (f" ({entry['reason']})" if entry["reason"] else "")
        wall = "" if entry["wall_time_s"] is None else f", {entry['wall_time_s']:.2f} s"
        log(f"{label:<34} {state}{wall}")
    return entry


def external_inputs(simulator: str, data_inputs: dict, variants: dict[str, str]) -> dict:
    """Every input that changes an external folder's numbers."""
    return {
        "simulator": simulator,
        "variants": sorted(variants),
        **data_inputs,
        "versions": versions(),
    }


def run_external(
    simulator: str,
    out: Path,
    *,
    benchmark: str,
    mesh_size: int,
    options: dict,
    material,
    model: str,
    h: float,
    steps: int,
    plane: str = "strain",
    variants: list[str] | None = None,
    solver: str = "direct",
    petsc: str = "",
    force: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> ExternalSummary:
    """Export the benchmark, run our reference and every chosen variant of the simulator, grade
    them, and write the simulator folder `out` (see the module docstring; the output-folder
    rules of workflows/io/output.py). Collective; returns the folder's summary. Complete
    results of the same inputs are kept unless force. `petsc` is the --petsc text, already in
    PETSc's options database (it changes our reference, so it is one of the inputs)."""
    from dataclasses import asdict

    sim = get_simulator(simulator)
    missing = sim.available() if comm.rank == 0 else None
    missing = comm.bcast(missing, root=0)
    if missing:
        raise SimulatorError(f"{simulator}: {missing}")
    data, bench, _ = build(
        benchmark, mesh_size, options, material, model, h, steps, plane, "dynamic", comm
    )
    kind = comm.bcast(tool_kind(data) if comm.rank == 0 else None, root=0)
    if kind is not None and not poses_contact(simulator, kind):  # never as if the tool were absent
        raise SimulatorError(f"{simulator}: {getattr(sim, 'CONTACT_NOTE', NO_CONTACT)}")
    posed_by = posing(simulator, data) if comm.rank == 0 else sim  # a contact export: its adapter
    chosen = comm.bcast(
        choose_variants(simulator, data, variants) if comm.rank == 0 else None, root=0
    )
    if not chosen:
        why = comm.bcast(posed_by.skipped(data) if comm.rank == 0 else None)
        raise SimulatorError(
            f"{simulator} poses no variant of this benchmark"
            + (f": {'; '.join(f'{k}: {v}' for k, v in why.items())}" if why else "")
        )
    posed = {
        "benchmark": benchmark,
        "mesh_size": mesh_size,
        "options": options,
        "material": asdict(material),
        "model": model,
        "h": h,
        "steps": steps,
        "plane": plane,
    }
    # no --petsc stays out, so that results written before it counted keep their fingerprint
    petsc = {"petsc": " ".join(petsc.split())} if petsc.strip() else {}
    inputs = external_inputs(simulator, {**posed, "solver": solver, **petsc}, chosen)
    with RunFolder(out, comm) as folder:
        if folder.prepare(inputs, force) == "complete":
            if comm.rank == 0:
                log(f"{out}: complete results for the same inputs exist, skipped (--force reruns)")
            summary: ExternalSummary = comm.bcast(
                read_external_summary(folder.path) if comm.rank == 0 else None, root=0
            )
            return {**summary, "skipped": True}  # type: ignore[typeddict-unknown-key]
        with folder.writing() as tmp:
            reference = tmp / "reference.xdmf"
            info = run_reference(data, bench, material, reference, solver, comm, log)
            if comm.rank == 0:
                from tissuebench.workflows.io.exported import write_json

                data.reference = {**info, "file": "reference.xdmf"}
                write_json(data, tmp / "benchmark.json")
            runs = {}
            for variant, description in chosen.items():
                runs[label_of(simulator, variant)] = run_variant(
                    simulator, data, variant, description, reference, tmp / variant, comm, log
                )
            summary = cast(  # with posed's keys, which mypy cannot count from a plain dict
                ExternalSummary,
                {
                    "kind": "external",
                    "schema_version": SCHEMA_VERSION,
                    "simulator": simulator,
                    "title": sim.TITLE,
                    **posed,
                    "num_dofs": int(data.nodes.size) if comm.rank == 0 else None,
                    "end_time": steps * h,
                    "reference": {**info, "file": "reference.xdmf"},
                    "skipped_variants": posed_by.skipped(data) if comm.rank == 0 else None,
                    "runs": runs,
                    "files": ["benchmark.json", "reference.xdmf", "reference.h5", SUMMARY],
                    "inputs": inputs,
                    "fingerprint": fingerprint(inputs),
                },
            )

            collective(comm, lambda: write_summary(tmp, summary), folder.path)
    return comm.bcast(summary if comm.rank == 0 else None, root=0)
