"""A study case's summary.json, typed: `CaseSummary` (the case) and its `RunSummary`s (one a
run), read and written here only (workflows/study.py writes it, `read_case_summary` reads it).

`CaseSummary.to_json()` gives the file's dict exactly as study has always written it (same keys,
same order, same values; the case's benchmark options as top-level keys between `plane` and
`solver`), so `write_case_summary` reproduces a committed summary.json byte for byte;
`from_json` refuses anything else in one line (ValueError). Other summaries (compare's,
external's, the leaderboard's user folders, output.RunFolder's fingerprint check) are other
schemas and are not read here."""

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from tissuebench.core.errors import UserError
from tissuebench.metrics.table import METRICS
from tissuebench.workflows.output import SUMMARY

READINGS = ("max", "mean")  # the two readings of a metric's history (metrics.compare.summarize)

_RUN_HEAD = (
    "algorithm",
    "model",
    "material",
    "status",
    "diverged_step",
    "diverged_time",
    "reason",
    "steps",
    "wall_time_s",
    "setup_time_s",
)
_TIP = "tip_displacement_final"
# SPEC 11, written only where they differ from the paper's: the element's scheme, the explicit
# sub-steps per step h, and the critical step (s) that `auto` measured
_SCHEME_KEYS = {"scheme": "standard", "substeps": 1, "critical_dt_s": None}
_CASE_HEAD = (
    "case",
    "description",
    "benchmark",
    "material",
    "reference",
    "mesh_size",
    "num_dofs",
    "h",
    "end_time",
    "steps",
    "plane",
)
_CASE_TAIL = ("solver", "system_time_s", "versions", "runs", "files", "inputs", "fingerprint")


