"""What was graded against what: what a reference file's folder says of it (the study case or
the export it belongs to), what a truth case poses, and a candidate's mesh; compare writes them
into summary.json (workflows/compare/grading.py)."""

from __future__ import annotations

from pathlib import Path

from tissuebench.core.errors import UserError
from tissuebench.workflows.io.summary import kind_of, read_case_summary, read_summary


def folder_fingerprint(path: Path) -> dict:
    """reference_fingerprint's fields that the reference's folder states ({} when none): a
    study case's summary.json with a run of the file's name, else the export STEM.json beside
    STEM.reference.xdmf (read by io/exported.py)."""
    from tissuebench.workflows.io.exported import read_json

    folder = path.parent
    found = read_summary(folder)
    if found is not None and kind_of(found) == "case":
        try:
            summary = read_case_summary(folder)
        except UserError:  # not a case summary of this tissuebench: the folder says nothing
            summary = None
        run = summary.runs.get(path.stem) if summary is not None else None
        if summary is not None and run is not None:
            material = next(
                (
                    r["material"]["name"]
                    for r in summary.inputs.get("runs", [])
                    if r.get("label") == path.stem
                ),
                None,
            )
            return {
                "source": "run folder",
                "benchmark": summary.benchmark,
                "case": summary.case,
                "options": dict(summary.inputs.get("options") or {}),
                "material": material,
                "model": run.model,
                "mesh_size": summary.mesh_size,
            }
    stem = path.name.split(".")[0]
    export = folder / f"{stem}.json"
    if path.name.startswith(f"{stem}.reference.") and export.is_file():
        data = read_json(export)
        return {
            "source": "export",
            "benchmark": data.benchmark,
            "case": stem,
            "options": dict(data.options),
            "material": data.material.name,
            "model": data.model,
            "mesh_size": data.mesh_size,
        }
    return {}


def mesh_of(series) -> dict | None:
    """The mesh of a series (metrics.series.Series): {"cell_type", "cells", "nodes",
    "dimension", "dofs"}, dofs = nodes x dimension (a first-order displacement field)."""
    if series is None:
        return None
    return {
        "cell_type": str(series.cell_type),
        "cells": int(len(series.cells)),
        "nodes": int(len(series.points)),
        "dimension": int(series.dim),
        "dofs": int(series.points.size),
    }


def truth_fingerprint(case: str) -> dict:
    """What the truth case (SPEC 10) poses: benchmark, material, model, options."""
    from tissuebench.meshes import get_entry
    from tissuebench.solvers.truth.cases import CASES

    benchmark, material, model, scale, width = CASES[case]
    options = {"load_scale": scale} | ({} if width is None else {"needle_width": width})
    return {
        "source": "truth",
        "truth": case,
        "benchmark": benchmark,
        "case": None,
        "options": options,
        "material": material,
        "model": model,
        "mesh_size": None,
        "nodes": None,
        "dimension": get_entry(benchmark).gdim,
    }


def reference_fingerprint(reference: str | Path, series) -> dict:
    """What a reference series file is: its dimension and nodes (read), and, as the folder it
    is in says, its benchmark, case, options, material, model and mesh size: a run folder of
    ours (summary.json with a run of the file's name) or an export (STEM.json beside
    STEM.reference.xdmf). "source" names which ("run folder", "export", or "file" when
    neither: the benchmark is then unknown)."""
    path = Path(reference)
    found = {
        "source": "file",
        "truth": None,
        "benchmark": None,
        "case": None,
        "options": None,
        "material": None,
        "model": None,
        "mesh_size": None,
    }
    try:
        found |= folder_fingerprint(path)
    except Exception:  # anything a file can hold: the folder says nothing
        pass
    return found | {"nodes": int(len(series.points)), "dimension": int(series.dim)}
