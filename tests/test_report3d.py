"""The README's section on the needle in 3D (workflows/contact/report3d.py) reads the cylinder
boards of a leaderboard record: its table ranks by E_i max against the truth, each simulator is
named by its best row, and the row picked at real-time cost is the most accurate of those that
run at most as fast as time (not the cheapest, nor one slower than time)."""

import json
from pathlib import Path

import pytest

from tissuebench.workflows.contact import report3d

pytestmark = pytest.mark.serial


def _row(label: str, e_max: float, wall: float, status: str = "ok") -> dict:
    return {
        "label": label,
        "dofs": 1000,
        "status": status,
        "truth": {"interior_error_max": e_max},
        "contact": {"force_error": 0.1, "interpenetration_max": 0.002},
        "wall_time_s": wall,
        "end_time": 10.0,
    }


def test_the_3d_section_ranks_and_picks_from_the_record(tmp_path: Path):
    board = {"name": "cylinder-X", "benchmark": "cylinder", "truth": "cylinder-X",
             "mesh_size": None, "truth_band": 1e-6, "skip_note": "not run: none"}  # fmt: skip
    rows = [
        _row("implicit", 1e-4, 200.0),  # the most accurate, slower than time (20 s/s)
        _row("mujoco:fast", 9e-3, 2.0),  # real time, the least accurate
        _row("drake:linear", 3e-3, 8.0),  # real time (0.8 s/s), more accurate
        _row("drake:stiff", 5e-3, 5.0),  # drake's worse variant
        _row("newton:vbd", 1e-5, 30.0, status="diverged"),  # did not finish: not picked
    ]
    other = {"board": {**board, "benchmark": "contact", "name": "contact-X"}, "rows": []}
    (tmp_path / "leaderboard.json").write_text(
        json.dumps({"cases": [other, {"board": board, "rows": rows}]})
    )
    text = "\n".join(report3d.paper_section(tmp_path))
    assert "## The needle in 3D (SPEC 13)" in text
    table = [line for line in text.splitlines() if " | 1,000 dofs | " in line]
    assert [line.split(" | ")[0][2:] for line in table] == [
        "implicit",
        "drake:linear",
        "drake:stiff",
        "mujoco:fast",
        "newton:vbd",
    ]  # fmt: skip (ranked by E_i max; the run that did not finish last)
    assert "- drake (best: drake:linear)" in text and "drake:stiff)" not in text
    assert "newton" not in text.split("What each simulator loses")[1].split("At real-time")[0]
    assert "the smallest E_i max against the truth is drake:linear's" in text


def test_no_record_no_section(tmp_path: Path):
    assert report3d.paper_section(tmp_path) == []
