"""Issue 13: a benchmark and a metric are each added by one registry line, with no other edit,
and every command that iterates the registries takes them: a throwaway 2D cantilever under
gravity and a throwaway fourth metric (the largest nodal error) run through `run`,
`stability` and the report."""

import csv
import json

from mpi4py import MPI

import gmsh
import numpy as np
import pytest

from tissuebench.meshes import BENCHMARKS
from tissuebench.meshes.benchmark import Benchmark, Constraint, Entry, fixed
from tissuebench.meshes.gmshio import check_positive_int, start_gmsh, to_dolfinx
from tissuebench.metrics import METRICS, Metric
from tissuebench.workflows import cli

LENGTH, HEIGHT = 1.0, 0.25  # m


def cantilever(mesh_size: int = 2, comm: MPI.Comm = MPI.COMM_WORLD, msh_path=None) -> Benchmark:
    """A LENGTH x HEIGHT cantilever of 4n x n quadrilaterals, clamped at x = 0, bending under
    gravity 0.05 m/s^2 in -y."""
    check_positive_int("mesh size", mesh_size)
    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add("cantilever")
        geo = gmsh.model.geo
        p = [
            geo.addPoint(x, y, 0.0) for x, y in [(0, 0), (LENGTH, 0), (LENGTH, HEIGHT), (0, HEIGHT)]
        ]
        lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        for line, cells in zip(
            lines, [4 * mesh_size, mesh_size, 4 * mesh_size, mesh_size], strict=True
        ):
            geo.mesh.setTransfiniteCurve(line, cells + 1)
        geo.mesh.setTransfiniteSurface(surface)
        geo.mesh.setRecombine(2, surface)
        geo.synchronize()
        gmsh.model.addPhysicalGroup(2, [surface], 1, name="cantilever")
        gmsh.model.addPhysicalGroup(1, [lines[3]], 1, name="clamped")  # x = 0
        gmsh.model.mesh.generate(2)
    tagged = to_dolfinx(comm, gdim=2, msh_path=msh_path)
    return Benchmark(
        name="cantilever",
        tagged=tagged,
        constraints=[Constraint("clamped", *tagged.entities("clamped"), fixed(2))],
        gravity=(0.0, -0.05),
        material="MP3",
        dt=1 / 30,
        end_time=2.0,
        extent=LENGTH,
        mesh_size=mesh_size,
        probe=(LENGTH, HEIGHT / 2),
    )


CANTILEVER = Entry(
    build=cantilever,
    gdim=2,
    material="MP3",
    mesh_size=2,
    dt=1 / 30,
    end_time=2.0,
    nodes=lambda n: (4 * n + 1) * (n + 1),
    cell_size=lambda n: HEIGHT / n,
    materials=("MP3",),
    study_sizes=(1, 2),
    probe=(LENGTH, HEIGHT / 2),
    probe_label="free end (1, 0.125) m",
)


def largest_nodal_error(metrics, u_ref: np.ndarray, u_cand: np.ndarray) -> float:
    """max over nodes of |u'_n - u_n| (m), over all ranks."""
    local = np.linalg.norm((u_cand - u_ref).reshape(-1, metrics.dim), axis=1).max(initial=0.0)
    return metrics.comm.allreduce(float(local), op=MPI.MAX)


MAX_ERROR = Metric("E_max", "largest nodal error (m)", largest_nodal_error)


@pytest.fixture
def registered(monkeypatch):
    monkeypatch.setitem(BENCHMARKS, "cantilever", CANTILEVER)  # the one line that adds a benchmark
    monkeypatch.setitem(METRICS, "max_nodal_error", MAX_ERROR)  # the one line that adds a metric


def test_new_benchmark_and_metric_run_through_run_and_report(registered, tmp_path, capsys):
    from tissuebench.workflows.io.summary import CaseSummary
    from tissuebench.workflows.study import common as report

    out = tmp_path / "run"
    status = cli.main(["run", "cantilever", "--end-time", "1", "--out", str(out)])
    assert status == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["runs"]) == {
        "implicit",
        "implicit-lumped",
        "explicit",
        "explicit-lumped",
        "quasi-static",
    }
    assert all(run["status"] == "ok" for run in summary["runs"].values())
    with open(out / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    assert "max_nodal_error" in rows[0]
    ref = [float(r["max_nodal_error"]) for r in rows if r["algorithm"] == "implicit"]
    assert ref == [0.0] * 31  # the reference against itself
    # an independent bound on the new metric: E_i nodal = |Ω|^(-1/2) Σ w_n |e_n| with Σ w_n = |Ω|,
    # so E_i nodal <= |Ω|^(1/2) E_max
    for r in rows:
        if r["algorithm"] == "quasi-static" and int(r["step"]) > 0:
            e_max, nodal = float(r["max_nodal_error"]), float(r["interior_error_nodal"])
            assert 0 < nodal <= (LENGTH * HEIGHT) ** 0.5 * e_max * (1 + 1e-12)
    run = summary["runs"]["quasi-static"]
    assert run["max_nodal_error_max"] > run["max_nodal_error_mean"] > 0
    assert (out / "tip.csv").is_file() and (out / "errors.png").stat().st_size > 1000
    table = report.metric_table(CaseSummary.from_json(summary))  # through the one reader
    assert "E_max max" in table and "quasi-static" in table


def test_new_benchmark_in_the_stability_command(registered, tmp_path, capsys):
    """The eigenvalue prediction of the explicit schemes' critical step, checked by real runs
    just above (diverges) and below (stays bounded) it, on the new benchmark."""
    out = tmp_path / "stability"
    status = cli.main(
        ["stability", "cantilever", "--no-sweep", "--max-steps", "3000", "--out", str(out)]
    )
    assert status == 0, capsys.readouterr().err
    record = json.loads((out / "stability.json").read_text())
    assert record["benchmark"] == "cantilever" and record["cell_size"] == pytest.approx(HEIGHT / 2)
    checks = {(r["algorithm"], r["ratio"] > 1): r["status"] for r in record["run_check"]}
    assert checks == {
        ("explicit", True): "diverged",
        ("explicit", False): "ok",
        ("explicit-lumped", True): "diverged",
        ("explicit-lumped", False): "ok",
    }
