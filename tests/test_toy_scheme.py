"""A fifth discretisation scheme defined in the test folder alone (tests/toy_scheme.py: `stiffened`,
factor x the standard element's K_0, registered in solvers.schemes.SCHEMES) goes through `run`, the
frontier's study and figure, the leaderboard and its page as the five of solvers/schemes/ do (issue
41): what the commands know of it is what its Scheme states (its parameter in --help, the linear
model only, a spare colour in figures). Physics: at factor 1 it is the standard element, so its rod
tip follows the standard element's to round-off; at factor 2 the quasi-static tip (K u = f at every
step) is half the standard element's."""

import argparse
import csv
from pathlib import Path

from mpi4py import MPI

import matplotlib.colors
import matplotlib.image
import numpy as np
import pytest
from toy_scheme import NAME, registered

from tissuebench.solvers.schemes import SCHEMES, SPARE_COLOURS, colour_of
from tissuebench.workflows.cli import main, parser
from tissuebench.workflows.frontier import report
from tissuebench.workflows.frontier import runs as study

ROOT = Path(__file__).resolve().parents[1]
RUN = ["--mesh-size", "1", "--end-time", "0.2", "--no-figures"]


@pytest.fixture(scope="module")
def toy():
    with registered() as scheme:
        yield scheme
    assert NAME not in SCHEMES


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A truth cache of the test's own (empty: no run is graded against a truth)."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))


def tips(folder) -> dict[str, np.ndarray]:
    """{algorithm: the rod tip's displacement at every step (steps x 3, m)} of a run."""
    MPI.COMM_WORLD.barrier()
    with open(folder / "tip.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return {
        a: np.array(
            [[float(r[k]) for k in ("u_x", "u_y", "u_z")] for r in rows if r["algorithm"] == a]
        )
        for a in {r["algorithm"] for r in rows}
    }


def test_the_toy_runs_as_the_standard_element_it_scales(toy, tmp_path, cache):
    algorithms = ["--algorithms", "implicit,explicit-lumped,quasi-static"]
    for scheme in ("standard", NAME, f"{NAME}:factor=2"):
        out = tmp_path / scheme.replace(":", "-")
        assert main(["run", "rod", "--out", str(out), "--scheme", scheme, *RUN, *algorithms]) == 0
    plain, same, stiff = (tips(tmp_path / s) for s in ("standard", NAME, f"{NAME}-factor=2"))
    assert set(plain) == set(same) == {"implicit", "explicit-lumped", "quasi-static"}
    for algorithm, u in plain.items():
        assert np.abs(u[1:, 1]).min() > 1e-7  # the rod sags from the first step on
        np.testing.assert_allclose(same[algorithm], u, rtol=1e-10, atol=1e-14 * np.abs(u).max())
    # linear statics: twice the stiffness, half the displacement, at every step
    u = plain["quasi-static"]
    np.testing.assert_allclose(
        stiff["quasi-static"], u / 2, rtol=1e-9, atol=1e-14 * np.abs(u).max()
    )


@pytest.mark.serial  # the refusal is said on rank 0 only
def test_the_commands_say_what_the_toy_states(toy, tmp_path, capsys):
    """Its parameter's meaning and range, and no nonlinear form: refused in one line, as the
    five schemes are."""
    said = "factor=1: the standard element's stiffness times, 0.5 <= factor <= 4"
    for command in ("run", "frontier"):  # --scheme, and the frontier's list of its schemes
        assert f"{NAME} ({said}" in " ".join(help_of(command).split()), command
    code = main(
        ["run", "rod", "--out", str(tmp_path / "bad"), "--scheme", f"{NAME}:factor=5", *RUN]
    )
    said = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in said
    assert (
        "factor (the standard element's stiffness times)" in said and "0.5 <= factor <= 4" in said
    )
    code = main(["run", "rod", "--out", str(tmp_path / "bad"), "--scheme", NAME, *RUN,
                 "--models", "linear,neo-hookean", "--algorithms", "explicit-lumped"])  # fmt: skip
    said = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in said
    assert f"--scheme {NAME} runs the linear model only, not neo-hookean" in said
    assert "mean-dilatation has a nonlinear form, F-bar, for the explicit algorithms" in said


