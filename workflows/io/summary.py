"""summary.json, every kind of it, read and written here only.

Three commands write a folder with a summary.json, each of its own kind:
- "case": a study case (`tissuebench run`, the paper's cases; workflows/run/case.py), typed as
  `CaseSummary` and its `RunSummary`s. `CaseSummary.to_json()` gives the file's dict exactly as
  study has always written it (same keys, same order, same values; the case's benchmark options
  as top-level keys between `plane` and `solver`), so that `write_summary` reproduces a
  committed summary.json byte for byte; `from_json` refuses anything else in one line
  (ValueError). Its file has no `kind` key.
- "compare": `tissuebench compare` (workflows/compare/grading.py builds it), typed as
  `CompareSummary` and its `CompareRun`s.
- "external": `tissuebench external` and the leaderboard's simulator folders
  (workflows/simulators/runner.py builds it), typed as `ExternalSummary` and its
  `VariantRun`s.
Every kind carries `files` and, in a folder of its own (not an external variant's), the `inputs`
and their `fingerprint` (core/fingerprint.py), from which workflows/io/output.py decides whether a
folder holds the results of the same inputs.

Schema version: `SCHEMA_VERSION`, the key `schema_version`. A summary without it is version 1
(every summary written before the key existed, and the committed case summaries in results/).
Compare and external summaries are written with it; a case summary is written without it, so
that the committed results stay byte-identical, until its schema changes (version 2 is then
written). A summary of a version newer than this module's is refused in one line.

`read_summary` is the one reader of the file (a JSON object, or None), `read_case_summary`,
`read_compare_summary` and `read_external_summary` its typed readers, `dumps` and
`write_summary` the one writer (JSON indented by 2, a newline at the end)."""

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, NotRequired, TypedDict

from tissuebench.core.errors import UserError

SUMMARY = "summary.json"  # the file's name in every folder that has one
SCHEMA_VERSION = 1  # of every kind; a summary without `schema_version` is version 1
VERSION_KEY = "schema_version"
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
# SPEC 12, written only for a benchmark with contact: the run's largest needle force |F| (N/m)
# and interpenetration (m)
_CONTACT = "contact"
CONTACT_READINGS = ("needle_force_max", "interpenetration_max")
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
# written only by a case that timed its phases (absent from the committed summaries written
# before): {phase: wall time in s}, after system_time_s
_PHASES = "phases_s"


def _tail(phases: bool) -> list[str]:
    """The case's keys after its options, in the file's order, with or without _PHASES."""
    tail = list(_CASE_TAIL)
    if phases:
        tail.insert(tail.index("system_time_s") + 1, _PHASES)
    return tail


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
    # SPEC 12, a benchmark with contact: {"needle_force_max": N/m, "interpenetration_max": m}
    contact: dict[str, float | None] | None = None

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
        if self.contact is not None:
            entry[_CONTACT] = self.contact
        return entry

    @classmethod
    def from_json(cls, data: Any, label: str = "") -> "RunSummary":
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
        from tissuebench.metrics.table import METRICS  # DOLFINx: only when a summary is read

        readings: dict[str, float | None] = {}
        known = {f"{m}_{kind}" for m in METRICS for kind in READINGS}
        for k, v in data.items():
            if k in _RUN_HEAD or k == _TIP or k in _SCHEME_KEYS or k == _CONTACT:
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
        contact = data.get(_CONTACT)
        _check(
            contact is None
            or (
                isinstance(contact, dict)
                and set(contact) == set(CONTACT_READINGS)
                and all(v is None or _number(v) for v in contact.values())
            ),
            f"{where}: {_CONTACT} is not an object of {', '.join(CONTACT_READINGS)}",
        )
        return cls(
            **{k: data[k] for k in _RUN_HEAD},
            **{k: data[k] for k in _SCHEME_KEYS if k in data},
            readings=readings,
            has_probe=_TIP in data,
            tip_displacement_final=tip,
            contact=contact,
        )


