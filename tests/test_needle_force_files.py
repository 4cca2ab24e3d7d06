"""compare's --needle-force and an edited export (the fourth red team): a FIFO, a folder, a cell
beyond the csv module's limit, a force of the wrong number of components, and an export whose
reference force or load scale was edited into something else are each one line, exit status
2, no hang, no traceback, nothing written."""

import json
import os
import shutil

import pytest
from helpers import tissuebench
from test_inputs import one_line

pytestmark = [pytest.mark.serial, pytest.mark.usefixtures("empty_truth_cache")]


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    folder = tmp_path_factory.mktemp("contact-export")
    out = folder / "contact.json"
    r = tissuebench("export", "contact", "--mesh-size", 4, "--end-time", 0.1, "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    return folder


def compare(folder, force, tmp_path, timeout=120):
    reference = folder / "contact.reference.xdmf"
    out = tmp_path / "graded"
    args = ("compare", reference, reference, "--out", out, "--needle-force", force)
    return tissuebench(*args, timeout=timeout), out


def test_a_fifo_a_folder_and_a_huge_cell(export, tmp_path):
    fifo = tmp_path / "force.fifo"
    os.mkfifo(fifo)
    huge = tmp_path / "huge.csv"
    huge.write_text("time,force_x,force_y\n0," + "1" * 200_000 + ",0\n")
    for force, words in ((fifo, "not a regular file"), (tmp_path, "a folder"), (huge, "CSV")):
        result, out = compare(export, force, tmp_path, timeout=60)  # a FIFO once hung here
        assert words in one_line(result), force
        assert not out.exists()


def test_a_force_of_the_wrong_dimension(export, tmp_path):
    force = tmp_path / "force.csv"
    force.write_text("time,force_x,force_y,force_z\n0,0,0,0\n0.0333333333333,1,0,0\n")
    result, out = compare(export, force, tmp_path)
    assert "3 force components" in one_line(result)
    assert not out.exists()


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda d: d["reference"]["contact"].update(force=[[1, 2, 3]]), "reference.contact"),
        (lambda d: d["reference"]["contact"].update(force="abc"), "reference.contact"),
        (lambda d: d["options"].update(load_scale="abc"), "load_scale"),
    ],
)
def test_an_edited_export(export, tmp_path, edit, words):
    edited = tmp_path / "edited"
    shutil.copytree(export, edited)
    path = edited / "contact.json"
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))
    force = tmp_path / "force.csv"
    force.write_text("time,force_x,force_y\n0,0,0\n")
    result, out = compare(edited, force, tmp_path)
    assert words in one_line(result)
    assert not out.exists()
