"""Issue 5: the command line's contract (files, columns, skipping, refusals) and its MPI runs."""

import csv
import json
import time

import numpy as np
import pytest
from helpers import tissuebench

from tissuebench.workflows.io.series import read_series

COLUMNS = [
    "algorithm",
    "step",
    "time",
    "relative_error",
    "surface_error",
    "interior_error",
    "interior_error_nodal",
    "status",
]

# drives the command line in subprocesses; their runs are not graded against a cached truth
pytestmark = [pytest.mark.serial, pytest.mark.slow, pytest.mark.usefixtures("empty_truth_cache")]


def read_metrics(path):
    with open(path) as f:
        rows = list(csv.reader(f))
    assert rows[0] == COLUMNS
    return rows[1:]


def curves(path):
    """{algorithm: array of (step, time, the four metrics)} from a metrics.csv."""
    out = {}
    for row in read_metrics(path):
        out.setdefault(row[0], []).append([float(x) for x in row[1:-1]])
    return {k: np.array(v) for k, v in out.items()}


def statuses(path):
    """{algorithm: [status per step]} from a metrics.csv."""
    out = {}
    for row in read_metrics(path):
        out.setdefault(row[0], []).append(row[-1])
    return out


def block_args(out):
    """A small block run: N = 6, 1 s, explicit and quasi-static beside the reference."""
    return (
        "run",
        "block",
        "--out",
        out,
        "--mesh-size",
        6,
        "--end-time",
        1.0,
        "--algorithms",
        "explicit,quasi-static",
    )


@pytest.fixture(scope="module")
def block_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "block"
    start = time.perf_counter()
    r = tissuebench(*block_args(out))
    r.wall_s = time.perf_counter() - start  # the whole command, start-up included
    assert r.returncode == 0, r.stderr[-2000:]
    return out, r


def test_run_writes_the_contract(block_run):
    out, result = block_run
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["runs"]) == {
        "implicit",
        "explicit",
        "quasi-static",
    }  # the reference always runs
    for label, run in summary["runs"].items():
        assert run["status"] == "ok" and run["steps"] == 30 and run["diverged_step"] is None
        assert {"wall_time_s", "relative_error_max", "interior_error_mean"} <= set(run)
        series = read_series(out / f"{label}.xdmf")
        assert np.allclose(series.times, np.arange(31) / 30)
        assert read_series(out / f"{label}.xdmf", "velocity").displacements[0].shape == (49, 2)
    assert (
        summary["benchmark"] == "block"
        and summary["material"] == ["MP1"]
        and summary["mesh_size"] == 6
    )
    assert summary["h"] == pytest.approx(1 / 30) and summary["end_time"] == pytest.approx(1.0)
    assert summary["versions"]["dolfinx"]
    for figure in ("errors.png", "deformed.png", "reference.gif"):
        assert (out / figure).stat().st_size > 1000
    c = curves(out / "metrics.csv")
    assert set(c) == {"implicit", "explicit", "quasi-static"}
    ref = c["implicit"]
    assert np.array_equal(ref[:, 0], np.arange(31)) and np.allclose(ref[:, 1], np.arange(31) / 30)
    assert np.isnan(ref[0, 2]) and np.all(ref[1:, 2:] == 0)  # the reference's own rows
    assert np.all(c["quasi-static"][1:, 2:] > 0)
    assert "implicit" in result.stdout and "ok" in result.stdout


def test_run_says_and_records_the_time_of_each_phase(block_run):
    """summary.json's phases_s: mesh, forms, each run's set-up and loop, output, metrics,
    figures, each non-negative, summing to no more than the command's wall time; one line each
    on stdout with the same time."""
    out, result = block_run
    summary = json.loads((out / "summary.json").read_text())
    phases = summary["phases_s"]
    runs = [f"run {label}" for label in summary["runs"]]
    assert list(phases) == ["mesh", "forms", *runs, "output", "metrics", "figures"]
    assert all(t >= 0 for t in phases.values())
    assert sum(phases.values()) <= result.wall_s
    for phase, t in phases.items():
        line = next(x for x in result.stdout.splitlines() if x.startswith(f"block: {phase} "))
        assert line.split()[-2] == f"{t:.2f}"


