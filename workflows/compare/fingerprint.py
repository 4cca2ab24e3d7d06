"""What a reference file's folder says of it: the study case or the export it belongs to."""

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
