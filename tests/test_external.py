"""`tissuebench external` and the leaderboard: outside simulators run end to end and graded.
The checks are against things independent of the runner: our implicit is CalculiX's
ALPHA = 0 scheme (the same trapezoidal rule on the same mesh), HHT-alpha and reduced
integration are other schemes and discretisations and must show it, and the Pareto front is
checked by hand on points whose front is known."""

import argparse
import csv
import json

import numpy as np
import pytest
from helpers import needs_ccx, tissuebench

from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard.rows import Board, pareto

# a minute or more in all: make test starts it first; its runs are not graded against a cached
# truth
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("empty_truth_cache")]

SMALL = ["--mesh-size", "2", "--material", "MP3", "--end-time", "0.5"]  # 15 steps of 1/30 s


def metric(folder, column):
    """A column of a grading folder's metrics.csv, steps 0..N."""
    with open(folder / "metrics.csv", newline="") as f:
        return np.array([float(row[column] or "nan") for row in csv.DictReader(f)])


def test_pareto_front_by_hand():
    """(cost, error): a point is on the front unless another is at most as costly and as wrong
    and better in one; equal points do not dominate each other."""
    points = [(1, 1), (2, 0.5), (3, 0.7), (0.5, 2), (2, 0.5), (4, 0.1), (5, 0.1)]
    assert pareto(points) == [True, True, False, True, True, True, False]


@pytest.mark.serial
def test_external_refuses_in_one_line(tmp_path):
    """An unknown simulator and an unknown option value end in one line, exit 2."""
    r = tissuebench("external", "nosuch", "rod", "--out", tmp_path / "x")
    assert r.returncode == 2 and "unknown simulator 'nosuch'" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = tissuebench("external", "calculix", "rod", "--dt", "-1", "--out", tmp_path / "x")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x").exists()


