"""`tissuebench run` says each run's error against the truth (issue 44: the MP2 Q1 rod, 50 %
too stiff against the truth, scored 0 against implicit on its own grid): the truth case a run
poses (workflows/truth/run.py), and the printed E_i, which is compare's against the truth."""

import dataclasses
import json
from pathlib import Path

import pytest
from helpers import tissuebench

from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth.store import is_cached
from tissuebench.workflows.truth.run import truth_of

pytestmark = pytest.mark.serial  # command lines run as subprocesses


def test_the_truth_a_run_poses():
    """The case of the run's benchmark, material (every property), model, load scale and needle
    width; the mesh, the scheme and our contact penalty do not change the physics."""
    mp2, mp3, mp1 = (get_material(m) for m in ("MP2", "MP3", "MP1"))
    assert truth_of("rod", mp3, "linear", {}) == "rod"
    assert truth_of("rod", mp2, "linear", {}) == "rod-MP2"
    assert truth_of("rod", mp3, "neo-hookean-barrier", {"load_scale": 3.0}) == "rod-nhb-s3"
    assert truth_of("rod", mp3, "neo-hookean-barrier", {"load_scale": 1.5}) == "rod-nhb-s1.5"
    assert truth_of("rod", mp3, "neo-hookean", {"load_scale": 3.0}) is None
    assert truth_of("block", mp1, "linear", {}) is None  # a point needle: no truth
    assert truth_of("block", mp1, "linear", {"needle_width": 0.2}) == "block-MP1-w0.2"
    assert truth_of("contact", mp1, "linear", {"kappa": 100.0}) == "contact-MP1"
    softer = dataclasses.replace(mp3, E=6000.0)  # a user's material named like ours is not ours
    assert truth_of("rod", softer, "linear", {}) is None


def test_run_prints_compare_s_error_against_the_truth(tmp_path: Path):
    """On the paper's rod for 6 steps: where the truth `rod` is cached, run's line for
    explicit-lumped gives compare truth:rod's E_i max to its three digits; where it is not,
    run says so and names the command that computes it."""
    out = tmp_path / "rod"
    done = tissuebench(
        "run", "rod", "--out", out, "--algorithms", "implicit,explicit-lumped", "--end-time", "0.2"
    )
    assert done.returncode == 0, done.stderr[-2000:]
    said = [line for line in done.stdout.splitlines() if "against the truth" in line]
    if not is_cached("rod"):
        assert any("not cached here (`tissuebench truth rod`" in line for line in said), said
        return
    (line,) = [line for line in said if line.startswith("explicit-lumped:")]
    graded = tmp_path / "graded"
    compared = tissuebench("compare", "truth:rod", out / "explicit-lumped.xdmf", "--out", graded)
    assert compared.returncode == 0, compared.stderr[-2000:]
    summary = json.loads((graded / "summary.json").read_text())
    peak = summary["runs"]["explicit-lumped"]["interior_error_max"]
    assert f"E_i max {peak:.3g}," in line, (line, peak)


def test_a_run_whose_truth_does_not_converge_is_told_its_fallback(tmp_path, monkeypatch):
    """Issue 59, item 7e: a cylinder run at full load (s = 1) was told to compute the truth
    cylinder-MP1 (about 25 min), whose levels do not converge. A run that poses a case with
    fallbacks (solvers/truth/fallbacks.py) is told the first of them and the load to run at, at
    which `run` grades it against that fallback; never to compute its own truth."""
    from types import SimpleNamespace

    from mpi4py import MPI

    from tissuebench.solvers.truth.cases import CASES
    from tissuebench.solvers.truth.fallbacks import FALLBACKS
    from tissuebench.workflows.truth.run import truth_lines

    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))  # nothing cached
    origins = {source: case for case, (source, _) in reversed(FALLBACKS.items())}  # the first
    assert origins["cylinder-MP1"] == "cylinder-MP1-s0.5"
    for origin, first in origins.items():
        benchmark, name, model, scale, width = CASES[origin]
        material = get_material(name)
        options = {"load_scale": scale} | ({} if width is None else {"needle_width": width})
        run = SimpleNamespace(plane=None, benchmark=benchmark, options=options,
                              runs={"implicit": SimpleNamespace(model=model)})  # fmt: skip
        (line,) = truth_lines(run, tmp_path / "run", material, MPI.COMM_SELF)
        at = FALLBACKS[first][1]
        assert line.startswith(f"against the truth {origin}: none, its levels do not converge")
        assert f"its fallback is {first}, at load scale s = {at:g}: run again with " in line
        assert f"--load-scale {at:g} (the rest as here)" in line
        assert f"`tissuebench truth {first}` has computed it" in line
        assert f"tissuebench truth {origin}`" not in line
        # run again at that load, the run poses the fallback: it is graded against it
        assert truth_of(benchmark, material, model, {**options, "load_scale": at}) == first
