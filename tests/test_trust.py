"""Nothing read is trusted (issue 23, item 4). The leaderboard reads users' compare folders,
its own earlier table and the mesh-sensitivity study's report; the study reads the rows it
saved. Checked: a user folder graded on another case (its reference's fingerprint), and a
row with a bad label, status, wall time or metric, is left out with one line naming it,
before anything runs, and the rest
is written; every text read is escaped in leaderboard.md; a user's label never names a
simulator; a NaN never ranks; a saved rows file that does not parse is recomputed, serial
and under mpiexec (the study test is collective)."""

import argparse
import csv
import json
import math
import shutil
from pathlib import Path

from mpi4py import MPI

import pytest

from tissuebench.solvers import ALGORITHMS
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.io.manifest import seal
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard import figures as document
from tissuebench.workflows.leaderboard import rows as ranking
from tissuebench.workflows.leaderboard import users as user_folders
from tissuebench.workflows.leaderboard.figures import markdown
from tissuebench.workflows.leaderboard.mesh_sensitivity import (
    MARKER,
    STUDIES,
    Study,
    leaderboard_boards,
    run_study,
)
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, mark_pareto, pareto

COMM = MPI.COMM_WORLD
TINY = Study("rod-MP3", "rod", "MP3", 4, end_time=0.2)  # grids 1, 2, 4; 6 steps of 1/30 s
# the case of a user's run graded on TINY's grid of size 4 (the same mesh, h and T): the
# rod's 8 x 4 x 4 hexahedra, 9 x 5 x 5 = 225 nodes
ROD = Board("rod-tiny", "rod", "MP3", "linear", simulators=(), mesh_size=4, end_time=0.2,
            description="rod, n = 4, 0.2 s")  # fmt: skip
BLOCK = Board("block-tiny", "block", "MP1", "linear", simulators=(), end_time=0.2,
              description="block, 0.2 s")  # fmt: skip
HOSTILE = "x|y<script>alert(1)</script>"


def all_ranks(flag: bool) -> bool:
    return COMM.allreduce(bool(flag), op=MPI.LAND)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """TINY's study run once (its series serve as a user's runs): its output folder."""
    out = Path(COMM.bcast(str(tmp_path_factory.mktemp("study")) if COMM.rank == 0 else None))
    result = run_study(TINY, out, "direct", "", COMM, log=lambda line: None, quick=True)
    assert len(result["rows"]) == 3 * 3 * len(ALGORITHMS)
    return out


def series(study: Path, name: str) -> Path:
    return study / "mesh-sensitivity-quick" / TINY.name / f"hexahedron-grid-4-{name}.xdmf"


@pytest.fixture(scope="module")
def graded(study):
    """A user's compare folder, graded on ROD's case (rank 0 writes; serial tests only)."""
    from helpers import tissuebench

    folder = study / "graded"
    ref = study / "reference"  # a run folder of ours: compare records its case (issue 26)
    r = tissuebench("run", "rod", "--mesh-size", "4", "--material", "MP3", "--end-time", "0.2",
                    "--algorithms", "implicit", "--out", ref)  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    compare(ref / "implicit.xdmf", series(study, "explicit-lumped"), folder,
            label="my-solver", wall_time=0.25, comm=MPI.COMM_SELF)  # fmt: skip
    return folder


def user_folder(graded: Path, where: Path, change=None, label=None) -> Path:
    """A copy of the graded folder at `where`, its summary.json changed by change(run, summary)
    and its run renamed to `label`."""
    shutil.copytree(graded, where)
    summary = json.loads((where / "summary.json").read_text())
    (old, run), = summary["runs"].items()  # fmt: skip
    if change:
        change(run, summary)
    summary["runs"] = {label or old: run}
    (where / "summary.json").write_text(json.dumps(summary))
    seal(where)  # as compare would have written it: its manifest holds the summary's hash
    return where