@dataclass
class CaseSummary:
    """A study case's summary.json: the case (name, description, benchmark, the material
    names, the reference run's label), its discretisation (mesh_size cells per unit, num_dofs,
    time step h in s, end_time in s, steps, plane: "strain"/"stress" or None in 3D), the
    benchmark's `options` (e.g. needle_width in m, load_scale), the linear solver, the set-up
    time of one material's system (s), the wall time of each phase of the run that wrote it
    (`phases_s`, s, in the order they ran: mesh, forms, each run's set-up and loop, metrics,
    output, figures; None in a summary written before they were timed), the software
    versions, the `runs` by label, the folder's `files`, the `inputs` and their `fingerprint`
    (which the timings are no part of). `skipped` (not in the file) is True when run_case
    reused complete results instead of computing them."""

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
    phases_s: dict[str, float] | None = None

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
        for k in _tail(self.phases_s is not None):
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
    def from_json(cls, data: Any) -> "CaseSummary":
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
        phases = data.get(_PHASES)
        _check(
            phases is None
            or (
                isinstance(phases, dict)
                and all(_number(t) and math.isfinite(t) and t >= 0 for t in phases.values())
            ),
            f"{_PHASES} is not an object of wall times",
        )
        keys = list(data)
        head, tail = len(_CASE_HEAD), keys.index("solver")
        _check(
            keys[:head] == list(_CASE_HEAD) and keys[tail:] == _tail(_PHASES in data),
            "keys out of order",
        )
        return cls(
            **{k: data[k] for k in _CASE_HEAD},
            options={k: data[k] for k in keys[head:tail]},
            **{k: data[k] for k in _CASE_TAIL if k != "runs"},
            phases_s=phases,
            runs={
                label: RunSummary.from_json(run, str(label)) for label, run in data["runs"].items()
            },
        )


class CompareRun(TypedDict):
    """A run of a compare summary (the candidate's, keyed by its label): its status ("ok",
    "diverged", "missing", "reference diverged": the worst of its steps), the step it diverged
    at and its time (s) and the reason, None when it did not, its steps after t = 0, the steps
    graded, its wall time (s, as --wall-time gave it; None without), and for every metric of
    METRICS "<metric>_max" and "<metric>_mean" (None where no step was graded; keys that a
    TypedDict cannot name)."""

    status: str
    diverged_step: int | None
    diverged_time: float | None
    reason: str | None
    steps: int
    graded_steps: int
    wall_time_s: float | None


class CompareSummary(TypedDict):
    """compare's summary.json (workflows/compare/grading.py, its module docstring says each entry):
    the reference and candidate files with their fields, the reference's `fingerprint` (what
    it poses) and the candidate's `mesh`, the notes on how the series were read, h (s; None
    for one step), steps and end_time (s), the metrics' symbols and units, the reference's
    divergence, the `runs` (one), the versions, the files and, against the truth, `truth`
    (case, own error, timings). `inputs` and `fingerprint` are absent in a folder that an
    external simulator's variant was graded into."""

    kind: Literal["compare"]
    schema_version: NotRequired[int]
    reference: dict[str, Any]
    candidate: dict[str, Any]
    notes: list[str]
    h: float | None
    steps: int
    end_time: float
    metrics: dict[str, dict[str, str]]
    reference_diverged_step: int | None
    reference_diverged_reason: str | None
    runs: dict[str, CompareRun]
    versions: dict[str, Any]
    files: list[str]
    truth: NotRequired[dict[str, Any]]
    # against a contact reference (SPEC 12): force_error (1), interpenetration_max (m), ...
    contact: NotRequired[dict[str, Any]]
    inputs: NotRequired[dict[str, Any]]
    fingerprint: NotRequired[str]


class VariantRun(TypedDict, total=False):
    """A variant's run in an external summary, keyed SIMULATOR:VARIANT: the simulator, its
    title and version, the variant and its description, its mesh, dofs and timing, its status
    ("ok", "diverged", "failed") with the reason, its wall time (s), and, once graded, the
    compare run's entries (steps, graded_steps, diverged_step, diverged_time, the metrics'
    readings)."""

    simulator: str
    title: str
    version: str | None
    variant: str
    description: str
    mesh: Any
    dofs: int | None
    timing: Any
    status: str
    reason: str | None
    wall_time_s: float | None
    diverged_step: int | None
    diverged_time: float | None
    steps: int
    graded_steps: int


class ExternalSummary(TypedDict):
    """An external simulator folder's summary.json (workflows/simulators/runner.py): the
    simulator and its title, what it poses (benchmark, mesh size, options, the material's
    fields, model, h in s, steps, plane), our reference's dofs and end time (s) and its run
    (`reference`), the variants the simulator skipped with why, the `runs`, the files, and the
    inputs with their fingerprint."""

    kind: Literal["external"]
    schema_version: NotRequired[int]
    simulator: str
    title: str
    benchmark: str
    mesh_size: int
    options: dict[str, Any]
    material: dict[str, Any]
    model: str
    h: float
    steps: int
    plane: str
    num_dofs: int | None
    end_time: float
    reference: dict[str, Any]
    skipped_variants: dict[str, str] | None
    runs: dict[str, VariantRun]
    files: list[str]
    inputs: dict[str, Any]
    fingerprint: str


