"""Issue 14: the large-deformation part of `tissuebench paper` (SPEC section 8): its cases,
its figures and the claims of its report.

The report's claims are checked against hand-built summaries whose numbers are chosen here, so
that each sentence has a known right answer (as tests/test_report.py does for part 1); the
figures' geometry against fields whose Jacobian and outline are known in closed form. No run."""

import csv
import json
from dataclasses import replace
from types import SimpleNamespace

from mpi4py import MPI  # noqa: F401 (loads libmpi before dolfinx)

import numpy as np
import pytest
from summaries import case_summary, update

from tissuebench.metrics.table import METRICS
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.models import run_label
from tissuebench.workflows.run import model_figures as figures_models
from tissuebench.workflows.run.case import RunSpec, algorithm_case, model_case
from tissuebench.workflows.study import divergence
from tissuebench.workflows.study import large_deformation as part2
from tissuebench.workflows.study.cases import cases, model_cases

pytestmark = pytest.mark.serial  # files and figures on rank 0's terms

REF = "implicit+neo-hookean"
H = 1 / 30


def run_entry(label, mean=1e-3, diverged=None, reason=None, tip=None):
    algorithm, _, model = label.partition("+")
    entry = {
        "algorithm": algorithm,
        "model": model or "linear",
        "material": "MP1",
        "status": "ok" if diverged is None else "diverged",
        "diverged_step": None if diverged is None else round(diverged / H),
        "diverged_time": diverged,
        "reason": reason,
        "steps": 300,
        "wall_time_s": 0.1,
    }
    for m in METRICS:
        entry[f"{m}_mean"] = entry[f"{m}_max"] = 0.0 if label == REF else mean
    if tip is not None:
        entry["tip_displacement_final"] = tip
    return entry


def summary(name, benchmark="block", scale=1.0, width=0.0, means=None, diverged=None):
    """A summary of the 20 runs: E_i time-means from `means` (default 1e-3 m), the runs of
    `diverged` ({label: (time, reason)}) diverged."""
    means, diverged = means or {}, diverged or {}
    runs = {}
    for model in MODELS:
        for algorithm in ALGORITHMS:
            label = run_label(algorithm, model)
            t, why = diverged.get(label, (None, None))
            runs[label] = run_entry(label, means.get(label, 1e-3), t, why)
    runs = {REF: runs.pop(REF), **runs}
    s = {
        "case": name,
        "description": name,
        "benchmark": benchmark,
        "reference": REF,
        "mesh_size": 20 if benchmark == "block" else 3,
        "num_dofs": 882,
        "h": H,
        "end_time": 10.0,
        "steps": 300,
        "solver": "direct",
        "load_scale": scale,
        "runs": runs,
        "files": ["metrics.csv", "summary.json"],
    }
    if benchmark == "block":
        s["needle_width"] = width
    return case_summary(s)


# --- the cases ----------------------------------------------------------------------------


def test_part_2_has_the_four_named_cases_of_spec_section_8():
    found = {c.name: c for c in model_cases()}
    assert len(found) == 4
    expected = {  # (benchmark, s, w, reference) as SPEC section 8's table names them
        ("block", 1.0, 0.0, REF),
        ("block", 2.0, 0.2, "implicit+neo-hookean-barrier"),
        ("rod", 1.0, None, REF),
        ("rod", 3.0, None, "implicit+neo-hookean-barrier"),
    }
    got = {
        (c.benchmark, c.options["load_scale"], c.options.get("needle_width"), c.reference)
        for c in found.values()
    }
    assert got == expected
    for case in found.values():
        assert len(case.runs) == len(ALGORITHMS) * len(MODELS)
        assert {(r.algorithm, r.model) for r in case.runs} == {
            (a, m) for a in ALGORITHMS for m in MODELS
        }
        assert figures_models.is_model_case(case)
    # part 1 keeps its cases, all linear, so its figures and fingerprints stay as they were
    assert not any(figures_models.is_model_case(c) for c in cases())


