"""The real-time frontier (SPEC 11, workflows/frontier/runs.py and frontier/report.py): which runs
it holds, that an interrupted study resumes where it stopped, and the frontier and Pareto
selections on rows whose answer is known."""

import math

import pytest

from tissuebench.workflows.frontier import runs as study
from tissuebench.workflows.frontier.report import frontier, markdown, pareto

pytestmark = pytest.mark.serial  # the study runs on one core, never under mpiexec


def row(scheme="standard", algorithm="implicit", requested="1", size=3, cost=0.01, mean=1e-5,
        status="ok", cell="hexahedron", case="rod-MP2"):  # fmt: skip
    return {
        "case": case, "benchmark": "rod", "material": "MP2", "cell": cell, "scheme": scheme,
        "algorithm": algorithm, "requested": requested, "substeps": 1, "mesh_size": size,
        "dofs": 336, "critical_dt_s": math.nan, "status": status, "diverged_time": math.nan,
        "setup_s": 0.1, "loop_s": cost * 10, "cost": cost, "interior_error_mean": mean,
        "interior_error_max": 2 * mean, "relative_error_mean": 0.1, "relative_error_max": 0.2,
        "truth_own_error": 6e-7, "truth_size": 1e-4, "timings": 1,
        "whole_s": 0.1 + cost * 10, "whole_cost": (0.1 + cost * 10) / 10,
    }  # fmt: skip


def test_the_study_holds_every_scheme_on_its_cells_and_four_sizes():
    configs = list(study.configs(("rod-MP2", "block-MP2-w0.2")))
    shapes = {
        "rod-MP2": ("hexahedron", "tetrahedron"),
        "block-MP2-w0.2": ("quadrilateral", "triangle"),
    }
    for case, cells in shapes.items():
        mine = [c for c in configs if c.case == case]
        assert {c.cell for c in mine} == set(cells)
        assert len({c.mesh_size for c in mine}) == 4
        schemes = {c.scheme.split(":")[0] for c in mine}
        assert schemes == {"standard", "mean-dilatation", "hourglass", "anp", "penalty"}
        # explicit-lumped at h itself only for Q1/P1 and the penalty (the paper's question)
        at_h = {
            c.scheme.split(":")[0]
            for c in mine
            if c.algorithm == "explicit-lumped" and c.substeps == 1
        }
        assert at_h == {"standard", "penalty"}
        # explicit (consistent mass) with auto sub-steps, on every scheme and cell that
        # explicit-lumped with auto sub-steps runs on, on the two smaller sizes
        smaller = sorted({c.mesh_size for c in mine})[:2]
        lumped = {c.key()[:3] + c.key()[5:] for c in mine if c.algorithm == "explicit-lumped"
                  and c.substeps == "auto" and c.mesh_size in smaller}  # fmt: skip
        consistent = {c.key()[:3] + c.key()[5:] for c in mine if c.algorithm == "explicit"}
        assert {c.mesh_size for c in mine if c.algorithm == "explicit"} == set(smaller)
        assert consistent == lumped and {c.substeps for c in mine if c.algorithm == "explicit"} == {
            "auto"
        }
    assert len({c.key() for c in configs}) == len(configs)


def test_an_interrupted_study_resumes_from_its_rows(tmp_path, monkeypatch):
    calls = []

    def fake_run(config, truth, comm):
        if len(calls) == 3:
            raise KeyboardInterrupt
        calls.append(config.key())
        return row(config.scheme, config.algorithm, str(config.substeps), config.mesh_size,
                   cell=config.cell, case=config.case)  # fmt: skip

    monkeypatch.setattr(study, "run_config", fake_run)
    monkeypatch.setattr(study, "load_truth", lambda case, comm: "truth")
    monkeypatch.setattr(study, "own_error", lambda truth: 6e-7)  # the rows' truth_own_error
    with pytest.raises(KeyboardInterrupt):
        study.run_study(tmp_path, ("rod-MP2",), quick=True)
    kept = study.read_rows(tmp_path / "frontier.csv")
    assert [study.row_key(r) for r in kept] == calls
    first = list(calls)
    calls.clear()
    monkeypatch.setattr(
        study, "run_config", lambda c, t, comm: (calls.append(c.key()), fake_row(c))[1]
    )
    rows = study.run_study(tmp_path, ("rod-MP2",), quick=True)
    every = [c.key() for c in study.configs(("rod-MP2",), quick=True)]
    assert calls == every[3:] and first == every[:3]
    assert sorted(study.row_key(r) for r in rows) == sorted(every)
    # a truth computed again (another own error): every row of the case runs again
    calls.clear()
    monkeypatch.setattr(study, "own_error", lambda truth: 5e-7)
    rows = study.run_study(tmp_path, ("rod-MP2",), quick=True)
    assert calls == every and len(study.read_rows(tmp_path / "frontier.csv")) == len(every)