MALFORMED = {  # folder name -> (change to its run or summary, what the line says)
    "negative-wall": (lambda r, s: r.update(wall_time_s=-1.0), "wall_time_s -1.0 is not"),
    "text-wall": (lambda r, s: r.update(wall_time_s="fast"), "wall_time_s 'fast' is not"),
    "no-wall": (lambda r, s: r.pop("wall_time_s"), "no wall_time_s"),
    "nan-error": (lambda r, s: r.update(interior_error_mean=math.nan), "interior_error_mean nan"),
    "negative-error": (lambda r, s: r.update(relative_error_max=-1), "relative_error_max -1"),
    "no-metric": (lambda r, s: r.pop("surface_error_max"), "no surface_error_max"),
    "odd-status": (lambda r, s: r.update(status="great"), "status 'great' is not one of"),
    "no-end-time": (lambda r, s: s.pop("end_time"), "no positive numbers h and end_time"),
    "text-end-time": (lambda r, s: s.update(end_time="10"), "no positive numbers h and end_time"),
    "negative-end-time": (lambda r, s: s.update(end_time=-0.2), "no positive numbers h"),
    "other-steps": (lambda r, s: s.update(steps=12), "graded over 12 steps"),
    "no-reference": (lambda r, s: s.update(reference={}), "records no fingerprint of its"),
    "unknown-reference": (  # graded against a file of no run folder or export of ours
        lambda r, s: s["reference"]["fingerprint"].update(source="file", benchmark=None),
        "so its case is not known: compare against the reference `tissuebench export` writes",
    ),
    "not-compare": (lambda r, s: s.update(kind="run"), "its summary.json is not compare's"),
}


@pytest.mark.serial
def test_user_rows_leave_out_what_is_malformed(graded, tmp_path):
    """One good folder and one of each malformed kind: the good one is a row with the
    numbers compare wrote, every other is left out in one line naming its folder and why."""
    user = tmp_path / "user"
    good = user_folder(graded, user / "good", label=HOSTILE)
    for name, (change, _) in MALFORMED.items():
        user_folder(graded, user / name, change)
    user_folder(graded, user / "newline", label="a\n## PWNED")
    user_folder(graded, user / "long", label="x" * 65)
    (user / "empty").mkdir()
    (user / "garbage").mkdir()
    (user / "garbage" / "summary.json").write_text('{"kind": "compare", "runs": {"a": ')
    rows, skipped = ranking.user_rows(ROD, user)
    assert [r.label for r in rows] == [HOSTILE]
    assert rows[0].source == "user" and rows[0].wall_time_s == 0.25
    # no number is taken from the folder: the leaderboard grades its series (grading.py)
    assert rows[0].errors == dict.fromkeys(error_keys()) and rows[0].status == "not graded"
    summary = json.loads((good / "summary.json").read_text())
    assert rows[0].series == summary["candidate"]["file"]
    assert rows[0].series_hash == ranking.series_hash(summary["inputs"]["candidate"]["files"])
    assert len(skipped) == len(MALFORMED) + 4
    for line in skipped:
        assert "\n" not in line and str(user) in line
    for name, (_, why) in MALFORMED.items():
        line = next(x for x in skipped if x.startswith(f"{user / name}:"))
        assert why in line, line
    newline = next(x for x in skipped if x.startswith(f"{user / 'newline'}:"))
    assert "a\\n## PWNED" in newline and "not printable" in newline
    assert any(x.startswith(f"{user / 'long'}:") and "1 to 64" in x for x in skipped)
    assert any(x.startswith(f"{user / 'empty'}: left out: no readable summary") for x in skipped)
    assert any(x.startswith(f"{user / 'garbage'}: left out: no readable") for x in skipped)


