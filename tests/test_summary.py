"""workflows/io/summary.py: summary.json, every kind. Read and written back, every committed
results/ summary of a study case is reproduced byte for byte (the file as study wrote it,
json.dumps(indent=2) and a newline); a malformed file is refused in one line; each kind is read
by its reader only, a missing schema version is version 1 and a newer one is refused."""

import copy
import json
from pathlib import Path

from mpi4py import MPI  # noqa: F401 (loads libmpi before dolfinx)

import pytest

from tissuebench.core.errors import UserError
from tissuebench.metrics.table import METRICS
from tissuebench.workflows.io.summary import (
    SCHEMA_VERSION,
    CaseSummary,
    RunSummary,
    dumps,
    kind_of,
    read_case_summary,
    read_compare_summary,
    read_external_summary,
    read_summary,
    version_of,
    write_summary,
)
from tissuebench.workflows.study import truth as paper_truth
from tissuebench.workflows.study.cases import cases, model_cases
from tissuebench.workflows.study.paper import LARGE

RESULTS = Path(__file__).parents[1] / "results"
# every study case that `tissuebench paper` commits: part 1, part 2 and the truth's runs
FOLDERS = (
    [RESULTS / c.name for c in cases()]
    + [RESULTS / LARGE / c.name for c in model_cases()]
    + [RESULTS / c.name for c in paper_truth.cases("direct", "")]
)


def committed(folder: Path) -> tuple[str, dict]:
    text = (folder / "summary.json").read_text()
    return text, json.loads(text)


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda f: f.relative_to(RESULTS).as_posix())
def test_committed_summary_is_reproduced_byte_for_byte(folder):
    text, doc = committed(folder)
    summary = CaseSummary.from_json(doc)
    assert json.dumps(summary.to_json(), indent=2) + "\n" == text
    assert summary.dumps() == text
    # the reader gives the same, and the fields are the file's values
    again = read_case_summary(folder)
    assert again == summary and not again.skipped
    assert summary.reference_run is summary.runs[doc["reference"]]
    for label, run in doc["runs"].items():
        typed = summary.runs[label]
        assert (typed.status, typed.wall_time_s) == (run["status"], run["wall_time_s"])
        for metric in METRICS:
            for kind in ("max", "mean"):
                assert typed.reading(metric, kind) == run[f"{metric}_{kind}"]
        assert typed.has_probe == ("tip_displacement_final" in run)


def test_options_sit_between_plane_and_solver():
    _, doc = committed(RESULTS / LARGE / "block-MP1-s2-w0.2")
    summary = CaseSummary.from_json(doc)
    assert summary.options == {"load_scale": 2.0, "needle_width": 0.2}
    assert summary.option("needle_width", 0) == 0.2 and summary.option("absent", 7) == 7
    keys = list(summary.to_json())
    assert keys[keys.index("plane") + 1 : keys.index("solver")] == ["load_scale", "needle_width"]


def with_phases(doc: dict, phases: object) -> dict:
    """A copy of a summary dict with `phases_s` where the writer puts it, after system_time_s."""
    out = {}
    for key, value in doc.items():
        out[key] = value
        if key == "system_time_s":
            out["phases_s"] = phases
    return out


def test_phase_times_are_read_and_written_back_after_the_system_time():
    _, committed_doc = committed(RESULTS / "block-MP1")
    # as written before phases were timed: the committed summary without them
    doc = {key: value for key, value in committed_doc.items() if key != "phases_s"}
    assert CaseSummary.from_json(doc).phases_s is None
    assert CaseSummary.from_json(committed_doc).phases_s is not None  # the committed one's
    phases = {"mesh": 0.5, "forms": 1.25, "run implicit": 3.0, "output": 0.0}
    timed = with_phases(doc, phases)
    summary = CaseSummary.from_json(timed)
    assert summary.phases_s == phases
    assert summary.dumps() == json.dumps(timed, indent=2) + "\n"  # the place and the values
    assert CaseSummary.from_json(summary.to_json()) == summary
    # the timings are no input: the fingerprint is the one written without them
    assert summary.fingerprint == doc["fingerprint"] and "phases_s" not in summary.inputs
    for bad in ({"mesh": -1.0}, {"mesh": "fast"}, [0.5], {"mesh": float("nan")}):
        with pytest.raises(ValueError, match="phases_s"):
            CaseSummary.from_json(with_phases(doc, bad))
    last = {**doc, "phases_s": phases}  # after fingerprint: out of order
    with pytest.raises(ValueError, match="out of order"):
        CaseSummary.from_json(last)