def test_no_figures_draws_none_and_writes_the_same_numbers(tmp_path):
    """--no-figures: no PNG or GIF, none listed in summary.json, every other file as with
    figures and the same numbers; run again without it, the figures are drawn (the same
    inputs are not skipped while their figures are missing)."""
    args = ("run", "rod", "--mesh-size", 1, "--end-time", 0.2, "--algorithms", "explicit")
    drawn, bare = tmp_path / "drawn", tmp_path / "bare"
    r = tissuebench(*args, "--out", drawn)
    assert r.returncode == 0, r.stderr[-2000:]
    r = tissuebench(*args, "--out", bare, "--no-figures")
    assert r.returncode == 0, r.stderr[-2000:]
    pictures = {p.name for p in drawn.iterdir() if p.suffix in (".png", ".gif")}
    assert {"errors.png", "tip.png", "deformed.png", "reference.gif"} <= pictures
    assert not any(p.suffix in (".png", ".gif") for p in bare.iterdir())
    a, b = (json.loads((d / "summary.json").read_text()) for d in (drawn, bare))
    assert [f for f in a["files"] if f not in pictures] == b["files"]
    assert all((bare / f).is_file() for f in b["files"])
    assert "figures" in a["phases_s"] and "figures" not in b["phases_s"]
    for name in ("metrics.csv", "tip.csv"):
        assert (drawn / name).read_bytes() == (bare / name).read_bytes()
    for label, run in a["runs"].items():
        timed = ("wall_time_s", "setup_time_s")
        assert {k: v for k, v in run.items() if k not in timed} == {
            k: v for k, v in b["runs"][label].items() if k not in timed
        }
    assert a["fingerprint"] == b["fingerprint"]
    r = tissuebench(*args, "--out", bare)  # the same inputs, with figures this time
    assert r.returncode == 0, r.stderr[-2000:]
    assert "without figures" in r.stdout and "skipped" not in r.stdout
    assert pictures <= {p.name for p in bare.iterdir()}


def test_rerun_skips_complete_results_unless_forced(block_run):
    out, _ = block_run
    before = (out / "summary.json").stat().st_mtime_ns
    args = block_args(out)
    r = tissuebench(*args)
    assert r.returncode == 0 and "skipped" in r.stdout
    assert (out / "summary.json").stat().st_mtime_ns == before