Summary = CaseSummary | CompareSummary | ExternalSummary


def kind_of(data: dict[str, Any]) -> str:
    """The kind of a summary.json's dict: its `kind` ("compare", "external"), else "case"."""
    kind = data.get("kind")
    return kind if isinstance(kind, str) else "case"


def version_of(data: dict[str, Any]) -> int:
    """The schema version of a summary.json's dict: its `schema_version`, 1 when absent."""
    version = data.get(VERSION_KEY, 1)
    return version if _integer(version) else 0


_ABSENT = object()  # what _load gives for a summary.json that is absent or not JSON


def _load(folder: Path) -> object:
    """`folder`/summary.json's JSON value; _ABSENT if it is absent or not JSON."""
    try:
        return json.loads((Path(folder) / SUMMARY).read_text())
    except (OSError, ValueError, RecursionError):
        return _ABSENT


def read_summary(folder: Path) -> dict[str, Any] | None:
    """`folder`/summary.json as a dict, of any kind and unchecked (the keys every kind shares,
    `files`, `inputs` and `fingerprint`, are what workflows/io/output.py reads); None if it is
    absent, unreadable or not a JSON object."""
    data = _load(folder)
    return data if isinstance(data, dict) else None


def _of_kind(folder: Path, kind: str) -> dict[str, Any] | None:
    """read_summary's dict when it is of `kind` (None otherwise); UserError (one line) for a
    schema version that this tissuebench does not know."""
    data = read_summary(folder)
    if data is None or kind_of(data) != kind:
        return None
    if not 1 <= version_of(data) <= SCHEMA_VERSION:
        raise UserError(
            f"{Path(folder) / SUMMARY}: schema version {data.get(VERSION_KEY)!r}, which this "
            f"tissuebench (version {SCHEMA_VERSION}) cannot read; write it again, or update"
        )
    return data


def read_case_summary(folder: Path) -> CaseSummary | None:
    """The study case summary.json of `folder`; None if it is absent or not JSON; UserError (one
    line) if it is JSON but not a study case's summary."""
    path = Path(folder) / SUMMARY
    data = _load(folder)
    if data is _ABSENT:
        return None
    if isinstance(data, dict) and version_of(data) != 1:  # the case schema has one version
        raise UserError(
            f"{path}: schema version {data.get(VERSION_KEY)!r}, which this tissuebench "
            "cannot read; write it again, or update"
        )
    try:
        return CaseSummary.from_json(data)
    except ValueError as e:
        raise UserError(f"{path}: not a study case's summary: {e}") from None


def read_compare_summary(folder: Path) -> CompareSummary | None:
    """The compare summary.json of `folder`; None if it is absent, not JSON or of another
    kind."""
    return _of_kind(folder, "compare")  # type: ignore[return-value]


def read_external_summary(folder: Path) -> ExternalSummary | None:
    """The external simulator folder's summary.json of `folder`; None if it is absent, not
    JSON or of another kind."""
    return _of_kind(folder, "external")  # type: ignore[return-value]


def dumps(summary: Summary | dict[str, Any]) -> str:
    """summary.json's text: a CaseSummary as study has always written it, a compare or
    external summary as its dict, indented by 2, with a newline at the end."""
    if isinstance(summary, CaseSummary):
        return summary.dumps()
    return json.dumps(summary, indent=2) + "\n"


def write_summary(folder: Path, summary: Summary | dict[str, Any]) -> None:
    """Write `summary` as `folder`/summary.json (dumps)."""
    (Path(folder) / SUMMARY).write_text(dumps(summary))


def write_case_summary(folder: Path, summary: CaseSummary) -> None:
    """Write `summary` as `folder`/summary.json (the text study has always written)."""
    write_summary(folder, summary)


def candidate_file(summary: CompareSummary, folder: str | Path) -> str | None:
    """The candidate series file that the compare summary.json in `folder` records, as a path
    found from any working folder: as recorded when absolute (summary_of records it so); for
    a summary of an older compare, which recorded it as typed, the absolute path of its
    inputs (`inputs.candidate.file`), else the recorded path taken relative to `folder`.
    None when it records none."""
    cand = summary.get("candidate")
    file = cand.get("file") if isinstance(cand, dict) else None
    if not isinstance(file, str) or not file:
        return None
    if Path(file).is_absolute():
        return file
    inputs = summary.get("inputs")
    read = inputs.get("candidate") if isinstance(inputs, dict) else None
    resolved = read.get("file") if isinstance(read, dict) else None
    if isinstance(resolved, str) and Path(resolved).is_absolute():
        return resolved
    return str(Path(folder).resolve() / file)
