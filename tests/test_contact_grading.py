"""compare against a contact reference (SPEC 12): the candidate's interpenetration, measured
from its series, and its force error when it hands its needle force (--needle-force).

Independent checks: our run's own Measures (solvers/contact.py, the deformed edge in DOLFINx's
dof layout) against compare's sampling of the series file read back (metrics/contact.py); a
candidate moved 0.01 m into the needle (analytic: at the needle's tip, whose normal is -x, the
gap falls by the move); a one-element-thick slab of the same edge (every z layer the 2D chain);
serial against mpiexec -n 2."""

import contextlib
import json
from pathlib import Path

import meshio
import numpy as np
import pytest
from helpers import tissuebench

from tissuebench.core.errors import UserError
from tissuebench.meshes.contact import needle
from tissuebench.metrics.contact import interpenetration_curve
from tissuebench.workflows.compare.grading import GradingError, compare
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.io.tables import read_rows, write_force_csv

# the command on rank 0's files; parallel: its own test; its runs are not graded against a
# cached truth
pytestmark = [pytest.mark.serial, pytest.mark.usefixtures("empty_truth_cache")]

MOVE = 0.01  # m, the candidate moved into the needle


@pytest.fixture(scope="module")
def run4(tmp_path_factory) -> Path:
    """`tissuebench run contact` on N = 4 to T = 1 s (implicit and explicit, sub-stepped)."""
    out = tmp_path_factory.mktemp("contact") / "run4"
    done = tissuebench(
        "run", "contact", "--mesh-size", "4", "--end-time", "1", "--algorithms",
        "implicit,explicit", "--substeps", "auto", "--out", str(out),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    return out


def recorded(run: Path, label: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times s, force (steps, 2) N/m, interpenetration m) of our run `label` (contact.csv)."""
    rows = [r for r in read_rows(run / "contact.csv") if r["algorithm"] == label]
    return (
        np.array([float(r["time"]) for r in rows]),
        np.array([[float(r["force_x"]), float(r["force_y"])] for r in rows]),
        np.array([float(r["interpenetration"]) for r in rows]),
    )


def force_file(run: Path, label: str, path: Path) -> Path:
    times, force, _ = recorded(run, label)
    write_force_csv(path, times, force)
    return path


def graded(out: Path) -> tuple[dict, list[dict]]:
    return json.loads((out / "summary.json").read_text()), read_rows(out / "metrics.csv")


def write_xdmf(path: Path, points, cells, cell_type, values, times) -> None:
    with contextlib.chdir(path.parent), meshio.xdmf.TimeSeriesWriter(path.name) as writer:
        writer.write_points_cells(points, [(cell_type, cells)])
        for t, u in zip(times, values, strict=True):
            writer.write_data(t, point_data={"displacement": u})


@pytest.mark.parametrize("label", ["implicit", "explicit"])
def test_our_run_graded_against_itself_and_its_reference(run4, tmp_path, label):
    """Each run's own force as --needle-force: against its own run a force error of exactly 0;
    and compare's interpenetration at every step, sampled from the series file, equals what our
    run's Measures recorded to 1e-12 m (a first-order candidate on the same mesh)."""
    forces = force_file(run4, label, tmp_path / "force.csv")
    out = tmp_path / "self"
    reference = run4 / f"{label}.xdmf"
    said = compare(reference, reference, out, needle_force=forces)
    summary, rows = graded(out)
    _, _, depth = recorded(run4, label)
    assert summary["contact"]["force_error"] == 0.0
    assert summary["runs"][label]["force_error"] == 0.0
    assert summary["metrics"]["interpenetration_max"]["unit"] == "m"
    assert depth.max() > 0.005  # m: the tissue passes into the needle (a penalty)
    curve = np.array([float(r["interpenetration"]) for r in rows])
    assert np.abs(curve - depth).max() < 1e-12
    assert summary["contact"]["interpenetration_max"] == pytest.approx(depth.max(), abs=1e-12)
    assert "force error force_error: 0 (against our " in said["force error"]
    # against the run folder's reference (implicit): its force from contact.csv
    out = tmp_path / "vs-implicit"
    compare(run4 / "implicit.xdmf", reference, out, needle_force=forces)
    summary, rows = graded(out)
    _, mine, _ = recorded(run4, label)
    _, theirs, _ = recorded(run4, "implicit")
    scale = np.linalg.norm(theirs, axis=1).max()
    expected = np.linalg.norm(mine - theirs, axis=1).max() / scale
    assert summary["contact"]["force_error"] == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert [float(r["force_x"]) for r in rows] == pytest.approx(list(mine[:, 0]), abs=0)
    curve = np.array([float(r["interpenetration"]) for r in rows])
    assert np.abs(curve - depth).max() < 1e-12


def test_a_candidate_moved_into_the_needle(run4, tmp_path):
    """Our implicit moved 0.01 m in +x (into the needle) everywhere: its interpenetration grows
    by the move, never more (the signed distance is 1-Lipschitz), exactly at t = 0 (the edge
    touches the tip, whose outward normal is -x) and at most 3 % less later (the deepest point
    stays near the tip: its normal within 14 degrees of -x); no --needle-force: the force
    error is not given (null), said in one line."""
    series = read_series(run4 / "implicit.xdmf")
    moved = [u + np.array([MOVE, 0.0]) for u in series.displacements]
    candidate = tmp_path / "moved.xdmf"
    write_xdmf(candidate, series.points, series.cells, "quad", moved, series.times)
    out = tmp_path / "graded"
    said = compare(run4 / "implicit.xdmf", candidate, out)
    summary, rows = graded(out)
    _, _, before = recorded(run4, "implicit")
    after = np.array([float(r["interpenetration"]) for r in rows])
    assert after[0] == pytest.approx(MOVE, abs=1e-15)
    grown = after - before
    assert grown.max() <= MOVE * (1 + 1e-12)
    assert grown.min() >= 0.97 * MOVE
    assert np.median(np.abs(grown - MOVE)) < 1e-12  # most steps: exactly the move
    assert summary["contact"]["force_error"] is None and not summary["contact"]["force_given"]
    assert said["force error"].startswith("force error: not given")
    assert "force_x" not in rows[0]


def test_a_slab_has_the_interpenetration_of_its_plane(run4):
    """A one-element-thick slab (the 2D mesh's nodes at z = 0 and 0.1 m, the same in-plane
    displacement on both layers) has the 2D mesh's interpenetration, each z layer its chain."""
    series = read_series(run4 / "explicit.xdmf")
    c = needle(1.0)
    flat = interpenetration_curve(series.points, series.displacements, series.times, c)
    n = len(series.points)
    slab = np.vstack([np.c_[series.points, np.zeros(n)], np.c_[series.points, np.full(n, 0.1)]])
    moved = [np.vstack([np.c_[u, np.zeros(n)]] * 2) for u in series.displacements]
    thick = interpenetration_curve(slab, moved, series.times, c)
    _, _, depth = recorded(run4, "explicit")
    assert np.abs(flat - depth).max() < 1e-12
    assert np.array_equal(thick, flat)
    with pytest.raises(ValueError, match="no node of the candidate lies on the contact edge"):
        interpenetration_curve(series.points * 0.5, series.displacements, series.times, c)


def test_needle_force_is_refused_for_a_rod(tmp_path):
    """--needle-force against a reference that is not a contact case: one line, before any
    truth is loaded or series read; through the command, exit status 2."""
    forces = tmp_path / "f.csv"
    write_force_csv(forces, np.array([0.0, 0.1]), np.zeros((2, 2)))
    with pytest.raises(GradingError, match="--needle-force is for a contact reference") as err:
        compare("truth:rod", tmp_path / "absent.xdmf", tmp_path / "out", needle_force=forces)
    assert "\n" not in str(err.value)
    done = tissuebench(
        "compare", "truth:rod", str(forces), "--out", str(tmp_path / "o2"),
        "--needle-force", str(forces),
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip().count("\n") == 0 and "contact reference" in done.stderr


def test_a_force_file_off_the_steps_is_refused(run4, tmp_path):
    """A force file whose times are not the graded t_i: one line naming the row."""
    times, force, _ = recorded(run4, "implicit")
    bad = tmp_path / "bad.csv"
    write_force_csv(bad, times * 1.5, force)
    with pytest.raises(UserError, match=r"its time stamps are not the graded steps") as err:
        compare(run4 / "implicit.xdmf", run4 / "explicit.xdmf", tmp_path / "o", needle_force=bad)
    assert "\n" not in str(err.value) and "row 2 is at t = 0.05 s" in str(err.value)


def test_serial_equals_mpiexec(run4, tmp_path):
    """compare with --needle-force on 1 and on 2 ranks: the same force error, interpenetration
    and metrics."""
    forces = force_file(run4, "explicit", tmp_path / "force.csv")
    found = {}
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        done = tissuebench(
            "compare", str(run4 / "implicit.xdmf"), str(run4 / "explicit.xdmf"), "--out",
            str(out), "--needle-force", str(forces), ranks=ranks,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-2000:]
        found[ranks] = graded(out)
    (one, rows1), (two, rows2) = found[1], found[2]
    assert one["contact"]["force_error"] > 0
    for key in ("force_error", "interpenetration_max", "interior_error_max"):
        assert one["runs"]["explicit"][key] == pytest.approx(
            two["runs"]["explicit"][key], rel=1e-10, abs=1e-15
        )
    for a, b in zip(rows1, rows2, strict=True):
        assert float(a["interpenetration"]) == float(b["interpenetration"])