def test_compare_reads_our_output_back(block_run, tmp_path):
    """compare on our own XDMF files gives the curves that run computed in memory."""
    out, _ = block_run
    r = tissuebench(
        "compare", out / "implicit.xdmf", out / "quasi-static.xdmf", "--out", tmp_path / "cmp"
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert "relative_error: max" in r.stdout
    ours = curves(out / "metrics.csv")["quasi-static"]
    theirs = curves(tmp_path / "cmp" / "metrics.csv")["quasi-static"]
    assert np.allclose(theirs, ours, rtol=1e-10, atol=1e-14, equal_nan=True)


def test_diverged_run_is_reported_and_kept(tmp_path):
    out = tmp_path / "mp2"
    r = tissuebench(
        "run",
        "block",
        "--out",
        out,
        "--mesh-size",
        6,
        "--material",
        "MP2",
        "--end-time",
        0.5,
        "--algorithms",
        "explicit-lumped",
    )
    assert r.returncode == 0, r.stderr[-2000:]
    run = json.loads((out / "summary.json").read_text())["runs"]["explicit-lumped"]
    assert run["status"] == "diverged" and run["diverged_step"] >= 1
    assert run["diverged_time"] == pytest.approx(run["diverged_step"] / 30)
    c = curves(out / "metrics.csv")["explicit-lumped"]
    assert len(c) == 16 and np.all(np.isnan(c[run["diverged_step"] :, 2:]))
    k = run["diverged_step"]
    assert statuses(out / "metrics.csv")["explicit-lumped"] == ["ok"] * k + ["diverged"] * (16 - k)
    assert len(read_series(out / "explicit-lumped.xdmf").times) == run["diverged_step"]
    assert "DIVERGED" in r.stdout


@pytest.mark.parametrize(
    "args, message",
    [
        (("run", "sphere"), "unknown benchmark"),
        (("run", "block", "--algorithms", "leapfrog"), "unknown algorithm"),
        (("run", "block", "--material", "MP7"), "unknown material"),
        (("run", "block", "--dt", "0"), "positive number"),
        (("run", "block", "--dt", "-0.1"), "positive number"),
        (("run", "block", "--end-time", "nan"), "positive number"),
        (("run", "block", "--mesh-size", "7"), "must be even"),
        (("run", "rod", "--mesh-size", "0"), "positive whole number"),
        (("run", "block", "--solver", "magic"), "unknown solver"),
        (("run", "block", "--models", "linear,hyperelastic"), "unknown model"),
        (("run", "rod", "--load-scale", "0"), "load scale must be"),
        (("run", "block", "--load-scale", "-2"), "load scale must be"),
        (("run", "rod", "--load-scale", "inf"), "load scale must be"),
        (("run", "block", "--models", "svk", "--plane", "stress"), "plane strain"),
        (("run", "block", "--reference", "implicit+svk"), "not among the runs"),
        (("run", "rod", "--models", "svk", "--reference", "implicit"), "not among the runs"),
        (
            ("run", "rod", "--models", "svk", "--petsc", "-implicit_snes_type nonsense"),
            "SNES type nonsense",
        ),
    ],
)
def test_refusals(tmp_path, args, message):
    out = tmp_path / "out"
    r = tissuebench(
        *args,
        "--out",
        out,
        "--end-time" if "--end-time" not in args else "--needle-width",
        "0.1" if "--end-time" not in args else "0",
    )
    assert r.returncode == 2
    assert (
        message in r.stderr
        and len(r.stderr.strip().splitlines()) == 1
        and "Traceback" not in r.stderr
    )
    assert not out.exists() and not any(tmp_path.iterdir())


def test_refuses_bad_material_file_and_unwritable_output(tmp_path):
    bad = tmp_path / "soft.toml"
    bad.write_text("E = 100\nnu = 0.6\nrho = 1000\n")
    r = tissuebench("run", "block", "--material", bad, "--out", tmp_path / "a")
    assert r.returncode == 2 and "nu must satisfy" in r.stderr and not (tmp_path / "a").exists()
    blocker = tmp_path / "file"
    blocker.write_text("")
    r = tissuebench("run", "block", "--out", blocker / "x")
    assert r.returncode == 2 and "cannot create" in r.stderr
    r = tissuebench(
        "compare", tmp_path / "missing.xdmf", tmp_path / "missing2.xdmf", "--out", tmp_path / "c"
    )
    assert r.returncode == 2 and "missing.xdmf" in r.stderr and not (tmp_path / "c").exists()


def test_interrupted_output_is_replaced_whole(tmp_path):
    """A leftover partial directory of ours (an interrupted run, with our marker) and an
    incomplete folder of ours (a file of ours deleted) are redone."""
    out = tmp_path / "rod"
    args = ("run", "rod", "--out", out, "--mesh-size", 1, "--end-time", 0.2)
    r = tissuebench(*args, "--algorithms", "implicit")
    assert r.returncode == 0, r.stderr[-2000:]
    (out / "implicit.h5").unlink()
    partial = tmp_path / ".tissuebench-partial-rod"
    partial.mkdir()
    (partial / "junk.h5").write_text("half")
    (partial / ".tissuebench-temporary").write_text('{"tissuebench": "temporary"}')
    r = tissuebench(*args, "--algorithms", "implicit")
    assert r.returncode == 0, r.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rod"]
    summary = json.loads((out / "summary.json").read_text())
    assert all((out / f).is_file() for f in summary["files"])
    assert (out / "tip.csv").is_file() and len(
        summary["runs"]["implicit"]["tip_displacement_final"]
    ) == 3


@pytest.mark.parametrize(
    "benchmark, size, shape",
    [
        ("block", 8, ()),
        ("rod", 2, ()),
        ("block", 8, ("--cell", "triangle", "--mesh", "unstructured", "--needle-width", 0.2)),
        ("rod", 2, ("--cell", "tetrahedron")),
    ],
)
def test_run_serial_equals_mpiexec(tmp_path, benchmark, size, shape):
    # the numbers only: the figures are drawn under mpiexec in test_signals and the README's line
    args = ("run", benchmark, "--mesh-size", size, "--end-time", 1.0, "--no-figures", *shape)
    serial = tissuebench(*args, "--out", tmp_path / "serial")
    parallel = tissuebench(*args, "--out", tmp_path / "parallel", ranks=2)
    assert serial.returncode == 0 and parallel.returncode == 0, parallel.stderr[-2000:]
    a, b = (
        curves(tmp_path / "serial" / "metrics.csv"),
        curves(tmp_path / "parallel" / "metrics.csv"),
    )
    assert a.keys() == b.keys()
    for label in a:
        assert np.allclose(a[label], b[label], rtol=1e-8, atol=1e-12, equal_nan=True), label
    assert (
        json.loads((tmp_path / "parallel" / "summary.json").read_text())["versions"]["mpi_ranks"]
        == 2
    )
    assert parallel.stdout.count("results in") == 1  # only rank 0 prints
    assert parallel.stdout.count("all phases") == 1


def test_mesh_command_saves_msh(tmp_path):
    import meshio

    r = tissuebench("mesh", "rod", "--mesh-size", 2, "--out", tmp_path / "rod.msh")
    assert r.returncode == 0, r.stderr[-2000:]
    m = meshio.read(tmp_path / "rod.msh")
    assert (
        len(m.points) == 5 * 3 * 3
        and sum(len(c.data) for c in m.cells if c.type == "hexahedron") == 16
    )
    assert "clamped" in r.stdout
    r = tissuebench("mesh", "block", "--mesh-size", 3, "--out", tmp_path / "b.msh")
    assert r.returncode == 2 and "must be even" in r.stderr and not (tmp_path / "b.msh").exists()
