"""A contact row's needle force travels in the leaderboard's record (issues 59, 60): each row
carries its force curve (Row.force_curve, force_curve.py), the force figure and the grading
read that curve and never a file at the row's recorded path, a malformed curve is dropped in
one line, and a user's row's cached grades are keyed by its force too."""

import json
from dataclasses import replace

import numpy as np
import pytest

from tissuebench.workflows.io.tables import write_force_csv
from tissuebench.workflows.leaderboard import force_figure
from tissuebench.workflows.leaderboard.caches import Caches
from tissuebench.workflows.leaderboard.force_curve import (
    check_curve,
    curve_of,
    force_hash,
    row_force,
)
from tissuebench.workflows.leaderboard.grading import grade_user_row
from tissuebench.workflows.leaderboard.record import (
    read_record,
    record_of,
    record_text,
)
from tissuebench.workflows.leaderboard.row import Kind
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys
from tissuebench.workflows.leaderboard.users import user_key

BOARD = Board(
    "contact-tiny", "contact", "MP1", "linear", mesh_size=4, end_time=0.5,
    options={"kappa": 10.0, "load_scale": 1.0}, simulators=(), description="contact, N = 4",
)  # fmt: skip
OLD_PATH = "results/leaderboard/contact-tiny/forces/implicit.csv"  # relative: where it ran


def curve(scale: float = 1.0, steps: int = 11) -> dict:
    times = np.linspace(0.0, 0.5, steps)
    force = np.column_stack([scale * np.sin(3 * times) + 1 / 3, -scale * times])
    return curve_of(times, force)


def contact_row(label: str = "implicit", source: str = "tissuebench", **kw) -> Row:
    kw = {"reference": source == "tissuebench", **kw}
    return Row(
        BOARD.name, label, source, "d", "reference", 10, "ok", None,
        dict.fromkeys(error_keys(), 1e-3), 1.0, 0.5, "this session",
        contact={"force_error": 0.0, "interpenetration_max": 1e-3, "force_error_how": "x"},
        **kw,
    )  # fmt: skip


def written(folder, rows) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    record = record_of([BOARD], {BOARD.name: rows}, {BOARD.name: []})
    (folder / "leaderboard.json").write_text(record_text(record))


def drawn(monkeypatch, tmp_path, board, rows):
    """The force figure of rows (plot_force) as drawn: (its curves' {label: (x, y)}, its note's
    texts)."""
    from matplotlib.figure import Figure

    figures = []
    save = Figure.savefig

    def kept(fig, *args, **kwargs):
        figures.append(fig)
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", kept)
    force_figure.plot_force(tmp_path / "force.png", board, rows)
    (fig,) = figures
    (ax,) = fig.axes
    lines = {line.get_label(): (line.get_xdata(), line.get_ydata()) for line in ax.get_lines()}
    return lines, [t.get_text() for t in ax.texts]


def test_the_record_carries_the_curve_and_the_figure_draws_it_anywhere(tmp_path, monkeypatch):
    """A record written with a contact row's curve, rendered from another folder with no
    force file there: the row's curve is drawn as recorded. A file planted at the row's old
    relative path (other numbers) is not read."""
    source = tmp_path / "clone" / "results"
    mine = curve()
    written(source, [contact_row(force=OLD_PATH, force_curve=mine)])
    text = (source / "leaderboard.json").read_text()
    assert '"unit": "N/m"' in text and len(text.splitlines()) < 120  # each list on one line
    elsewhere = tmp_path / "elsewhere"
    planted = elsewhere / OLD_PATH
    planted.parent.mkdir(parents=True)
    write_force_csv(planted, np.linspace(0, 0.5, 11), np.full((11, 2), 99.0))
    monkeypatch.chdir(elsewhere)
    boards, rows, _ = read_record(source)
    (row,) = rows[BOARD.name]
    assert row.force_curve == mine and row.force == OLD_PATH
    board = boards[0]
    board.truth = None  # no truth force: the rows' curves alone
    lines, notes = drawn(monkeypatch, tmp_path, board, rows[BOARD.name])
    x, y = lines["implicit (reference)"]
    assert np.array_equal(x, mine["times"])
    assert np.array_equal(y, [f[0] for f in mine["force"]])  # F_x: not the planted 99
    assert not any("not found" in n or "not in the record" in n for n in notes)


def test_a_row_without_a_curve_reads_no_file(tmp_path, monkeypatch):
    """A row read back with a force path and no curve (a record of before): its force is
    not recorded, and the planted file at its path is neither drawn nor graded."""
    from tissuebench.workflows.leaderboard.contact import grade_forces

    monkeypatch.chdir(tmp_path)
    planted = tmp_path / OLD_PATH
    planted.parent.mkdir(parents=True)
    write_force_csv(planted, np.linspace(0, 0.5, 11), np.ones((11, 2)))
    row = contact_row(force=OLD_PATH)
    assert row_force(row) is None and force_hash(row) is None
    board = replace(BOARD, truth=None)
    lines, notes = drawn(monkeypatch, tmp_path, board, [row])
    assert "implicit (reference)" not in lines
    assert any("forces not in the record" in n and n.rstrip().endswith("implicit") for n in notes)
    grade_forces([row], np.ones((11, 2)), "contact-MP1", 0.1)
    assert row.contact["force_error"] == 0.0  # kept: not graded from the planted file
    assert "its force is not recorded" in row.contact["force_error_how"]