def test_a_registered_case_joins_its_part_with_the_papers_solver_until_it_is_taken_out():
    from tissuebench.workflows.study import cases as paper_cases

    before = [c.name for c in cases()], [c.name for c in model_cases()]
    mine = algorithm_case("rod-MP3-mine", "rod", "MP3", ["explicit"], end_time=1.0)
    theirs = model_case("rod-MP3-theirs", "rod", "MP3", ["implicit"], list(MODELS))
    paper_cases.register(mine)
    paper_cases.register(theirs, large=True)
    try:
        first, second = cases("iterative", "-ksp_rtol 1e-9"), model_cases()
        assert [c.name for c in first] == [*before[0], mine.name]
        assert [c.name for c in second] == [*before[1], theirs.name]
        added = first[-1]  # as registered, with the paper's solver and PETSc options
        assert (added.solver, added.petsc, added.end_time) == ("iterative", "-ksp_rtol 1e-9", 1.0)
        assert added.runs == mine.runs and mine.solver == "direct"  # the registered one as it was
        with pytest.raises(ValueError, match="already has a case 'rod-MP3'"):
            paper_cases.register(algorithm_case("rod-MP3", "rod", "MP3", []))
        with pytest.raises(ValueError, match="rod-MP3-mine"):  # a name of the other part
            paper_cases.register(replace(theirs, name=mine.name), large=True)
    finally:
        paper_cases.unregister(mine.name)
        paper_cases.unregister(theirs.name)
    assert ([c.name for c in cases()], [c.name for c in model_cases()]) == before


def test_paper_cases_names_the_cases_it_runs_and_refuses_others_in_one_line():
    from tissuebench.core.errors import UserError
    from tissuebench.workflows.study import truth as paper_truth
    from tissuebench.workflows.study.paper import select

    first, truth, second = cases(), paper_truth.cases(), model_cases()
    assert select(None, first, truth, second) == (first, truth, second)
    chosen = select(["rod-MP3", "rod-MP3-s3"], first, truth, second)
    assert [[c.name for c in part] for part in chosen] == [["rod-MP3"], [], ["rod-MP3-s3"]]
    # the truth's two folders run together (paper_truth grades them as one)
    assert select(["block-MP1", "truth-rod-MP3"], first, truth, second)[1] == truth
    with pytest.raises(UserError, match="--cases rod-MP4: no such case; name some of block-MP1"):
        select(["rod-MP3", "rod-MP4"], first, truth, second)
    with pytest.raises(UserError, match="at least one case of part 1"):
        select(["rod-MP3-s3"], first, truth, second)


# --- figures ------------------------------------------------------------------------------


def test_jacobian_of_an_affine_field_is_det_of_its_gradient_everywhere():
    rng = np.random.default_rng(3)
    for n, d in ((4, 2), (8, 3)):
        X = figures_models.VTK_CORNERS[n] * [0.3, 0.2, 0.5][:d] + 0.1
        A = 0.3 * rng.normal(size=(d, d))
        J = figures_models.jacobians(X, np.arange(n)[None], (X @ A.T)[None])
        assert J.shape == (1, 1, 2**d)
        assert np.allclose(J, np.linalg.det(np.eye(d) + A), rtol=1e-12)
    # a quadrilateral folded over itself: one corner pushed across the opposite one
    X = figures_models.VTK_CORNERS[4]
    u = np.zeros_like(X)
    u[2] = [-1.6, -1.6]
    assert figures_models.jacobians(X, np.arange(4)[None], u[None]).min() < 0


def test_silhouette_of_a_moved_square_and_a_side_view_of_a_box():
    X = figures_models.VTK_CORNERS[4]
    shape = figures_models.silhouette(X, np.arange(4)[None], np.tile([0.5, -2.0], (4, 1)))
    assert shape.area == pytest.approx(1.0) and shape.bounds == pytest.approx((0.5, -2, 1.5, -1))
    box = figures_models.VTK_CORNERS[8] * [0.5, 0.25, 0.25]
    rotation = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    side = figures_models.silhouette(box, np.arange(8)[None], box @ rotation.T - box)
    assert side.area == pytest.approx(0.5 * 0.25)
    assert side.bounds == pytest.approx((-0.25, 0.0, 0.0, 0.5))


def test_boundary_nodes_of_a_two_by_two_grid_leave_out_the_centre():
    cells = np.array([[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]])
    assert figures_models.boundary_nodes(cells).tolist() == [0, 1, 2, 3, 5, 6, 7, 8]