def fake_row(config):
    return row(config.scheme, config.algorithm, str(config.substeps), config.mesh_size,
               cell=config.cell, case=config.case)  # fmt: skip


def test_frontier_and_pareto_pick_the_known_runs():
    rows = [
        row("standard", cost=0.02, mean=4e-5),
        row("standard", size=6, cost=2.0, mean=1e-5),  # too costly for real time
        row("mean-dilatation", cost=0.01, mean=5e-6),
        row("mean-dilatation", size=6, cost=0.5, mean=1e-6),
        row("anp", cell="tetrahedron", cost=0.005, mean=3e-5),
        row(
            "penalty:nu_p=0.3,k=0.1",
            "explicit-lumped",
            cell="tetrahedron",
            status="diverged",
            cost=1e-4,
            mean=math.nan,
        ),  # fmt: skip
    ]
    best = frontier(rows)
    assert [(r["scheme"], r["mesh_size"]) for r in best] == [
        ("mean-dilatation", 6), ("anp", 3), ("standard", 3)
    ]  # fmt: skip
    front = pareto(rows)
    assert [(r["scheme"], r["cost"]) for r in front] == [
        ("anp", 0.005), ("mean-dilatation", 0.01), ("mean-dilatation", 0.5)
    ]  # fmt: skip
    text = markdown(rows, ("rod-MP2",), "header")
    assert "closest run is mean-dilatation implicit on the size-6 mesh" in text
    # the paper's grid (n = 3), implicit: Q1 4e-5 m^3 at 0.02 s/s, mean-dilatation 5e-6 at 0.01
    assert "8 times closer to the truth (E_i mean) at 0.5 times the cost" in text


def test_the_answer_reads_the_rows():
    """results/README.md's SPEC 11 section: the closest real-time run with its share of the
    truth's size (E_i max / size), the paper's grid Q1 against mean-dilatation, and the
    paper's question where the penalty at h = 1/30 s diverged."""
    from tissuebench.workflows.frontier.report import answer

    rows = [
        row("standard", cost=0.02, mean=4e-5) | {"interior_error_max": 5e-5},
        row("mean-dilatation", cost=0.01, mean=5e-6) | {"interior_error_max": 1e-5},
        row("penalty:nu_p=0.3,k=0.1", "explicit-lumped", cell="tetrahedron", status="diverged",
            mean=math.nan) | {"diverged_time": 0.2},
        row("standard", "explicit-lumped", "auto", cell="tetrahedron", mean=3e-5)
        | {"substeps": 23},
    ]  # fmt: skip
    for r in rows:
        r["truth_size"] = 1e-4
    text = " ".join(answer(rows))
    assert "closest run is mean-dilatation implicit on the size-3 mesh" in text
    assert "max 1e-05, 10 % of the truth's size" in text
    assert "Q1 is 50 % off (E_i mean 4e-05) and mean-dilatation 10 % (E_i mean 5e-06)" in text
    assert "penalty:nu_p=0.3,k=0.1 diverged at t = 0.2 s" in text
    assert "with 23 sub-steps: E_i mean 3e-05" in text
    assert "closest runs are: rod-MP2: mean-dilatation implicit, n = 3, 10 %" in text
    assert "With an explicit loop (sub-steps included): rod-MP2: P1 explicit-lumped" in text


def test_a_cost_near_the_budget_is_timed_again_and_the_smaller_kept(tmp_path, monkeypatch):
    """Rows within RETIME are timed once more; the smaller time stands, the row says it was
    timed twice, and it is not timed a third time."""
    rows = [row(cost=0.5), row("mean-dilatation", cost=0.001), row("anp", cost=2.0)]
    study.write_rows(tmp_path / "frontier.csv", rows, study.COLUMNS)
    # the rows' loops took 10 x cost seconds for 10 simulated s: again 3 s, then 30 s
    again = iter([3.0, 30.0])
    monkeypatch.setattr(study, "loop_seconds", lambda config: next(again))
    kept = study.retime(tmp_path, log=lambda line: None)
    costs = {r["scheme"]: (r["cost"], r["timings"]) for r in kept}
    assert costs["standard"] == (pytest.approx(0.3), 2)  # faster the second time
    assert costs["anp"] == (pytest.approx(2.0), 2)  # slower: the first time stands
    assert costs["mean-dilatation"] == (pytest.approx(0.001), 1)  # far from the budget
    assert study.read_rows(tmp_path / "frontier.csv") == kept

    def never(config):
        raise AssertionError("timed a third time")

    monkeypatch.setattr(study, "loop_seconds", never)
    study.retime(tmp_path, log=lambda line: None)


