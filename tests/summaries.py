"""Hand-built study case summaries for the report tests: a partial summary.json dict (the keys a
test needs) completed with neutral defaults and read through CaseSummary.from_json, the one
reader (workflows/io/summary.py), so that a test's summary is one the reader accepts."""

from tissuebench.workflows.io.summary import CaseSummary, RunSummary

RUN = {  # a run's required keys, neutral
    "algorithm": "implicit",
    "model": "linear",
    "material": "MP1",
    "status": "ok",
    "diverged_step": None,
    "diverged_time": None,
    "reason": None,
    "steps": 0,
    "wall_time_s": 0.0,
    "setup_time_s": 0.0,
}
HEAD = {  # the case's keys before its options
    "case": "case",
    "description": "",
    "benchmark": "block",
    "material": ["MP1"],
    "reference": None,  # default: the first run
    "mesh_size": 20,
    "num_dofs": 0,
    "h": 0.1,
    "end_time": 1.0,
    "steps": 10,
    "plane": "strain",
}
TAIL = {  # after its options
    "solver": "direct",
    "system_time_s": 0.0,
    "versions": {},
    "runs": {},
    "files": [],
    "inputs": {},
    "fingerprint": "",
}


def case_summary(doc: dict) -> CaseSummary:
    """The CaseSummary of a partial summary dict; keys that are neither the case's nor its
    runs' are the benchmark's options (needle_width, load_scale)."""
    runs = {label: {**RUN, **run} for label, run in doc["runs"].items()}
    full = {k: doc.get(k, v) for k, v in HEAD.items()}
    if full["reference"] is None:
        full["reference"] = next(iter(runs))
    full |= {k: v for k, v in doc.items() if k not in HEAD and k not in TAIL}
    full |= {k: doc.get(k, v) for k, v in TAIL.items()} | {"runs": runs}
    return CaseSummary.from_json(full)


def update(run: RunSummary, **fields: object) -> None:
    """Set a run's fields as a summary.json entry names them (`<metric>_mean` a reading,
    `tip_displacement_final` the probe's tip)."""
    for key, value in fields.items():
        if key.endswith(("_max", "_mean")):
            run.readings[key] = value
        elif key == "tip_displacement_final":
            run.has_probe, run.tip_displacement_final = True, value
        else:
            setattr(run, key, value)
