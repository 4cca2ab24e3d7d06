"""A diverged run never looks like a finished one (issue 44, item 5): on rod-MP2 the record's
explicit-lumped diverged (its largest displacement 2.67e4 m at the end) and its budget showed
a total of 0.0711 m^3 with no word of it. Its errors are time means and maxima over the steps
before it diverged: the budget (page, figure, table), the ranked divisions, leaderboard.md and
leaderboard.csv say so beside them, and it never ranks."""

import csv

import pytest

from tissuebench.workflows.leaderboard import document, page
from tissuebench.workflows.leaderboard.budget import covers, marked, plot_budget
from tissuebench.workflows.leaderboard.figures import budget_table
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys, write_csv

BOARD = Board("rod-MP2", "rod", "MP2", "linear", simulators=(), truth="rod-MP2")
SPAN = "over the steps before it diverged"


def row(label: str, status: str, total: float, reference: bool = False) -> Row:
    """A row of ours graded against the truth with a budget (m^3), 10 s simulated in 5 s."""
    errors = dict.fromkeys(error_keys(), total)
    r = Row("rod-MP2", label, "tissuebench", "ours", "reference", 336, status,
            None if status == "ok" else "largest displacement 2.67e+04 m > 100 x the domain's "
            "extent", errors, 5.0, 10.0, "this session", reference=reference)  # fmt: skip
    r.truth = {"interior_error_mean": total, "interior_error_max": 2 * total,
               "relative_error_mean": 0.1, "relative_error_max": 0.2}  # fmt: skip
    r.budget = {"total": total, "discretisation": 1e-7, "algorithm": total, "model": 0.0}
    return r


def rows() -> list[Row]:
    return [row("implicit", "ok", 1e-6, reference=True), row("explicit-lumped", "diverged", 0.0711)]


def test_what_the_errors_cover():
    assert covers("ok") == "every step"
    assert covers("diverged") == "the steps before it diverged"
    assert covers("failed") == "the steps before it failed"
    assert marked("implicit", "ok") == "implicit"
    assert marked("explicit-lumped", "diverged") == f"explicit-lumped (diverged: {SPAN})"
    assert marked("explicit-lumped", "diverged", short=True) == "explicit-lumped (diverged)"


@pytest.mark.serial  # leaderboard.csv in tmp_path, which mpiexec's ranks share
def test_the_budget_and_the_ranks_say_it_diverged(tmp_path):
    ours = rows()
    svg = page.budget_plot(BOARD, ours, "m^3")
    assert "explicit-lumped (diverged)</text>" in svg  # its line's label
    assert f"explicit-lumped (diverged: {SPAN})" in svg  # its tooltip
    assert "implicit (" not in svg  # a run that finished: no mark
    tip = page.tip_lines(BOARD, ours[1], "m^3")
    assert any(line.startswith(f"budget (time-mean E_i, m^3, {SPAN})") for line in tip), tip
    assert not any(SPAN in line for line in page.tip_lines(BOARD, ours[0], "m^3"))
    table = budget_table(ours)
    (line,) = [x for x in table if "explicit" in x]
    assert line.startswith(f"| explicit-lumped (diverged: {SPAN}) | 0.0711")
    for open_ in (False, True):  # both divisions: the diverged run listed, marked, not ranked
        html = page.division(BOARD, ours, True, open_, "m^3")
        (cells,) = [x for x in html.split("<tr") if "explicit-lumped" in x]
        assert f"explicit-lumped (diverged: {SPAN})</td>" in cells
        assert cells.split("<td>")[1].startswith("-</td>")  # no rank
    md = "\n".join(document.case_lines(BOARD, ours, [], "now"))
    assert "explicit-lumped (diverged" not in md  # ours' best is implicit, which finished
    alone = "\n".join(document.case_lines(BOARD, ours[1:], [], "now"))
    assert f"| explicit-lumped (diverged: {SPAN}) |" in alone  # its source's only run
    write_csv(tmp_path / "leaderboard.csv", ours)
    with open(tmp_path / "leaderboard.csv", newline="") as f:
        said = {r["label"]: r for r in csv.DictReader(f)}
    assert said["implicit"]["errors_over"] == "every step"
    assert said["explicit-lumped"]["errors_over"] == "the steps before it diverged"
    assert said["explicit-lumped"]["pareto_mean"] == "False"


@pytest.mark.serial  # a figure, drawn by one process
def test_the_budget_figure_marks_it(tmp_path, monkeypatch):
    import matplotlib.image

    from tissuebench.workflows.leaderboard import budget

    drawn = []
    real = budget.Figure

    class Spy(real):  # the tick labels as matplotlib is given them
        def add_subplot(self, *args, **kwargs):
            ax = super().add_subplot(*args, **kwargs)
            set_yticks = ax.set_yticks
            ax.set_yticks = lambda ticks, labels, **kw: (
                drawn.extend(labels),
                set_yticks(ticks, labels, **kw),
            )
            return ax

    monkeypatch.setattr(budget, "Figure", Spy)
    assert plot_budget(tmp_path / "b.png", "rod-MP2", rows(), "m^3")
    assert drawn == ["implicit", "explicit-lumped (diverged)"]
    assert matplotlib.image.imread(tmp_path / "b.png").shape[0] > 0