@needs_ccx
@pytest.mark.serial
def test_external_calculix_variants_on_the_rod(tmp_path):
    """CalculiX's ALPHA = 0 (the trapezoidal rule) reproduces our implicit within its printed
    digits after the first steps; HHT with ALPHA = -0.05 departs (its numerical damping) and
    reduced integration (C3D8R) departs further (another discretisation). A variant that
    cannot pose the rod (explicit: MP3 has stiffness damping) is refused with its reason; a
    second identical call keeps the complete folder."""
    out = tmp_path / "ccx"
    variants = "implicit-C3D8,hht-C3D8,implicit-C3D8R"
    r = tissuebench("external", "calculix", "rod", *SMALL, "--variants", variants, "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "not posed: calculix:explicit: CalculiX refuses stiffness damping" in r.stdout
    summary = json.loads((out / "summary.json").read_text())
    runs = summary["runs"]
    assert list(runs) == [f"calculix:{v}" for v in variants.split(",")]
    for label, run in runs.items():
        assert run["status"] == "ok" and run["wall_time_s"] > 0 and run["dofs"] == 135, (
            label
        )  # 5 x 3 x 3 nodes
        assert (out / label.split(":")[1] / "work" / "job.frd").is_file()
    e_n = metric(out / "implicit-C3D8", "relative_error")
    assert np.isnan(e_n[0]) and len(e_n) == 16
    assert np.all(e_n[6:] <= 1e-5), e_n  # CalculiX's a_0 differs in the first steps
    mean = {v: runs[f"calculix:{v}"]["interior_error_mean"] for v in variants.split(",")}
    assert mean["implicit-C3D8"] < 1e-7
    assert mean["hht-C3D8"] > 3 * mean["implicit-C3D8"]
    assert mean["implicit-C3D8R"] > 10 * mean["hht-C3D8"]
    # the leaderboard's row is compare's own grading of the same files
    again = compare(out / "reference.xdmf", out / "hht-C3D8" / "work" / "job.frd", tmp_path / "g")
    assert again and json.loads((tmp_path / "g" / "summary.json").read_text())["runs"]["job"][
        "interior_error_mean"
    ] == pytest.approx(mean["hht-C3D8"], rel=1e-12)
    r = tissuebench("external", "calculix", "rod", *SMALL, "--variants", "explicit-C3D8",
                    "--out", tmp_path / "x")  # fmt: skip
    assert r.returncode == 2 and "no variant explicit-C3D8" in r.stderr
    assert "stiffness damping" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = tissuebench("external", "calculix", "rod", *SMALL, "--variants", variants, "--out", out)
    assert r.returncode == 0 and "complete results for the same inputs exist, skipped" in r.stdout


@needs_ccx
@pytest.mark.serial
def test_leaderboard_on_a_small_rod(tmp_path, monkeypatch):
    """One small case: every algorithm of ours and CalculiX's variants in the table, the
    reference first with zero error, a user's compare folder joins the case, no run on the
    front is dominated by another finished run, and a leaderboard with rows of a simulator
    that cannot run here is not replaced without --force."""
    board = Board("rod-small", "rod", "MP3", "linear", simulators=("calculix",), mesh_size=2,
                  end_time=0.5, description="rod, n = 2, 0.5 s")  # fmt: skip
    monkeypatch.setattr(leaderboard, "BOARDS", [board])
    args = argparse.Namespace(out=tmp_path, solver="direct", petsc="", force=False, rerun=[])
    # a user's run, graded by compare into the case's user/ folder beforehand
    ours = tmp_path / "seed"
    assert tissuebench("run", "rod", *SMALL, "--algorithms", "implicit,explicit-lumped",
                       "--out", ours).returncode == 0  # fmt: skip
    user = tmp_path / "leaderboard" / "rod-small" / "user" / "mine"
    compare(ours / "implicit.xdmf", ours / "explicit-lumped.xdmf", user, label="my-solver",
            wall_time=0.25)  # fmt: skip
    assert leaderboard.main(args) == 0
    with open(tmp_path / "leaderboard.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    labels = [r["label"] for r in rows]
    assert {"implicit", "implicit-lumped", "explicit", "explicit-lumped", "quasi-static"} <= set(
        labels
    )
    # implicit and hht, each with C3D8, C3D8I, C3D8R and C3D20R
    assert sum(label.startswith("calculix:") for label in labels) == 8
    # ours on the rod split into tetrahedra and on gmsh's tetrahedra, graded on their own
    # meshes against the hexahedral reference: the cells alone make them differ from it
    for shape in ("tetrahedron grid", "tetrahedron unstructured"):
        tets = [r for r in rows if r["label"].endswith(f"({shape})")]
        assert len(tets) == 5, shape
        implicit = next(r for r in tets if r["label"].startswith("implicit ("))
        assert float(implicit["interior_error_max"]) > 0 and implicit["reference"] == "False"
    mine = next(r for r in rows if r["label"] == "my-solver")
    assert mine["timing"] == "reported by the user" and float(mine["wall_time_s"]) == 0.25
    lumped = next(r for r in rows if r["label"] == "explicit-lumped")
    assert float(mine["interior_error_mean"]) == pytest.approx(
        float(lumped["interior_error_mean"]), rel=1e-12
    )  # the same run, graded by compare and by the study
    reference = next(r for r in rows if r["reference"] == "True")
    assert reference["label"] == "implicit" and float(reference["interior_error_max"]) == 0
    done = [r for r in rows if r["status"] == "ok" and r["reference"] == "False"]
    points = {
        r["label"]: (float(r["wall_per_simulated_s"]), float(r["interior_error_mean"]))
        for r in done
    }
    for r in done:
        c, e = points[r["label"]]
        dominated = any(c2 <= c and e2 <= e and (c2, e2) != (c, e) for c2, e2 in points.values())
        assert (r["pareto_mean"] == "True") == (not dominated), r["label"]
    text = (tmp_path / "leaderboard.md").read_text()
    assert text.startswith(leaderboard.MARKER) and "## rod-small" in text
    assert (tmp_path / "leaderboard" / "rod-small.png").stat().st_size > 10_000
    # a full leaderboard (here: one with a simulator that is not installed) is kept
    # (written as ours: a record of another machine, listed in the folder's manifest)
    from tissuebench.workflows.io.output import write_owned

    record = json.loads((tmp_path / "leaderboard.json").read_text())
    elsewhere = dict(record["cases"][0]["rows"][-1], label="elsewhere:fast", source="Elsewhere")
    record["cases"][0]["rows"].append(elsewhere)
    write_owned(tmp_path / "leaderboard.json", lambda tmp: tmp.write_text(json.dumps(record)))
    with pytest.raises(leaderboard.OutputError, match="elsewhere, which cannot run here"):
        leaderboard.main(args)


@needs_ccx
@pytest.mark.serial
def test_leaderboard_across_mesh_sizes_runs_the_chosen_variants(tmp_path, monkeypatch):
    """A series of two mesh sizes (issue 27): on the finer case only the variants named for it
    run, the note says why the others do not, and one table lines the runs up across sizes."""
    common = dict(simulators=("calculix",), end_time=0.2, sizes="small")
    boards = [
        Board("rod-n1", "rod", "MP3", "linear", mesh_size=1, description="n = 1", **common),
        Board("rod-n2", "rod", "MP3", "linear", mesh_size=2, description="n = 2",
              variants={"calculix": ("implicit-C3D8I",)}, skip_note="only C3D8I here",
              **common),
    ]  # fmt: skip
    monkeypatch.setattr(leaderboard, "BOARDS", boards)
    args = argparse.Namespace(out=tmp_path, solver="direct", petsc="", force=False, rerun=[])
    assert leaderboard.main(args) == 0
    with open(tmp_path / "leaderboard.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ccx = {(r["case"], r["label"]) for r in rows if r["label"].startswith("calculix:")}
    assert len([c for c in ccx if c[0] == "rod-n1"]) == 8
    assert [c for c in ccx if c[0] == "rod-n2"] == [("rod-n2", "calculix:implicit-C3D8I")]
    text = (tmp_path / "leaderboard.md").read_text()
    assert "- only C3D8I here" in text
    # one table lines the runs up across the sizes (figures.size_table, from the record)
    from tissuebench.workflows.leaderboard.figures import size_series, size_table
    from tissuebench.workflows.leaderboard.record import read_record

    recorded, rows, _ = read_record(tmp_path)
    (series,) = size_series(recorded)
    table = [line for line in size_table(series, rows) if line.startswith("| ")]
    assert "n = 1 (" in table[0] and "n = 2 (" in table[0]
    labels = [line.split(" | ")[0][2:] for line in table[1:]]
    assert "calculix:implicit-C3D8I" in labels and "calculix:hht-C3D8" not in labels
    assert "implicit" in labels  # ours at both sizes