@pytest.mark.serial
def test_a_run_of_another_case_is_refused(graded, tmp_path):
    """The rod's compare under the block's user/ (same h, steps and T: only the reference's
    dimension tells), or under a rod case of another mesh size, is left out."""
    user = user_folder(graded, tmp_path / "user" / "rod-run").parent
    rows, skipped = ranking.user_rows(BLOCK, user)
    assert rows == [] and len(skipped) == 1
    assert skipped[0].startswith(f"{user / 'rod-run'}: left out: graded against ")
    assert "3D, 225 nodes, not this case (block-tiny: block MP1 linear" in skipped[0]
    assert skipped[0].endswith("2D, 441 nodes): compare against block-tiny's reference, or "
                               "move the folder under its own case")  # fmt: skip
    finer = Board("rod-n6", "rod", "MP3", "linear", simulators=(), mesh_size=6, end_time=0.2)
    rows, skipped = ranking.user_rows(finer, user)
    assert rows == [] and "3D, 637 nodes): compare against rod-n6's" in skipped[0]
    longer = Board("rod-1s", "rod", "MP3", "linear", simulators=(), mesh_size=4, end_time=1.0)
    rows, skipped = ranking.user_rows(longer, user)
    assert rows == [] and "the case is 30 steps of h = 0.0333333 s to T = 1 s" in skipped[0]
    assert len(ranking.user_rows(ROD, user)[0]) == 1  # its own case takes it


def row(label, cost, mean, status="ok", source="user", **kw) -> Row:
    errors = dict.fromkeys(error_keys())
    errors.update(interior_error_mean=mean, interior_error_max=mean)
    return Row("c", label, source, "d", "?", 0, status, None, errors, cost, 1.0, "t", **kw)


def test_a_nan_never_ranks():
    """NaN or infinite costs and errors are never on the front and never push a finite run
    off it; the reference and a run that did not finish never rank."""
    assert pareto([(1, math.nan), (2, 1.0), (math.nan, 0.1), (math.inf, 0.1), (3, math.inf)]) == [
        False, True, False, False, False,
    ]  # fmt: skip
    rows = [
        row("nan", 0.1, math.nan),
        row("fine", 1.0, 1e-3),
        row("nan-cost", math.nan, 1e-9),
        row("inf", 0.01, math.inf),
        row("diverged", 0.01, 1e-9, status="diverged"),
        row("ref", 0.01, 0.0, reference=True, source="tissuebench"),
        row("better", 2.0, 1e-4),
        row("worse", 3.0, 1e-2),
    ]
    mark_pareto(rows)
    front = {r.label for r in rows if r.pareto.get("mean")}
    assert front == {"fine", "better"}
    assert all(not r.pareto.get("max") for r in rows if r.label not in front)
    table = document.table(rows)
    nan = next(line for line in table if line.startswith("| nan |"))
    assert nan.endswith("| -/- |") and " | - | " in nan  # shown, not ranked
    order = [line.split(" |")[0][2:] for line in table[2:]]
    assert order.index("nan") > order.index("worse")  # sorted after every finite E_i


def test_markdown_escapes_every_text_read():
    """A label with HTML, a pipe or a newline, and a description, mesh, status and note
    from a summary.json, are literal text in leaderboard.md: no tag, no extra column, no
    heading, no line of their own."""
    board = Board("c", "rod", "MP3", "linear", description="the case")
    hostile = [
        row(HOSTILE, 1.0, 1e-3),
        row("a\n## PWNED", 1.0, 1e-3),
        row("b", 1.0, 1e-3, source="Evil <b>sim</b> | 1", group=None),
    ]
    hostile[2].description = "*DYNAMIC* `code` [link](http://x) $x$ ~~s~~ _e_ & \\"
    hostile[2].mesh = "m\r\n# mesh"
    hostile[2].status, hostile[2].reason = "failed", "<img src=x onerror=alert(1)>"
    text = markdown([board], {"c": hostile}, {"c": ["note\n## PWNED <script>"]}, "now")
    assert "<" not in text.replace("&lt;", "") and ">" not in text.replace("&gt;", "")
    assert not any(line.lstrip("- ").startswith("#") and "PWNED" in line
                   for line in text.splitlines())  # fmt: skip
    assert "x\\|y&lt;script&gt;alert(1)&lt;/script&gt;" in text
    table = [line for line in text.splitlines() if line.startswith("| ")]
    for line in table:  # 11 columns: 12 pipes that are not escaped
        assert line.replace("\\|", "").count("|") == 12, line
    assert (
        "\\*DYNAMIC\\* \\`code\\` \\[link\\](http://x) \\$x\\$ \\~\\~s\\~\\~ \\_e\\_ &amp; \\\\"
        in text
    )
    lines = text.splitlines()
    assert sum("PWNED" in line for line in lines) == 3  # its row, its list entry, the note
    assert len(lines) == len(
        markdown([board], {"c": hostile[:1] * 3}, {"c": ["n"]}, "now").splitlines()
    )