def malformed(doc: dict) -> list[dict]:
    """Copies of a valid summary with one fault each."""
    faults = []
    for key in ("runs", "h", "fingerprint"):
        bad = copy.deepcopy(doc)
        del bad[key]
        faults.append(bad)
    bad = copy.deepcopy(doc)
    bad["mesh_size"] = "20"
    faults.append(bad)
    bad = copy.deepcopy(doc)
    bad["reference"] = "no such run"
    faults.append(bad)
    bad = {"case": doc["case"], **{k: v for k, v in doc.items() if k != "case"}}
    bad = dict(reversed(list(bad.items())))  # keys out of order
    faults.append(bad)
    label = doc["reference"]
    for change in ({"status": 1}, {"surprise": 1.0}, {"relative_error_max": "big"}):
        bad = copy.deepcopy(doc)
        bad["runs"][label].update(change)
        faults.append(bad)
    bad = copy.deepcopy(doc)
    del bad["runs"][label]["steps"]
    faults.append(bad)
    faults.append([doc])
    return faults


@pytest.mark.serial  # writes files into tmp_path, which the ranks share
def test_malformed_summaries_are_refused_in_one_line(tmp_path):
    _, doc = committed(RESULTS / "block-MP1")
    for bad in malformed(doc):
        with pytest.raises(ValueError) as err:
            CaseSummary.from_json(bad)
        assert "\n" not in str(err.value)
    # the reader: absent or not JSON -> None; JSON but not a study case's -> UserError
    assert read_case_summary(tmp_path) is None
    (tmp_path / "summary.json").write_text("{not json")
    assert read_case_summary(tmp_path) is None
    (tmp_path / "summary.json").write_text(json.dumps({"kind": "compare", "runs": {}}))
    with pytest.raises(UserError, match="not a study case's summary: lacks case"):
        read_case_summary(tmp_path)


def test_run_without_probe_writes_no_tip_and_a_diverged_step_0_writes_none():
    base = dict(
        algorithm="explicit",
        model="linear",
        material="MP2",
        status="diverged",
        diverged_step=0,
        diverged_time=0.0,
        reason="NaN",
        steps=0,
        wall_time_s=0.0,
        setup_time_s=0.0,
    )
    assert "tip_displacement_final" not in RunSummary(**base).to_json()
    entry = RunSummary(**base, has_probe=True).to_json()
    assert entry["tip_displacement_final"] is None
    assert RunSummary.from_json(entry) == RunSummary(**base, has_probe=True)


@pytest.mark.serial  # rewrites one file in turn: ranks sharing tmp_path would race
def test_every_kind_has_its_reader_and_one_writer(tmp_path):
    """A case summary (no `kind`, no version: version 1), a compare and an external one: the
    writer gives the text that json.dumps(indent=2) and a newline give, each typed reader reads
    its kind and None for another."""
    text, doc = committed(RESULTS / "rod-MP3")
    assert (kind_of(doc), version_of(doc)) == ("case", 1)
    write_summary(tmp_path, read_case_summary(RESULTS / "rod-MP3"))
    assert (tmp_path / "summary.json").read_text() == text  # the committed bytes
    assert read_compare_summary(tmp_path) is None and read_external_summary(tmp_path) is None
    for kind, reader in (("compare", read_compare_summary), ("external", read_external_summary)):
        data = {"kind": kind, "schema_version": SCHEMA_VERSION, "runs": {}, "files": []}
        write_summary(tmp_path, data)
        assert (tmp_path / "summary.json").read_text() == json.dumps(data, indent=2) + "\n"
        assert dumps(data) == json.dumps(data, indent=2) + "\n"
        assert reader(tmp_path) == data == read_summary(tmp_path)
        assert kind_of(data) == kind and version_of(data) == SCHEMA_VERSION
        with pytest.raises(UserError, match="not a study case's summary"):
            read_case_summary(tmp_path)
        older = {k: v for k, v in data.items() if k != "schema_version"}
        write_summary(tmp_path, older)
        assert reader(tmp_path) == older and version_of(older) == 1
        write_summary(tmp_path, {**data, "schema_version": SCHEMA_VERSION + 1})
        with pytest.raises(UserError, match="schema version"):
            reader(tmp_path)
    write_summary(tmp_path, {**doc, "schema_version": 2})
    with pytest.raises(UserError, match="schema version 2"):
        read_case_summary(tmp_path)
