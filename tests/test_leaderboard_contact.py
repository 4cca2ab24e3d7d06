"""A contact case on the leaderboard (SPEC 12): its rows carry the force error and the
interpenetration in the record, leaderboard.csv, leaderboard.md and the page, with a force
figure; a simulator without a contact adapter (workflows/simulators/contact/) is not run on it.

A tiny case of ours (N = 4, 0.5 s) and two stand-in simulators: `mirror`, whose contact
adapter (registered in ADAPTERS from here) hands back our reference's own series and force (so
its force error must be exactly 0 and its interpenetration, measured by compare from the
series file, what our run's Measures recorded for the reference, to round-off), and `plain`,
which poses no contact."""

import argparse
import csv
import json
import sys
import types

import numpy as np
import pytest

from tissuebench.workflows.io.tables import write_force_csv
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard import runs
from tissuebench.workflows.leaderboard.rows import Board
from tissuebench.workflows.simulators import ExternalRun, runner
from tissuebench.workflows.simulators.contact import ADAPTERS

pytestmark = pytest.mark.serial  # the whole command on rank 0's files


def simulator(name: str) -> types.ModuleType:
    module = types.ModuleType(name)

    def run(data, variant, workdir):
        reference = workdir.parent.parent / "reference.xdmf"  # the runner's, beside the variant
        force = np.asarray(data.reference["contact"]["force"])
        path = workdir / "force.csv"
        write_force_csv(path, np.arange(len(force)) * data.h, force)
        return ExternalRun(reference, 0.01, int(data.nodes.size), "displacement", force=path)

    module.__dict__.update(
        NAME=name,
        TITLE=name.title(),
        available=lambda: None,
        variants=lambda data: {"copy": "our reference handed back"},
        skipped=lambda data: {},
        run=run,
    )
    return module


@pytest.fixture(scope="module")
def board_out(tmp_path_factory):
    fakes = {"mirror": simulator("mirror"), "plain": simulator("plain")}
    board = Board(
        "contact-tiny", "contact", "MP1", "linear", mesh_size=4, end_time=0.5,
        options={"kappa": 10.0, "load_scale": 1.0}, simulators=("mirror", "plain"),
        description="contact, N = 4, 0.5 s",
    )  # fmt: skip
    out = tmp_path_factory.mktemp("board") / "results"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(leaderboard, "BOARDS", [board])
        for module in (leaderboard, runs, runner):
            mp.setattr(module, "get_simulator", fakes.__getitem__)
        # mirror's contact adapter: one line in the registry (the fake poses contact as it
        # poses anything else: it hands back our reference)
        mp.setitem(sys.modules, "tests_mirror_contact", fakes["mirror"])
        mp.setitem(ADAPTERS, "mirror", {"half-stadium": "tests_mirror_contact"})
        args = argparse.Namespace(out=out, solver="direct", petsc="", force=False, rerun=[])
        assert leaderboard.main(args) == 0
    return out


def test_the_contact_columns_in_record_csv_md_and_page(board_out):
    out = board_out
    (case,) = json.loads((out / "leaderboard.json").read_text())["cases"]
    rows = {r["label"]: r for r in case["rows"]}
    ours = rows["implicit"]
    assert ours["reference"] and ours["contact"]["force_error"] == 0.0
    depth = ours["contact"]["interpenetration_max"]
    assert depth > 0.001  # m: our penalty lets the tissue into the needle
    mirror = rows["mirror:copy"]
    assert mirror["contact"]["force_error"] == 0.0  # its force is our reference's
    assert mirror["contact"]["interpenetration_max"] == pytest.approx(depth, abs=1e-12)
    assert "plain:copy" not in rows
    assert "plain: cannot pose a rigid tool in contact here" in case["notes"]
    for label in ("explicit", "explicit-lumped", "quasi-static", "implicit-lumped"):
        assert rows[label]["contact"]["force_error"] > 0  # not the reference's force
        assert "against our implicit's force" in rows[label]["contact"]["force_error_how"]
    with open(out / "leaderboard.csv", newline="") as f:
        table = {r["label"]: r for r in csv.DictReader(f)}
    assert float(table["mirror:copy"]["force_error"]) == 0.0
    assert float(table["implicit"]["interpenetration_max"]) == depth
    md = (out / "leaderboard.md").read_text()
    assert "| force error | interpenetration (m) |" in md
    assert "contact-tiny-force.png" in md
    page = (out / "leaderboard" / "index.html").read_text()
    assert "<th>force error</th><th>interpenetration (m)</th>" in page
    assert f"<td>{depth:.3g}</td>" in page
    png = out / "leaderboard" / "contact-tiny-force.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # every force travels in the record (force_curve.py): mirror's is our reference's
    curve = ours["force_curve"]
    assert curve["unit"] == "N/m" and len(curve["times"]) == len(curve["force"]) > 1
    assert mirror["force_curve"] == curve
    assert all(r["force_curve"] for r in rows.values() if r.get("force"))