def test_a_user_label_never_names_a_simulator(tmp_path):
    """A user's `my:solver` in leaderboard.csv is no simulator's row; another simulator's
    row that cannot run here still keeps the table."""
    rows = [row("my:solver", 1.0, 1e-3), row("implicit", 1.0, 0.0, source="tissuebench")]
    if COMM.rank == 0:
        ranking.write_csv(tmp_path / "leaderboard.csv", rows)
    COMM.barrier()
    leaderboard.check_target(tmp_path, set(), force=False)  # no refusal: nothing of "my"
    COMM.barrier()  # every rank has read it before it changes
    if COMM.rank == 0:
        with open(tmp_path / "leaderboard.csv", "a", newline="") as f:
            csv.writer(f).writerow(["c", "elsewhere:fast", "Elsewhere 1.0"])
    COMM.barrier()
    with pytest.raises(leaderboard.OutputError, match="rows of elsewhere, which cannot run"):
        leaderboard.check_target(tmp_path, set(), force=False)


def sensitivity_row(**change) -> dict:
    """One row of mesh-sensitivity.csv (text) of the rod's study."""
    good = {
        "case": "rod-MP3", "algorithm": "explicit", "shape": "hexahedron grid", "cell":
        "hexahedron", "mesh": "structured", "size": "4", "spacing_m": "0.25", "nodes": "125",
        "cells": "64", "dofs": "375", "status": "ok", "diverged_time_s": "", "steps": "300",
        "wall_time_s": "1.5", "end_time_s": "10.0", "cost_s_per_s": "0.15",
        "session": "2026-11-23 10:00 UTC",
    }  # fmt: skip
    good.update({k: "0.001" for k in error_keys() if not k.startswith("surface")})
    return {**good, **change}


def test_sensitivity_report_that_cannot_be_read_is_left_out(tmp_path):
    """An empty mesh-sensitivity.md beside its table: no runs, one line. A table whose rows
    are partly malformed: the good rows join the leaderboard, each bad one is one line."""
    lines = []
    if COMM.rank == 0:
        (tmp_path / "mesh-sensitivity.md").write_text("")
        rows = [sensitivity_row()]
        with open(tmp_path / "mesh-sensitivity.csv", "w", newline="") as f:
            out = csv.DictWriter(f, list(rows[0]))
            out.writeheader()
            out.writerows(rows)
        assert leaderboard_boards(tmp_path, lines.append) == []
        assert lines == [f"{tmp_path / 'mesh-sensitivity.md'}: not a report of tissuebench "
                         "sensitivity; its runs are left out"]  # fmt: skip
        (tmp_path / "mesh-sensitivity.md").write_text(f"{MARKER}\n\nthe study\n")
        bad = [
            sensitivity_row(wall_time_s="-1"),
            sensitivity_row(wall_time_s="fast"),
            sensitivity_row(end_time_s=""),
            sensitivity_row(interior_error_max="-0.5"),
            sensitivity_row(algorithm="<script>"),
            sensitivity_row(size="3"),
            sensitivity_row(nodes=None),
            sensitivity_row(status="diverged", diverged_time_s="soon"),
        ]
        nan = sensitivity_row(algorithm="implicit", interior_error_mean="nan",
                              session="<b>\n## PWNED")  # fmt: skip
        with open(tmp_path / "mesh-sensitivity.csv", "w", newline="") as f:
            out = csv.DictWriter(f, list(rows[0]))
            out.writeheader()
            out.writerows([rows[0], *bad, nan])
        lines.clear()
        boards = leaderboard_boards(tmp_path, lines.append)
        assert len(lines) == len(bad)
        assert all(f"mesh-sensitivity.csv, row {i}: not a run" in line
                   for i, line in enumerate(lines, start=2))  # fmt: skip
        (board, found), = boards  # fmt: skip
        assert board.name == f"mesh-sensitivity-{STUDIES[1].name}"
        assert [r.label for r in found] == [
            "explicit (hexahedron grid, size 4)", "implicit (hexahedron grid, size 4)"
        ]  # fmt: skip
        assert (
            found[0].cost == pytest.approx(0.15) and found[1].errors["interior_error_mean"] is None
        )
        assert "PWNED" not in board.description and "?" in found[1].timing
        mark_pareto(found)
        assert found[0].pareto == {"mean": True, "max": True} and "mean" not in found[1].pareto
    assert all_ranks(True)