def test_heat_map_marks_each_diverged_run_with_its_time_and_no_colour():
    s = summary(
        "case",
        means={"implicit": 3e-3, "implicit-lumped+neo-hookean": 5e-5},
        diverged={"explicit+neo-hookean": (1.9, "inverted element: J = -41.5 <= 0 at t = 1.9 s")},
    )
    fig = figures_models.realism_figure("case", s)
    ax = fig.axes[0]
    marked = [p for p in ax.patches if (p.get_gid() or "").startswith("diverged:")]
    assert [p.get_gid() for p in marked] == ["diverged:explicit+neo-hookean"]
    assert marked[0].get_hatch() == "///"
    texts = [t.get_text() for t in ax.texts]
    assert any("diverged at\nt = 1.9 s" in t for t in texts)
    assert any(t.startswith("reference") for t in texts)
    assert "3.00e-03" in texts and "5.00e-05" in texts
    algorithms, models, table = figures_models.realism_table(s)
    assert algorithms == list(ALGORITHMS) and models == list(MODELS)
    assert table[0][models.index("neo-hookean")] == "reference"


def test_error_rows_mark_divergence_in_every_metric_panel():
    s = summary("case", diverged={"implicit+svk": (1.6, "inverted element")})
    times = np.arange(301) * H
    curves = {}
    for label in s.runs:
        c = np.linspace(1e-5, 1e-2, 301)
        if label == "implicit+svk":
            c[48:] = np.nan
        curves[label] = {m: c.copy() for m in METRICS}
    fig = figures_models.error_figure("case", s, times, curves)
    marks = [
        line
        for ax in fig.axes
        for line in ax.get_lines()
        if line.get_gid() == "diverged:implicit+svk"
    ]
    assert len(marks) == 3 and all(np.allclose(m.get_xdata(), 1.6) for m in marks)
    assert not any(
        line.get_gid() == f"diverged:{REF}" for ax in fig.axes for line in ax.get_lines()
    )


# --- the report ---------------------------------------------------------------------------


def four_cases():
    """Linear loses as s^2; lumping and explicit-lumped far less; the corotational model is
    worse than linear on the block, better on the rod; svk and explicit+neo-hookean diverge."""
    svk = {
        "quasi-static+svk": (1.0, "Newton did not converge at t = 1 s, even with the load ..."),
        "implicit+svk": (1.6, "inverted element: J = -0.008 <= 0 at t = 1.6 s"),
        "explicit+svk": (1.5, "inverted element: J = -0.01 <= 0 at t = 1.5 s"),
    }
    blow_up = {"explicit+neo-hookean": (1.9, "inverted element: J = -41.5 <= 0 at t = 1.9 s")}
    return {
        "block-s1": summary(
            "block-s1",
            means={
                "implicit": 3e-3,
                "implicit+corotational": 6e-3,
                "implicit-lumped+neo-hookean": 5e-5,
                "explicit-lumped+neo-hookean": 4e-4,
            },
            diverged={**svk, **blow_up},
        ),
        "block-s2": summary(
            "block-s2",
            scale=2.0,
            width=0.2,
            means={"implicit": 12e-3, "implicit-lumped+neo-hookean": 1e-4},
            diverged={**svk, "implicit+corotational": (1.5, "inverted element: J = -0.01")},
        ),
        "rod-s1": summary(
            "rod-s1",
            "rod",
            means={
                "implicit": 4e-4,
                "implicit+corotational": 1e-4,
                "implicit-lumped+neo-hookean": 2e-5,
                "explicit+neo-hookean": 1e-7,
                "explicit-lumped+neo-hookean": 8e-5,
            },
        ),
        "rod-s3": summary(
            "rod-s3", "rod", scale=3.0, means={"implicit": 36e-4, "implicit+corotational": 9e-4}
        ),
    }