def test_a_row_carries_its_whole_run_time_also_from_an_older_file(tmp_path):
    """whole_s is the set-up and the loop (s), whole_cost their sum per simulated second; a
    frontier.csv written before those columns gets them from setup_s, loop_s and cost."""
    old = [c for c in study.COLUMNS if c not in ("whole_s", "whole_cost")]
    r = row(cost=0.05) | {"setup_s": 2.0}  # loop 0.5 s for 10 simulated s
    study.write_rows(tmp_path / "frontier.csv", [{k: r[k] for k in old}], old)
    (back,) = study.read_rows(tmp_path / "frontier.csv")
    assert back["whole_s"] == pytest.approx(2.5)
    assert back["whole_cost"] == pytest.approx(0.25) and back["cost"] == pytest.approx(0.05)


def test_the_answer_says_why_explicit_lumped_loses_with_the_measured_rows():
    """On an MP2 case the answer compares, mean-dilatation on the paper's grid, explicit-lumped
    (alpha M_L damping) with explicit (alpha M + beta K_0) and implicit, from the rows."""
    from tissuebench.workflows.frontier.report import answer

    md = "mean-dilatation"
    rows = [
        row(md, "explicit-lumped", "auto", mean=2e-5) | {"interior_error_max": 4.5e-5,
                                                        "substeps": 37},
        row(md, "explicit", "auto", mean=4e-6) | {"interior_error_max": 7.7e-6, "substeps": 40},
        row(md, cost=0.02, mean=4e-6) | {"interior_error_max": 7.6e-6},
    ]  # fmt: skip
    text = " ".join(answer(rows))
    assert "Explicit-lumped against explicit on the damped MP2 cases" in text
    assert "explicit-lumped (37 sub-steps) E_i max 4.5e-05, 45 % of the truth's size" in text
    assert "explicit (40 sub-steps) 7.7e-06, 7.7 %" in text
    assert "implicit 7.6e-06, 7.6 %" in text
    assert "alpha = 1 1/s, beta = 0.1 s" in text
    # without the explicit run (an older frontier.csv) the paragraph is not written
    assert "Explicit-lumped against explicit" not in " ".join(answer(rows[::2]))


def test_quick_interrupted_after_its_first_run_resumes_with_the_rest(tmp_path, monkeypatch):
    """Issue 60: `tissuebench frontier --quick` stopped by a signal after its first run (the
    second raising KeyboardInterrupt, as SIGINT does), then run again, runs only the configs
    not yet done, each once, into the same OUT/frontier-quick/frontier.csv; a third run runs
    none."""
    import argparse

    from tissuebench.workflows.commands import frontier as command

    calls = []

    def first_only(config, truth, comm):
        if calls:
            raise KeyboardInterrupt
        calls.append(config.key())
        return fake_row(config)

    monkeypatch.setattr(study, "run_config", first_only)
    monkeypatch.setattr(study, "load_truth", lambda case, comm: "truth")
    monkeypatch.setattr(study, "own_error", lambda truth: 6e-7)  # the rows' truth_own_error
    monkeypatch.setattr(command, "side_by_side", lambda case, repeats: [])  # no timing runs
    monkeypatch.setattr(command, "plot", lambda path, case, rows: path.write_bytes(b"png"))
    args = argparse.Namespace(out=tmp_path, cases="rod", quick=True)
    with pytest.raises(KeyboardInterrupt):
        command.main(args)
    every = [c.key() for c in study.configs(("rod",), quick=True)]
    assert calls == every[:1]
    table = tmp_path / "frontier-quick" / "frontier.csv"
    assert [study.row_key(r) for r in study.read_rows(table)] == every[:1]
    calls.clear()
    monkeypatch.setattr(
        study, "run_config", lambda c, t, comm: (calls.append(c.key()), fake_row(c))[1]
    )
    assert command.main(args) == 0
    assert calls == every[1:]
    assert sorted(study.row_key(r) for r in study.read_rows(table)) == sorted(every)
    calls.clear()
    assert command.main(args) == 0 and calls == []
    assert not (tmp_path / "frontier").exists()  # a quick run never touches the full study's