def test_the_record_alone_draws_every_force(board_out, tmp_path, monkeypatch):
    """The record copied alone (no force file beside it), drawn from another folder: every
    recorded row's force is drawn, none said missing."""
    from test_leaderboard_force_curve import drawn

    from tissuebench.workflows.leaderboard.record import read_record

    copy = tmp_path / "copy"
    copy.mkdir()
    (copy / "leaderboard.json").write_text((board_out / "leaderboard.json").read_text())
    monkeypatch.chdir(tmp_path)
    (board,), rows, _ = read_record(copy)
    lines, texts = drawn(monkeypatch, tmp_path, board, rows[board.name])
    assert {"implicit (reference)", "mirror:copy", "explicit"} <= set(lines)
    assert not any("not" in text and "force" in text for text in texts)


def test_a_record_without_contact_rows_has_no_contact_fields(board_out, tmp_path):
    """A row of another case reads and writes back without the contact fields (the record,
    the csv and the md of the other cases stay as they were)."""
    from tissuebench.workflows.leaderboard.record import row_record
    from tissuebench.workflows.leaderboard.rows import Row, error_keys, write_csv

    errors = dict.fromkeys(error_keys(), 1e-3)
    row = Row(
        "rod", "implicit", "tissuebench", "", "reference", 3, "ok", None, errors, 1.0, 10.0, ""
    )
    assert "contact" not in row_record(row) and "force" not in row_record(row)
    write_csv(tmp_path / "a.csv", [row])
    assert "force_error" not in (tmp_path / "a.csv").read_text()


def test_a_users_row_on_a_contact_case(board_out, tmp_path, monkeypatch):
    """A user's compare of our explicit run, with its force (--needle-force), joins the case:
    the leaderboard grades its series and force file itself, and gets the explicit row's force
    error (against our implicit: the case has no truth) and, from the series, the
    interpenetration our run's Measures recorded."""
    import shutil

    from tissuebench.workflows.compare.grading import compare

    out = tmp_path / "results"
    shutil.copytree(board_out, out)
    case = out / "leaderboard" / "contact-tiny"
    compare(
        case / "ours" / "implicit.xdmf",
        case / "ours" / "explicit.xdmf",
        case / "user" / "mine",
        label="mine",
        wall_time=1.0,
        needle_force=case / "forces" / "explicit.csv",
    )
    monkeypatch.setattr(leaderboard, "BOARDS", leaderboard.read_record(out)[0])
    args = argparse.Namespace(out=out, solver="direct", petsc="", force=False, rerun=None)
    assert leaderboard.main(args) == 0
    (record,) = json.loads((out / "leaderboard.json").read_text())["cases"]
    rows = {r["label"]: r for r in record["rows"]}
    mine, explicit = rows["mine"]["contact"], rows["explicit"]["contact"]
    assert mine["force_error"] == explicit["force_error"] > 0
    assert mine["interpenetration_max"] == pytest.approx(
        explicit["interpenetration_max"], abs=1e-12
    )
    assert mine["force_error_how"] == "against our implicit's force"
    assert rows["mine"]["force_curve"] == rows["explicit"]["force_curve"]  # its file's, kept