def help_of(command: str) -> str:
    """`tissuebench COMMAND --help`, its parser made now (the toy registered)."""
    sub = next(a for a in parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[command].format_help()


def row(scheme, cell, cost, mean, algorithm="implicit", size=1):
    """A frontier.csv row of rod-MP2 (cost in s per simulated s, E_i mean in m^3)."""
    return {
        "case": "rod-MP2", "benchmark": "rod", "material": "MP2", "cell": cell,
        "scheme": scheme, "algorithm": algorithm, "requested": "1", "substeps": 1,
        "mesh_size": size, "dofs": 336, "critical_dt_s": float("nan"), "status": "ok",
        "diverged_time": float("nan"), "setup_s": 0.1, "loop_s": 10 * cost, "cost": cost,
        "whole_s": 0.1 + 10 * cost, "whole_cost": 0.01 + cost, "interior_error_mean": mean,
        "interior_error_max": 2 * mean, "relative_error_mean": 0.1, "relative_error_max": 0.2,
        "truth_own_error": 6e-7, "truth_size": 1e-4, "timings": 1,
    }  # fmt: skip


@pytest.mark.serial  # draws one figure file
def test_the_frontier_runs_and_draws_the_toy(toy, tmp_path):
    configs = list(study.configs(("rod-MP2",), quick=True))
    toys = {c.cell for c in configs if c.scheme == f"{NAME}:factor=1"}
    assert toys == {"hexahedron", "tetrahedron"}  # on every cell its Scheme takes

    brown = SPARE_COLOURS[0]  # the first spare colour: the toy states none
    assert colour_of(NAME, "hexahedron") == brown
    # the five schemes keep the colours results/frontier/*.png were drawn with, in that order
    legend = report.colours()
    assert list(legend.items()) == [
        ("Q1", "tab:blue"), ("mean-dilatation", "tab:green"), ("hourglass", "tab:olive"),
        (NAME, brown), ("P1", "tab:orange"), ("anp", "tab:red"), ("penalty", "tab:purple"),
    ]  # fmt: skip

    rows = [
        row("standard", "hexahedron", 0.02, 4e-5),
        row(f"{NAME}:factor=2", "hexahedron", 0.03, 2e-5, size=2),
        row("standard", "tetrahedron", 0.01, 8e-5),
    ]
    figure = tmp_path / "frontier-rod-MP2.png"
    report.plot(figure, "rod-MP2", rows)
    pixels = matplotlib.image.imread(figure)[..., :3]
    drawn = 0.8 * np.array(matplotlib.colors.to_rgb(brown)) + 0.2  # alpha 0.8 on white
    assert (np.abs(pixels - drawn).max(axis=-1) < 0.02).sum() > 10  # the toy's run is drawn
    text = report.markdown(rows, ("rod-MP2",), "header")
    assert f"closest run is {NAME}:factor=2 implicit on the size-2 mesh" in text


def test_the_leaderboard_and_its_page_take_the_toys_frontier_run(toy):
    """A frontier run of the toy (a row of frontier.csv, as `tissuebench frontier` writes it)
    joins the leaderboard's case of its truth as a frontier row, on the Pareto front against
    the truth where it is the cheapest, and is shown on the page and in leaderboard.md."""
    from tissuebench.workflows.leaderboard import document, page
    from tissuebench.workflows.leaderboard.figures import unit_of
    from tissuebench.workflows.leaderboard.frontier_rows import frontier_row, join_frontier
    from tissuebench.workflows.leaderboard.row import Kind
    from tissuebench.workflows.leaderboard.rows import BOARDS, E_I, Row, error_keys

    board = next(b for b in BOARDS if b.name == "rod-MP3")  # its truth: "rod"
    truth = {f"{E_I}_mean": 5e-4, f"{E_I}_max": 8e-4}
    ours = Row(
        "rod-MP3",
        "implicit",
        "tissuebench",
        "a run",
        "reference",
        336,
        "ok",
        None,
        dict.fromkeys(error_keys(), 0.0),
        0.1,
        10.0,
        "now",
        reference=True,
        truth=truth,
    )
    with open(ROOT / "results" / "frontier" / "frontier.csv", newline="") as f:
        written = next(r for r in csv.DictReader(f) if r["case"] == "rod")
    run = frontier_row({**written, "scheme": f"{NAME}:factor=2"})
    rows = join_frontier([board], {board.name: [ours]}, {"rod": [run]})[board.name]
    (toys,) = [r for r in rows if r.kind is Kind.FRONTIER]
    assert toys.label.startswith(f"{NAME}:factor=2 implicit")
    assert toys.truth[f"{E_I}_max"] == float(written["interior_error_max"])
    text = page.render([board], {board.name: rows}, {board.name: []}, "now", unit_of)
    assert text.count(f"{NAME}:factor=2") >= 1
    shown = document.markdown([board], {board.name: rows}, {board.name: []}, "now")
    assert f"{NAME}:factor=2" in shown