@pytest.mark.parallel
def test_saved_rows_that_do_not_parse_are_recomputed(study, tmp_path):
    """A truncated rows-*.json, and one whose rows lost a key, are run again (one line
    each); the other meshes are read back untouched; the numbers are those of the first
    run. Collective: serial and under mpiexec alike."""
    out = tmp_path / "again"
    saved = out / "mesh-sensitivity-quick" / TINY.name
    if COMM.rank == 0:
        shutil.copytree(study / "mesh-sensitivity-quick", out / "mesh-sensitivity-quick")
    COMM.barrier()
    first = run_study(TINY, out, "direct", "", COMM, log=lambda line: None, quick=True)["rows"]
    truncated, keyless = (
        saved / "rows-tetrahedron-grid-2.json",
        saved / "rows-hexahedron-grid-1.json",
    )
    if COMM.rank == 0:
        text = truncated.read_text()
        truncated.write_text(text[: len(text) // 2])
        record = json.loads(keyless.read_text())
        del record["rows"][2]["interior_error_max"]
        keyless.write_text(json.dumps(record))
    COMM.barrier()
    others = sorted(set(saved.glob("rows-*.json")) - {truncated, keyless})
    before = {p: p.stat().st_mtime_ns for p in others}
    lines = []
    again = run_study(TINY, out, "direct", "", COMM, log=lines.append, quick=True)["rows"]
    if COMM.rank == 0:
        assert any(
            line.startswith(
                f"{truncated}: cannot be read (JSONDecodeError); this mesh is run again"
            )
            for line in lines
        ), lines
        assert any(
            line.startswith(
                f"{keyless}: holds a row without interior_error_max; this mesh is run again"
            )
            for line in lines
        ), lines
        ran = [line for line in lines if " ok: " in line or "DIVERGED" in line]
        assert len(ran) == 2 * len(ALGORITHMS)  # the two meshes, nothing else
    assert {p: p.stat().st_mtime_ns for p in others} == before
    key = ("shape", "size", "algorithm")
    first = {tuple(r[k] for k in key): r for r in first}
    assert len(again) == len(first)
    for r in again:
        assert r["interior_error_max"] == pytest.approx(
            first[tuple(r[k] for k in key)]["interior_error_max"], rel=1e-9
        )


@pytest.mark.serial
def test_leaderboard_leaves_out_bad_user_folders_before_it_runs(
    study, graded, tmp_path, monkeypatch
):
    """End to end on a tiny rod case without simulators: malformed and misplaced user folders
    and an empty mesh-sensitivity report are each said in one line on stderr before the first
    run starts; the leaderboard is written with the good user rows, escaped, and a rerun is
    not blocked by a user's label with ':'."""
    monkeypatch.setattr(leaderboard, "BOARDS", [ROD])
    user = tmp_path / "leaderboard" / ROD.name / "user"
    user_folder(graded, user / "hostile", label=HOSTILE)
    user_folder(graded, user / "colon", label="my:solver")
    user_folder(graded, user / "newline", label="x\n## PWNED")
    for name in ("negative-wall", "text-wall", "no-wall", "nan-error", "no-end-time"):
        user_folder(graded, user / name, MALFORMED[name][0])
    (tmp_path / "mesh-sensitivity.md").write_text("")
    (tmp_path / "mesh-sensitivity.csv").write_text("case,algorithm\nrod-MP3,implicit\n")
    events = []
    monkeypatch.setattr(user_folders, "warn", lambda line: events.append(("warn", line)))
    run_board = leaderboard.run_board

    def recorded(board, *args, **kw):
        events.append(("run", board.name))
        return run_board(board, *args, **kw)

    monkeypatch.setattr(leaderboard, "run_board", recorded)
    args = argparse.Namespace(out=tmp_path, solver="direct", petsc="", force=False, rerun=[])
    assert leaderboard.main(args) == 0
    kinds = [kind for kind, _ in events]
    assert kinds == ["warn"] * 7 + ["run"], events
    warned = "\n".join(line for _, line in events[:-1])
    for name in ("newline", "negative-wall", "text-wall", "no-wall", "nan-error", "no-end-time"):
        assert f"{user / name}:" in warned
    assert "mesh-sensitivity.md: not a report" in warned
    with open(tmp_path / "leaderboard.csv", newline="") as f:
        users = [r for r in csv.DictReader(f) if r["source"] == "user"]
    assert sorted(r["label"] for r in users) == sorted([HOSTILE, "my:solver"])
    text = (tmp_path / "leaderboard.md").read_text()
    assert "<script>" not in text and "\n## PWNED" not in text
    assert "x\\|y&lt;script&gt;alert(1)&lt;/script&gt;" in text
    assert "no wall\\_time\\_s" in text  # the note under the case says what was left out
    leaderboard.check_target(tmp_path, set(), force=False)  # "my" is no simulator


def test_figure_takes_labels_as_plain_text(tmp_path):
    """Labels that matplotlib would parse as (broken) mathtext are drawn as they are."""
    rows = [row(r"$\frac{$ x", 1.0, 1e-3), row("a$b$c", 2.0, 1e-4), row(r"$\bad", 0.5, 2e-3)]
    mark_pareto(rows)
    path = tmp_path / f"figure-{COMM.rank}.png"
    document.plot_case(path, Board("c", "rod", "MP3", "linear", description="d"), rows)
    assert all_ranks(path.stat().st_size > 10_000)


def test_a_figure_is_stamped_with_the_code_that_drew_it(tmp_path):
    """Each case's PNG carries the hash of the code that drew it; one drawn by other code (or
    by none that says) is not taken as drawn, so the leaderboard draws it again."""
    from tissuebench.workflows.io.output import write_owned
    from tissuebench.workflows.leaderboard.build import as_drawn_now
    from tissuebench.workflows.leaderboard.figures import STAMP, drawing_code, stamp_of

    rows = [row("a", 1.0, 1e-3), row("b", 2.0, 1e-4)]
    mark_pareto(rows)
    folder = tmp_path / f"rank-{COMM.rank}"
    folder.mkdir()
    path = folder / "c.png"
    board = Board("c", "rod", "MP3", "linear", description="d")
    write_owned(path, lambda tmp: document.plot_case(tmp, board, rows))
    assert stamp_of(path) == drawing_code() and as_drawn_now(path)
    import matplotlib.pyplot as plt

    for stamp in ("0" * 64, None):  # drawn by other code, or by one that did not stamp it
        fig = plt.figure()
        meta = {STAMP: stamp} if stamp else {}
        write_owned(path, lambda tmp, meta=meta: fig.savefig(tmp, format="png", metadata=meta))
        plt.close(fig)
        assert stamp_of(path) == stamp and not as_drawn_now(path)


def test_a_figures_stamp_is_the_code_that_process_loaded(monkeypatch):
    """The stamp is the hash of the drawing code as the process loaded it, not of the files as
    they are when a figure is saved: a long render while the code is edited must not stamp a
    figure drawn by the old code with the new code's hash (12 committed figures were found drawn
    by older code under the stamp of the code then committed)."""
    from pathlib import Path

    from tissuebench.workflows.leaderboard.figures import drawing_code
    from tissuebench.workflows.leaderboard.force_figure import force_drawing_code

    loaded = drawing_code(), force_drawing_code()
    monkeypatch.setattr(Path, "read_bytes", lambda self: b"# edited since")
    monkeypatch.setattr(Path, "read_text", lambda self, *a, **k: "# edited since")
    assert (drawing_code(), force_drawing_code()) == loaded