def _number(x: object) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _integer(x: object) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _check(ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(what)


@dataclass
class RunSummary:
    """One run of a case: what ran (algorithm, model, material name), how it ended (status
    "ok" or "diverged"; the first diverged step and its time in s, and the solver's reason, None
    when ok), `steps` time steps completed, the wall time of the time loop and of the set-up
    before it (s), the metric readings against the case's reference (`readings`: "<metric>_max"
    and "<metric>_mean" of metrics.table.METRICS, dimensionless, None where no step could be
    measured) and, where the benchmark has a probe, the probe's displacement at the last kept
    step (m; None if step 0 diverged). SPEC 11: the scheme of its element (solvers/schemes/),
    its sub-steps per step h and, where `auto` chose them, the critical step measured (s)."""

    algorithm: str
    model: str
    material: str
    status: str
    diverged_step: int | None
    diverged_time: float | None
    reason: str | None
    steps: int
    wall_time_s: float
    setup_time_s: float
    readings: dict[str, float | None] = field(default_factory=dict)
    has_probe: bool = False
    tip_displacement_final: list[float] | None = None
    scheme: str = "standard"
    substeps: int = 1
    critical_dt_s: float | None = None

    @property
    def ok(self) -> bool:
        """True if the run reached the end time."""
        return self.status == "ok"

    def reading(self, metric: str, kind: str = "max") -> float | None:
        """The run's `kind` ("max" or "mean") of `metric` over its history (dimensionless);
        None if unmeasured. KeyError if the summary has no such reading."""
        return self.readings[f"{metric}_{kind}"]

    def has_reading(self, metric: str) -> bool:
        """True if the summary holds `metric`'s readings (older files may lack a newer one)."""
        return f"{metric}_max" in self.readings

    def to_json(self) -> dict[str, Any]:
        """The run's entry of summary.json["runs"], keys in the file's order."""
        entry: dict[str, Any] = {k: getattr(self, k) for k in _RUN_HEAD}
        entry.update(self.readings)
        if self.has_probe:
            entry[_TIP] = self.tip_displacement_final
        for k, default in _SCHEME_KEYS.items():
            if getattr(self, k) != default:
                entry[k] = getattr(self, k)
        return entry

    @classmethod
    def from_json(cls, data: object, label: str = "") -> "RunSummary":
        """The run of a summary.json["runs"] entry; ValueError (one line) if malformed."""
        where = f"run {label!r}" if label else "run"
        _check(isinstance(data, dict), f"{where} is not an object")
        missing = [k for k in _RUN_HEAD if k not in data]
        _check(not missing, f"{where} lacks {', '.join(missing)}")
        for k in ("algorithm", "model", "material", "status"):
            _check(isinstance(data[k], str), f"{where}: {k} is not a string")
        _check(_integer(data["steps"]), f"{where}: steps is not an integer")
        for k in ("wall_time_s", "setup_time_s"):
            _check(_number(data[k]), f"{where}: {k} is not a number")
        _check(
            data["diverged_step"] is None or _integer(data["diverged_step"]),
            f"{where}: diverged_step is not an integer",
        )
        _check(
            data["diverged_time"] is None or _number(data["diverged_time"]),
            f"{where}: diverged_time is not a number",
        )
        _check(data["reason"] is None or isinstance(data["reason"], str), f"{where}: reason")
        readings: dict[str, float | None] = {}
        known = {f"{m}_{kind}" for m in METRICS for kind in READINGS}
        for k, v in data.items():
            if k in _RUN_HEAD or k == _TIP or k in _SCHEME_KEYS:
                continue
            _check(k in known, f"{where}: unknown key {k!r}")
            _check(v is None or _number(v), f"{where}: {k} is not a number")
            readings[k] = v
        tip = data.get(_TIP)
        _check(
            tip is None or (isinstance(tip, list) and all(_number(x) for x in tip)),
            f"{where}: {_TIP} is not a list of numbers",
        )
        _check(isinstance(data.get("scheme", ""), str), f"{where}: scheme is not a string")
        _check(_integer(data.get("substeps", 1)), f"{where}: substeps is not an integer")
        critical = data.get("critical_dt_s")
        _check(critical is None or _number(critical), f"{where}: critical_dt_s")
        return cls(
            **{k: data[k] for k in _RUN_HEAD},
            **{k: data[k] for k in _SCHEME_KEYS if k in data},
            readings=readings,
            has_probe=_TIP in data,
            tip_displacement_final=tip,
        )


@dataclass
class CaseSummary:
    """A study case's summary.json: the case (name, description, benchmark, the material
    names, the reference run's label), its discretisation (mesh_size cells per unit, num_dofs,
    time step h in s, end_time in s, steps, plane: "strain"/"stress" or None in 3D), the
    benchmark's `options` (e.g. needle_width in m, load_scale), the linear solver, the set-up
    time of one material's system (s), the software versions, the `runs` by label, the folder's
    `files`, the `inputs` and their `fingerprint`. `skipped` (not in the file) is True when
    run_case reused complete results instead of computing them."""

    case: str
    description: str
    benchmark: str
    material: list[str]
    reference: str
    mesh_size: int
    num_dofs: int
    h: float
    end_time: float
    steps: int
    plane: str | None
    options: dict[str, Any] = field(default_factory=dict)
    solver: str = "direct"
    system_time_s: float = 0.0
    versions: dict[str, Any] = field(default_factory=dict)
    runs: dict[str, RunSummary] = field(default_factory=dict)
    files: list[str] = field(default_factory=list)
    inputs: dict[str, Any] = field(default_factory=dict)
    fingerprint: str = ""
    skipped: bool = False

    def option(self, name: str, default: Any = None) -> Any:
        """The benchmark option `name` (e.g. "needle_width" in m, "load_scale"), or default
        when the case did not set it (or set it to None)."""
        value = self.options.get(name)
        return default if value is None else value

    @property
    def reference_run(self) -> RunSummary:
        """The reference run."""
        return self.runs[self.reference]

    def to_json(self) -> dict[str, Any]:
        """summary.json's dict, keys in the file's order (`skipped` is not written)."""
        doc: dict[str, Any] = {k: getattr(self, k) for k in _CASE_HEAD}
        doc.update(self.options)
        for k in _CASE_TAIL:
            doc[k] = (
                {lb: r.to_json() for lb, r in self.runs.items()}
                if k == "runs"
                else getattr(self, k)
            )
        return doc

    def dumps(self) -> str:
        """summary.json's text, as study writes it."""
        return json.dumps(self.to_json(), indent=2) + "\n"

    @classmethod
    def from_json(cls, data: object) -> "CaseSummary":
        """The case of summary.json's dict; ValueError (one line) if it is not a study case's
        summary."""
        _check(isinstance(data, dict), "not an object")
        missing = [k for k in (*_CASE_HEAD, *_CASE_TAIL) if k not in data]
        _check(not missing, f"lacks {', '.join(missing)}")
        for k in ("case", "description", "benchmark", "reference", "solver", "fingerprint"):
            _check(isinstance(data[k], str), f"{k} is not a string")
        _check(
            isinstance(data["material"], list)
            and all(isinstance(m, str) for m in data["material"]),
            "material is not a list of names",
        )
        for k in ("mesh_size", "num_dofs", "steps"):
            _check(_integer(data[k]), f"{k} is not an integer")
        for k in ("h", "end_time", "system_time_s"):
            _check(_number(data[k]) and math.isfinite(data[k]), f"{k} is not a number")
        _check(data["plane"] is None or isinstance(data["plane"], str), "plane is not a string")
        for k in ("versions", "inputs", "runs"):
            _check(isinstance(data[k], dict), f"{k} is not an object")
        _check(
            isinstance(data["files"], list) and all(isinstance(f, str) for f in data["files"]),
            "files is not a list of names",
        )
        _check(data["reference"] in data["runs"], "the reference is not among the runs")
        keys = list(data)
        head, tail = len(_CASE_HEAD), keys.index("solver")
        _check(
            keys[:head] == list(_CASE_HEAD) and keys[tail:] == list(_CASE_TAIL),
            "keys out of order",
        )
        return cls(
            **{k: data[k] for k in _CASE_HEAD},
            options={k: data[k] for k in keys[head:tail]},
            **{k: data[k] for k in _CASE_TAIL if k != "runs"},
            runs={
                label: RunSummary.from_json(run, str(label)) for label, run in data["runs"].items()
            },
        )


def read_case_summary(folder: Path) -> CaseSummary | None:
    """The study case summary.json of `folder`; None if it is absent or not JSON; UserError (one
    line) if it is JSON but not a study case's summary."""
    path = Path(folder) / SUMMARY
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError):
        return None
    try:
        return CaseSummary.from_json(data)
    except ValueError as e:
        raise UserError(f"{path}: not a study case's summary: {e}") from None


def write_case_summary(folder: Path, summary: CaseSummary) -> None:
    """Write `summary` as `folder`/summary.json (the text study has always written)."""
    (Path(folder) / SUMMARY).write_text(summary.dumps())
