"""The warm paper's part 2 shared with a second process (workflows/study/beside.py): the same
report, its wall times aside, as one process alone, each case run once."""

import json
import tempfile
from pathlib import Path

import pytest
from helpers import tissuebench

from tissuebench.workflows.study.beside import claim

# part 1's smallest case (the report needs one) and two of part 2, so that each process
# takes one of part 2: the worker the first, the paper the last
CASES = ["block-MP1", "block-MP1-s1", "block-MP1-s2-w0.2"]
TIMING = ("setup_time_s", "system_time_s", "wall_time_s", "phases_s", "created", "versions")


def numbers(folder: Path) -> dict:
    """A case folder's summary.json without its timings."""

    def strip(d):
        if isinstance(d, dict):
            return {k: strip(v) for k, v in d.items() if k not in TIMING}
        if isinstance(d, list):
            return [strip(x) for x in d]
        return d

    return strip(json.loads((folder / "summary.json").read_text()))


def report_without_times(path: Path) -> list[str]:
    """The report's lines, each table row without its last cell (a wall time)."""
    lines = path.read_text().splitlines()
    return [line.rsplit("|", 2)[0] if line.startswith("|") else line for line in lines]


def test_a_case_is_claimed_once():
    with tempfile.TemporaryDirectory() as claims:
        assert claim(Path(claims), "rod-MP3-s1")
        assert not claim(Path(claims), "rod-MP3-s1")
        assert claim(Path(claims), "rod-MP3-s3")


@pytest.mark.serial
def test_part_2_beside_gives_the_report_of_one_process(tmp_path):
    alone, beside = tmp_path / "alone", tmp_path / "beside"
    one = tissuebench("paper", "--out", alone, "--jobs", "1", "--cases", *CASES)
    assert one.returncode == 0, one.stderr[-2000:]
    assert "second process" not in one.stdout
    two = tissuebench("paper", "--out", beside, "--jobs", "2", "--cases", *CASES)
    assert two.returncode == 0, two.stderr[-2000:]
    assert "shared with a second process" in two.stdout
    for case in CASES[1:]:
        folder = Path("large-deformation") / case
        assert numbers(beside / folder) == numbers(alone / folder), case
        # run once, by one of the two: no folder said skipped as an earlier run's
        assert f"{beside / folder}: complete results" not in two.stdout
    assert report_without_times(beside / "README.md") == report_without_times(alone / "README.md")