def test_a_run_that_ended_early_is_marked_where_it_ended(tmp_path, monkeypatch):
    """A row that failed at its first step carries one sample: its curve draws no line, so
    it is marked with an x at its last sample and its status and time are in the legend; a
    row that finished is drawn as before, unmarked."""
    ended = curve(steps=1)
    rows = [
        contact_row(force_curve=curve()),
        replace(contact_row("sim:one", "sim", force_curve=ended), status="failed"),
    ]
    lines, _ = drawn(monkeypatch, tmp_path, replace(BOARD, truth=None), rows)
    x, y = lines["sim:one (failed at t = 0 s: x)"]
    assert np.array_equal(x, ended["times"]) and np.array_equal(y, [ended["force"][0][0]])
    assert "implicit (reference)" in lines

    from matplotlib.figure import Figure

    figures = []
    monkeypatch.setattr(Figure, "savefig", lambda fig, *a, **k: figures.append(fig))
    force_figure.plot_force(tmp_path / "again.png", replace(BOARD, truth=None), rows)
    marks = {line.get_label(): line.get_marker() for line in figures[0].axes[0].get_lines()}
    assert marks == {"implicit (reference)": "None", "sim:one (failed at t = 0 s: x)": "x"}


@pytest.mark.parametrize(
    "bad",
    [
        {"times": [0.0, 1.0], "force": [[1.0, 2.0]], "unit": "N/m"},  # lengths differ
        {"times": [0.0, 1.0], "force": [[1.0], [2.0]], "unit": "N/m"},  # one column
        {"times": [0.0, 1.0], "force": [[1.0, 2.0], [1.0, 2.0, 3.0]], "unit": "N/m"},
        {"times": [0.0, "1"], "force": [[1.0, 2.0], [1.0, 2.0]], "unit": "N/m"},
        {"times": [0.0, 1.0], "force": [[1.0, 2.0], [1.0, True]], "unit": "N/m"},
        {"times": [0.0, 1.0], "force": [[1.0, 2.0], [1.0, 2.0]], "unit": "N"},  # 2D is N/m
        {"times": [0.0], "force": [[1.0, 2.0, 3.0]], "unit": "N/m"},  # 3D is N
        {"times": [], "force": [], "unit": "N/m"},
        {"times": [0.0], "force": [[1.0, 2.0]]},
        [1, 2],
    ],
)
def test_a_malformed_curve_is_dropped_in_one_line(tmp_path, capsys, bad):
    with pytest.raises(ValueError):
        check_curve(bad)
    good = contact_row(force=OLD_PATH, force_curve=curve())
    record = record_of([BOARD], {BOARD.name: [good]}, {BOARD.name: []})
    record["cases"][0]["rows"][0]["force_curve"] = bad
    (tmp_path / "leaderboard.json").write_text(json.dumps(record))
    _, rows, _ = read_record(tmp_path)
    assert rows[BOARD.name][0].force_curve is None
    (said,) = capsys.readouterr().err.splitlines()
    assert "row 1 (implicit): its force curve dropped" in said


def test_non_finite_and_three_components(tmp_path):
    with pytest.raises(ValueError):
        check_curve({"times": [0.0], "force": [[float("nan"), 1.0]], "unit": "N/m"})
    three = curve_of([0.0, 0.1], [[0.1, 0.2, 1 / 3], [0.0, 0.0, 2.0]])
    assert three["unit"] == "N" and three["force"][0][2] == 0.333333333  # 9 digits


def test_a_cached_grade_changes_with_the_force_alone():
    """Two users' rows of the same series, the same in all but their force: neither takes
    the other's grades (the run's cache nor the record's key); the same force does."""
    board = replace(BOARD, truth=None)
    caches = Caches()

    def user(scale, error):
        row = contact_row("mine", "user", force="f.csv", force_curve=curve(scale))
        row.kind, row.series_hash, row.series = Kind.USER, "same series", "s.xdmf"
        row.contact["force_error"] = error
        return row

    first, other, again = user(1.0, 0.1), user(2.0, 0.2), user(1.0, 0.3)
    assert user_key(first) != user_key(other) and user_key(first) == user_key(again)
    for row in (first, other, again):
        grade_user_row(board, [], row, None, caches)
    assert other.contact["force_error"] == 0.2  # its own: not the first's
    assert again.contact["force_error"] == 0.1  # the first's: the same series and force
    assert len(caches.grades) == 2