def write_metrics(folder, s, growth=None):
    """metrics.csv with E_i = the run's mean at every step, multiplied by growth[label] per step
    over the last 10 steps before the divergence of a diverged run."""
    folder.mkdir(parents=True, exist_ok=True)
    growth = growth or {}
    with open(folder / "metrics.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["algorithm", "step", "time", *METRICS, "status"])
        for label, run in s.runs.items():
            last = run.diverged_step or 301
            for i in range(301):
                v = run.reading("interior_error", "mean") if i < last else np.nan
                if label in growth and last - 11 < i < last:
                    v *= growth[label] ** (i - (last - 11))
                w.writerow([label, i, i * H, *([v] * len(METRICS)), "ok"])


def test_linearisation_is_compared_with_lumping_and_explicit_stepping(tmp_path):
    large = four_cases()
    text = "\n".join(part2.large_deformation(tmp_path, large))
    block = next(line for line in text.splitlines() if line.startswith("- **block-s1**"))
    assert "linearisation loses E_i = 0.003 m" in block
    assert "60 times the loss from lumping (`implicit-lumped+neo-hookean`, 5e-05 m)" in block
    assert "explicit stepping (`explicit+neo-hookean`) diverged at t = 1.9 s" in block
    assert "7.5 times the loss from lumped explicit stepping" in block
    rod = next(line for line in text.splitlines() if line.startswith("- **rod-s1**"))
    assert "4000 times the loss from explicit stepping" in rod
    # at s = 1 the linear loss is the largest on both cases: 7.5 (block) and 5 (rod) times
    assert "linearisation is the largest of these losses on every case" in text
    assert "on block-s1 it is 7.5 times" in text and "on rod-s1 it is 5 times" in text
    v = part2.judge_paper_loads(large)  # the same verdict as data: block-s2, rod-s3 not at s = 1
    assert v.holds is True and v.checks == {"block-s1": True, "rod-s1": True}
    assert v.numbers["block-s1"] == (pytest.approx(7.5), "lumped explicit stepping")
    assert v.numbers["rod-s1"] == (pytest.approx(5.0), "lumped explicit stepping")
    # the linear loss grows as s^2 on both benchmarks (4 times for s = 2, 9 times for s = 3)
    assert "4 times for 2 times the load (the needle width changes too): as s^2" in text
    assert "9 times for 3 times the load: as s^2" in text
    # the corotational model: worse than linear on the block, better on the rods
    assert "on block-s1 0.006 m, 2 times the linear model's 0.003 m" in text
    assert "on rod-s1 0.0001 m, 4 times less than the linear model's 0.0004 m" in text
    assert "removes much of the linear model's loss on rod-s1, rod-s3; but not on block-s1" in text
    v = part2.judge_corotational(large)  # block-s2's corotational run diverged: not judged there
    assert v.holds is False and v.checks == {"block-s1": False, "rod-s1": True, "rod-s3": True}
    assert "`implicit+corotational` diverged at t = 1.5 s" in text


def test_linearisation_not_the_largest_loss_is_said_so(tmp_path):
    large = four_cases()
    update(large["rod-s1"].runs["implicit-lumped+neo-hookean"], interior_error_mean=8e-4)
    text = "\n".join(part2.large_deformation(tmp_path, large))
    assert "linearisation is not the largest of these losses on every case" in text
    assert "The paper's question" not in text
    v = part2.judge_paper_loads(large)  # lumping now loses 8e-4 > 4e-4 on the rod
    assert v.holds is False and v.checks == {"block-s1": True, "rod-s1": False}
    assert v.numbers["rod-s1"] == (pytest.approx(0.5), "lumping")


def test_divergences_give_reasons_times_and_what_the_data_say(tmp_path):
    large = four_cases()
    folder = tmp_path / part2.LARGE_DEFORMATION
    growth = {"explicit+neo-hookean": 1.5, "implicit+svk": 1.02, "explicit+svk": 1.03}
    for name, s in large.items():
        write_metrics(folder / name, s, growth)
    limits = {n: {"explicit": 0.0353, "explicit-lumped": 0.0647} for n in large}
    lines = part2.large_deformation(tmp_path, large, limits)
    text = "\n".join(lines)
    start = lines.index("### Which combinations diverge, and why")
    rows = [line for line in lines[start:] if line.startswith("| block-s1 |")]
    # every diverged run of the case, by time, with its reason from the summary
    assert [r.split(" | ")[1] for r in rows] == [
        "quasi-static+svk",
        "explicit+svk",
        "implicit+svk",
        "explicit+neo-hookean",
    ]
    assert "inverted element: J = -41.5 <= 0 at t = 1.9 s" in rows[-1]
    assert rows[-1].endswith("| n/a |")  # no deformation.json: said, not invented
    svk = next(line for line in lines if line.startswith("- **svk**"))
    assert "3 of 5 on block-s1, 3 of 5 on block-s2, 0 of 5 on rod-s1" in svk
    assert "found no static solution at t = 1 s (Newton failed), before any dynamic svk run" in svk
    assert "2 dynamic svk runs inverted a cell at t = 1.5 to 1.6 s" in svk
    explicit = next(line for line in lines if line.startswith("- **neo-hookean**"))
    assert "`explicit+neo-hookean` diverged on block-s1 (t = 1.9 s) and ran on block-s2" in explicit
    h = 1 / 30
    assert (
        f"{h / 0.0353:.3g} h_c for explicit, {h / 0.0647:.3g} h_c for explicit-lumped" in explicit
    )
    assert f"{100 * ((0.0353 / h) ** 2 - 1):.2g} % for explicit on block-s1" in explicit
    # E_i grew 1.5 per step over the last 10 steps: 1.5^10 = 57.7; the svk runs 1.03^10 = 1.34
    assert "grew 57.7 times on block-s1" in explicit and "at most 1.3 times" in explicit
    assert "an instability of the step rather than a collapse" in explicit
    items = [(n, label, r) for n, label, r in divergence.diverged_runs(large) if "neo" in label]
    v = divergence.judge_instability(tmp_path, large, items)
    assert v.holds is True and v.numbers["growth"] == {
        ("block-s1", "explicit+neo-hookean"): pytest.approx(1.5**10)
    }
    assert "- **linear**: no run diverged" in text
    v = divergence.judge_linear(large, {})  # no deformation.json: J not judged
    assert v.holds is True and v.checks == {"no run diverged": True} and v.numbers["J"] == {}
    update(large["rod-s3"].runs["implicit"], status="diverged", diverged_time=0.5)
    assert divergence.judge_linear(large, {}).numbers["diverged"] == ["implicit"]
    assert divergence.judge_linear(large, {}).holds is False


def test_explicit_without_geometric_growth_is_not_called_an_instability(tmp_path):
    large = four_cases()
    folder = tmp_path / part2.LARGE_DEFORMATION
    for name, s in large.items():
        write_metrics(folder / name, s)  # flat curves: no growth
    limits = {n: {"explicit": 0.0353, "explicit-lumped": 0.0647} for n in large}
    text = "\n".join(part2.large_deformation(tmp_path, large, limits))
    assert "grew 1 times on block-s1" in text
    assert "instability" not in text
    items = [(n, label, r) for n, label, r in divergence.diverged_runs(large) if "neo" in label]
    v = divergence.judge_instability(tmp_path, large, items)
    assert v.holds is False and v.checks["the error grew geometrically"] is False
    assert v.checks["the reference and explicit-lumped ran"] is True


def test_deformation_json_gives_the_place_of_the_smallest_j(tmp_path):
    large = four_cases()
    folder = tmp_path / part2.LARGE_DEFORMATION / "block-s1"
    folder.mkdir(parents=True)
    smallest = {
        label: {
            "J": 0.5,
            "step": 60,
            "time": 2.0,
            "cell_centre": [0.975, 0.475],
            "last_step": 300,
            "J_last_step": 0.5,
            "cell_centre_last_step": [0.975, 0.475],
        }
        for label in large["block-s1"].runs
    }
    smallest["explicit+neo-hookean"].update(last_step=56, J_last_step=0.02)
    smallest["implicit+corotational"]["J"] = 0.16
    smallest["implicit"]["J"] = -0.1  # the solver does not check the linear model
    (folder / "deformation.json").write_text(
        json.dumps(
            {
                "largest_deflection": {"label": REF, "step": 60, "time": 2.0, "u_max": 0.16},
                "smallest_J": smallest,
            }
        )
    )
    text = "\n".join(part2.large_deformation(tmp_path, large))
    row = next(line for line in text.splitlines() if "| explicit+neo-hookean |" in line)
    assert "0.02 at t = 1.87 s, in the cell at (0.975, 0.475) m, beside the needle" in row
    # the jump of J in the last step: from the last kept step to the reason's J
    assert (
        "the smallest J went from 0.02 (in the cell at (0.975, 0.475) m, beside the needle) "
        "to -41.5 on block-s1" in text
    )
    assert "| block-s1 | s = 1, w = 0 (point needle) | 0.16 (t = 2 s) |" in text
    assert "reaches J = 0.16 at t = 2 s; the reference's smallest J is 0.5" in text
    assert "but some had one: the smallest J of the linear runs is -0.1 on block-s1" in text


def test_ratios_keep_two_significant_digits():
    assert [part2.ratio_text(r) for r in (1.234, 7.5, 64.2, 115.0, 1332.0)] == [
        "1.2",
        "7.5",
        "64",
        "120",
        "1300",
    ]


def test_place_names_the_needle_and_the_clamp():
    block = summary("b", width=0.2)
    assert part2.place(block, [0.975, 0.575]).endswith("beside the needle")
    assert "needle" not in part2.place(block, [0.475, 0.575])
    rod = summary("r", "rod")
    words = part2.place(rod, [0.0417, 0.0417, 0.125])
    assert "clamped face x = 0" in words and "lower edge" in words
    assert "clamped" not in part2.place(rod, [0.458, 0.0417, 0.125])


def test_part_2_sections_show_their_figures_and_static_tips(tmp_path):
    large = four_cases()
    s = large["rod-s1"]
    s.files += ["errors.png", "realism.png", "tip_path.png"]
    tips = {"linear": [0.034, -0.1223], "neo-hookean": [0.0213, -0.1249]}
    tips["neo-hookean-barrier"] = [0.0214, -0.1248]
    tips["corotational"] = [0.0197, -0.1234]
    for model, tip in tips.items():
        update(s.runs[run_label("quasi-static", model)], tip_displacement_final=[*tip, 0.0])
    update(s.runs["quasi-static+svk"], status="diverged", diverged_step=1, diverged_time=H)
    lines = part2.large_deformation(tmp_path, large)
    assert lines[0].startswith("## Part 2")
    section = "\n".join(part2.model_case_section(tmp_path, "rod-s1", s))
    assert "![loss of realism](large-deformation/rod-s1/realism.png)" in section
    assert "![errors](large-deformation/rod-s1/errors.png)" in section
    assert "![tip path](large-deformation/rod-s1/tip_path.png)" in section
    assert "shapes.png" not in section  # not among the case's files
    assert (
        "linear (0.034, -0.1223) m, neo-hookean (0.0213, -0.1249) m, "
        "neo-hookean-barrier (0.0214, -0.1248) m, corotational (0.0197, -0.1234) m" in section
    )
    assert "svk: its quasi-static run diverged, no static tip" in section
    assert (
        "| rod-s1 | (0.034, -0.1223) | diverged at t = 0.0333 s | (0.0213, -0.1249) | "
        "(0.0214, -0.1248) | (0.0197, -0.1234) |" in lines
    )


def test_figures_of_a_model_case_replace_the_paper_figures(tmp_path, monkeypatch):
    """case_figures sends a case with models to figures_models and leaves a linear one alone."""
    from tissuebench.workflows.run import figures

    called = []
    monkeypatch.setattr(
        figures_models, "case_figures", lambda *args: called.append(args[1].name) or ["x.png"]
    )
    case = SimpleNamespace(name="m", runs=[RunSpec("implicit+svk", "implicit", "MP1", "svk")])
    assert figures.case_figures(tmp_path, case, {}, None, {}, {}) == ["x.png"]
    assert called == ["m"]


def test_an_outline_of_several_rings_carries_its_label_once():
    """A deformed outline of two pieces, one with a hole (a folded shape's union), is drawn
    ring by ring with the label on the first only (it once raised on the second ring: the
    leaderboard's large rod on n = 6 lost a 20-minute rerun to it)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure
    from shapely.geometry import MultiPolygon, Polygon

    from tissuebench.workflows.run.model_figures import draw_outline

    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    hole = [(0.4, 0.4), (0.6, 0.4), (0.6, 0.6), (0.4, 0.6)]
    shape = MultiPolygon([Polygon(square, [hole]), Polygon([(2, 0), (3, 0), (3, 1)])])
    ax = Figure().subplots()
    draw_outline(ax, shape, color="k", label="deformed")
    assert len(ax.lines) == 3
    assert [line.get_label() for line in ax.lines].count("deformed") == 1
