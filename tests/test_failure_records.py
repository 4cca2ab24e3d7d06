"""A truth's failure record (solvers/truth/store.py record_failure) read defensively (the fourth
red team): one holding [], null, or without its time, edited or cut short, is said in one line
and ignored, where `run rod` and `truth all --quick` ended in AttributeError and KeyError
tracebacks; a whole one is read as written."""

import json

import pytest

from tissuebench.solvers.truth import store

pytestmark = pytest.mark.serial  # a cache of its own


def whole(case: str) -> dict:
    return {
        "case": case,
        "fingerprint": store.fingerprint_of(case, True),
        "level": 4,
        "t": 0.5,
        "error": "Newton did not converge",
        "smallest_J": 0.2,
        "smallest_J_at": [0.1, 0.0, 0.0],
        "levels_done": [1, 2],
        "levels_done_smallest_J": [0.6, 0.4],
        "wall": [0.1, 0.5],
        "when": "2026-11-29 00:00 UTC",
    }


@pytest.mark.parametrize(
    "record, said",
    [
        ([], "not an object"),
        (None, "not an object"),
        ("t", "not an object"),
        ({"drop": "t"}, "(t)"),
        ({"t": "soon"}, "(t)"),
        ({"levels_done": None, "level": "4"}, "level, levels_done"),
    ],
)
def test_a_malformed_record_is_said_and_ignored(tmp_path, monkeypatch, capsys, record, said):
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path))
    case = "rod"
    if isinstance(record, dict):
        edited = whole(case)
        edited.pop(record.pop("drop", None), None)
        record = edited | record
    path = store.failure_path(case, True)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(record))
    assert store.load_failure(case, True) is None
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"tissuebench: truth {case}: {path}") and said in line


def test_a_whole_record_is_read(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path))
    path = store.failure_path("rod", True)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(whole("rod")))
    assert store.load_failure("rod", True) == whole("rod")
    assert capsys.readouterr().err == ""
