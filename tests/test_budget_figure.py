"""The error-budget figure of a leaderboard case (SPEC 10, issue 25 item 4)."""

from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.image import imread

from tissuebench.workflows.leaderboard.budget import budget_rows, plot_budget


def row(label, **budget):
    return SimpleNamespace(label=label, status="ok", budget=budget)


def test_rows_drawn_are_those_with_a_measured_total_ordered_by_it():
    rows = [
        row("a", total=3e-4, discretisation=2e-4, algorithm=1e-4, model=None),
        row("b", total=1e-5, discretisation=1e-5, algorithm=0.0, model=None),
        row("no truth"),  # no budget
        row("nan", total=float("nan")),
    ]
    assert [r.label for r in budget_rows(rows)] == ["b", "a"]


@pytest.mark.serial  # a figure, drawn by one process (rank 0's job)
def test_the_figure_draws_one_bar_per_measured_part(tmp_path):
    """Each measured part is a bar in its colour; an unmeasured one is not drawn: the pixels
    of a part's colour appear exactly when some row has that part measured."""
    path = tmp_path / "budget.png"
    rows = [
        row("a", total=3e-4, discretisation=2e-4, algorithm=1e-4, model=None),
        row("b", total=1e-5, discretisation=1e-5, algorithm=2e-6, model=None),
    ]
    assert plot_budget(path, "rod-MP3", rows, "m^3")
    image = imread(path)[..., :3]

    def present(hex_colour):
        rgb = np.array([int(hex_colour[i : i + 2], 16) / 255 for i in (1, 3, 5)])
        return int(np.sum(np.all(np.abs(image - rgb) < 0.02, axis=-1)))

    from tissuebench.workflows.leaderboard.budget import COLOURS

    assert present(COLOURS["discretisation"]) > 50 and present(COLOURS["algorithm"]) > 50
    # model: only its legend entry would show it; with no row measuring it, no bar and no legend
    assert present(COLOURS["model"]) < 20
    assert not plot_budget(tmp_path / "none.png", "x", [row("c")], "m^3")
    assert not (tmp_path / "none.png").exists()
