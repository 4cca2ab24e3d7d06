"""`tissuebench sensitivity --quick`: every algorithm on three grid sizes and three mesh shapes,
graded on its own mesh against implicit on the grid twice as fine. Checked: implicit
converges to that reference on every shape, serial and two ranks give the same numbers, a
rerun reads the graded meshes back, and a quick run never replaces a full report."""

import csv

import pytest
from helpers import tissuebench

from tissuebench.solvers import ALGORITHMS
from tissuebench.workflows.leaderboard.mesh_sensitivity import MARKER, QUICK

pytestmark = [pytest.mark.serial, pytest.mark.slow]  # subprocesses, serial and under mpiexec


def rows(folder):
    with open(folder / "mesh-sensitivity.csv", newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    r = tissuebench("sensitivity", "--quick", "--out", out)
    assert r.returncode == 0, r.stderr[-3000:]
    return out, r


def test_every_run_is_graded_and_reported(serial):
    out, _ = serial
    table = rows(out)
    assert len(table) == len(QUICK) * 3 * 3 * len(ALGORITHMS)
    text = (out / "mesh-sensitivity.md").read_text()
    assert text.startswith(f"{MARKER} (quick check")
    for study in QUICK:
        assert (out / f"mesh-sensitivity-{study.name}.png").stat().st_size > 10_000
        assert f"## {study.name}" in text
    assert {r["cell"] for r in table} == {"quadrilateral", "triangle", "hexahedron", "tetrahedron"}


def test_implicit_converges_to_the_finer_grid_on_every_shape(serial):
    """E_i of implicit against implicit on the grid of size 2N falls with every refinement,
    whatever the cells: the discretisation error is all that is left."""
    table = rows(serial[0])
    for study in QUICK:
        for shape in {r["shape"] for r in table if r["case"] == study.name}:
            mine = sorted(
                (
                    r
                    for r in table
                    if r["case"] == study.name
                    and r["shape"] == shape
                    and r["algorithm"] == "implicit"
                ),
                key=lambda r: int(r["size"]),
            )
            errors = [float(r["interior_error_max"]) for r in mine]
            assert [int(r["size"]) for r in mine] == list(study.sizes)
            assert errors[0] > errors[1] > errors[2] > 0, (study.name, shape, errors)


def test_serial_and_two_ranks_agree(serial, tmp_path):
    r = tissuebench("sensitivity", "--quick", "--out", tmp_path, ranks=2)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.count("wrote") == 1  # only rank 0 prints
    a, b = rows(serial[0]), rows(tmp_path)
    key = ("case", "algorithm", "shape", "size")
    b = {tuple(r[k] for k in key): r for r in b}
    for row in a:
        other = b[tuple(row[k] for k in key)]
        assert row["status"] == other["status"] and row["nodes"] == other["nodes"]
        for name in ("relative_error_max", "interior_error_max", "interior_error_mean"):
            assert float(other[name]) == pytest.approx(float(row[name]), rel=1e-8, abs=1e-14)


def test_a_rerun_reads_the_graded_meshes_back(serial):
    out, first = serial
    before = {p: p.stat().st_mtime_ns for p in (out / "mesh-sensitivity-quick").rglob("rows-*")}
    r = tissuebench("sensitivity", "--quick", "--out", out)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "DIVERGED" not in r.stdout and " ok: " not in r.stdout  # nothing was run again
    assert {p: p.stat().st_mtime_ns for p in before} == before


def test_a_quick_run_never_replaces_a_full_report(tmp_path):
    from tissuebench.workflows.io.output import write_owned

    md = tmp_path / "mesh-sensitivity.md"  # a full study's report, written by us
    write_owned(md, lambda tmp: tmp.write_text(f"{MARKER}\n\nthe full study\n"))
    r = tissuebench("sensitivity", "--quick", "--out", tmp_path)
    assert r.returncode == 2 and "holds a full study" in r.stderr
    assert md.read_text() == f"{MARKER}\n\nthe full study\n"
