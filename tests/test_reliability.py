"""Issue 12: tissuebench never loses a user's files, and every failure ends in one line.

Each test is one reproduction of the issue: foreign output folders, a diverging reference,
concurrent and stale runs, size limits, a full disk, signals, options that do not apply,
MUMPS failures and the XDMF number precision; serial and, where MPI matters, under
`mpiexec -n 2`.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from helpers import job, tissuebench
from test_cli import curves, statuses

SMALL = ("--mesh-size", 4, "--end-time", 0.1)
DIVERGING_REFERENCE = "-implicit_ksp_type cg -implicit_pc_type none -implicit_ksp_max_it 1"

pytestmark = [pytest.mark.serial, pytest.mark.slow]  # drives the command line in subprocesses


def one_line_error(result, status=2):
    """The command failed with `status` and exactly one line on stderr, no traceback."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == status, (result.returncode, result.stderr[-2000:])
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr[-2000:]
    return lines[0]


def tree(path):
    """Every file below path with its bytes, to show that nothing was touched."""
    return {
        str(p.relative_to(path)): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()
    }


# --- 1. a folder that is not ours is never touched ------------------------------------------


def test_foreign_folder_is_refused_and_kept(tmp_path):
    d = tmp_path / "d"
    d.mkdir()
    (d / "thesis.txt").write_text("x")
    for extra in ((), ("--force",)):
        r = tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", d, *extra)
        assert "did not write (thesis.txt)" in one_line_error(r)
    assert tree(tmp_path) == {"d/thesis.txt": b"x"}


@pytest.mark.parametrize("out", [".", "", ".."])
def test_current_folder_and_its_parents_are_refused(tmp_path, out):
    work = tmp_path / "work"
    work.mkdir()
    (work / "notes.txt").write_text("keep")
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "tissuebench.workflows.cli",
            "run",
            "block",
            *map(str, SMALL),
            "--algorithms",
            "implicit",
            "--out",
            out,
        ],
        cwd=work,
        capture_output=True,
        text=True,
    )
    assert "holds the current folder" in one_line_error(r)
    assert tree(tmp_path) == {"work/notes.txt": b"keep"}


def test_unwritable_and_dangling_outputs_are_refused_before_work(tmp_path):
    (tmp_path / "link").symlink_to(tmp_path / "nowhere" / "x")
    r = tissuebench("run", "block", *SMALL, "--out", tmp_path / "link")
    assert "symbolic link to nothing" in one_line_error(r)
    r = tissuebench("run", "block", *SMALL, "--out", "/proc/tissuebench-x")
    assert "cannot write in /proc" in one_line_error(r)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link"]


# --- 2. a diverging reference is a divergence like any other --------------------------------


@pytest.mark.parametrize("ranks", [1, 2])
def test_diverging_reference_is_recorded(tmp_path, ranks):
    out = tmp_path / "o" / "x"
    r = tissuebench(
        "run",
        "block",
        *SMALL,
        "--algorithms",
        "implicit,quasi-static",
        "--petsc",
        DIVERGING_REFERENCE,
        "--out",
        out,
        ranks=ranks,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    summary = json.loads((out / "summary.json").read_text())
    ref = summary["runs"]["implicit"]
    assert (
        ref["status"] == "diverged"
        and ref["diverged_step"] == 1
        and "did not converge" in ref["reason"]
    )
    assert summary["runs"]["quasi-static"]["status"] == "ok"
    c, s = curves(out / "metrics.csv"), statuses(out / "metrics.csv")
    assert np.all(np.isnan(c["quasi-static"][1:, 2:]))  # nothing to measure against from step 1 on
    assert s["quasi-static"] == [
        "ok",
        "reference diverged",
        "reference diverged",
        "reference diverged",
    ]
    assert s["implicit"] == ["ok", "diverged", "diverged", "diverged"]
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == ["x"]  # no partial folder, no lock


def test_stiff_material_diverges_explicit_schemes_only(tmp_path):
    stiff = tmp_path / "stiff.toml"
    stiff.write_text("E = 1e30\nnu = 0.3\nrho = 1000\n")
    out = tmp_path / "y"
    r = tissuebench("run", "block", *SMALL, "--material", stiff, "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    runs = json.loads((out / "summary.json").read_text())["runs"]
    assert {k: v["status"] for k, v in runs.items()} == {
        "implicit": "ok",
        "implicit-lumped": "ok",
        "explicit": "diverged",
        "explicit-lumped": "diverged",
        "quasi-static": "ok",
    }


# --- 3. one writer per folder ----------------------------------------------------------------


def test_second_writer_is_refused_and_stale_lock_taken_over(tmp_path):
    out = tmp_path / "run"
    lock = tmp_path / ".tissuebench-lock-run"
    mine = {"tissuebench": "lock", "host": os.uname().nodename}
    lock.write_text(json.dumps({**mine, "pid": os.getpid(), "since": "now"}))
    r = tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", out)
    assert "another tissuebench run is writing it" in one_line_error(r)
    assert not out.exists() and lock.exists()
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True
    )
    lock.write_text(json.dumps({**mine, "pid": int(dead.stdout), "since": "then"}))
    r = tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", out)
    assert r.returncode == 0, r.stderr[-2000:]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def start(args, ranks=1):
    cmd, env = job(["-m", "tissuebench.workflows.cli", *args], ranks)
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)


def wait_for(path, process, seconds=120):
    end = time.monotonic() + seconds
    while not path.exists():
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < end, f"{path} did not appear"
        time.sleep(0.05)


LONG_RUN = ("run", "block", "--mesh-size", 16, "--end-time", 300, "--algorithms", "implicit")


@pytest.mark.parametrize(
    "ranks, sig, status",
    [
        (1, signal.SIGINT, 130),
        (1, signal.SIGTERM, 143),
        (2, signal.SIGINT, 130),
        (2, signal.SIGTERM, 143),
    ],
)
def test_concurrent_run_refused_then_signal_cleans_up(tmp_path, ranks, sig, status):
    """While a run writes, a second one into the same folder is refused; a signal then ends
    the first with one line and its status, the partial folder and the lock removed."""
    (tmp_path / "keep.txt").write_text("mine")
    out = tmp_path / "run"
    first = start([*LONG_RUN, "--out", out], ranks)
    try:
        wait_for(tmp_path / ".tissuebench-partial-run", first)
        second = tissuebench(*LONG_RUN, "--out", out)
        assert "another tissuebench run is writing it" in one_line_error(second)
        first.send_signal(sig)
        _, stderr = first.communicate(timeout=120)
    finally:
        first.kill()
    assert first.returncode == status, stderr[-2000:]
    # under mpiexec every rank stops at the same step and the job ends normally: no MPI_Abort,
    # which could kill the processes before their last line reached mpiexec
    lines = [line for line in stderr.replace("\r", "\n").splitlines() if line.strip()]
    lines = [line for line in lines if "%|" not in line]
    assert (
        len(lines) == 1 and ("interrupted" if sig == signal.SIGINT else "terminated") in lines[0]
    ), stderr[-2000:]
    assert tree(tmp_path) == {"keep.txt": b"mine"}


# --- 4. results are complete only for the same inputs ---------------------------------------


def test_changed_material_is_not_skipped(tmp_path):
    soft = tmp_path / "soft.toml"
    soft.write_text('name = "soft"\nE = 300\nnu = 0.3\nrho = 1000\n')
    out = tmp_path / "z"
    args = ("run", "block", *SMALL, "--algorithms", "implicit", "--material", soft, "--out", out)
    assert tissuebench(*args).returncode == 0
    assert "skipped" in tissuebench(*args).stdout
    soft.write_text('name = "soft"\nE = 400\nnu = 0.3\nrho = 1000\n')  # same name, other values
    line = one_line_error(tissuebench(*args))
    assert "other inputs" in line and "E: 300.0 -> 400.0" in line and "--force" in line
    r = tissuebench(*args, "--force")
    assert r.returncode == 0 and "skipped" not in r.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["inputs"]["runs"][0]["material"]["E"] == 400.0


def test_paper_refuses_a_case_folder_of_other_inputs(tmp_path):
    run = tmp_path / "one"
    assert (
        tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", run).returncode
        == 0
    )
    results = tmp_path / "results"
    results.mkdir()
    os.rename(run, results / "block-MP1")
    before = tree(results)
    line = one_line_error(tissuebench("paper", "--out", results))
    assert "block-MP1: holds results of other inputs" in line and "mesh_size: 4 -> 20" in line
    assert tree(results) == before


def test_paper_keeps_a_readme_it_did_not_write(tmp_path):
    (tmp_path / "README.md").write_text("# my notes\n")
    line = one_line_error(tissuebench("paper", "--out", tmp_path))
    assert "README.md: exists and was not written by tissuebench" in line
    assert tree(tmp_path) == {"README.md": b"# my notes\n"}


# --- 5, 6. sizes, and a full disk ------------------------------------------------------------


@pytest.mark.parametrize(
    "args, message",
    [
        (("run", "block", "--mesh-size", 100000), "of memory"),
        (("run", "block", "--end-time", "1e12"), "steps, more than"),
        (("run", "block", "--dt", "1e-300", "--end-time", "1e300"), "inf steps"),
        (("mesh", "rod", "--mesh-size", 100000), "of memory"),
    ],
)
def test_cases_that_cannot_fit_are_refused_at_once(tmp_path, args, message):
    out = tmp_path / ("m.msh" if args[0] == "mesh" else "out")
    started = time.monotonic()
    r = tissuebench(*args, "--out", out)
    assert message in one_line_error(r)
    assert time.monotonic() - started < 60 and not any(tmp_path.iterdir())


def test_estimate_grows_with_the_case():
    from tissuebench.workflows.io.limits import estimate

    small, fine, long = (
        estimate(2, 21**2, 300, 5),
        estimate(2, 41**2, 300, 5),
        estimate(2, 21**2, 600, 5),
    )
    assert small.memory < fine.memory and small.disk < fine.disk and small.disk < long.disk
    # the series on disk: u and v, 3 components of float64 per node and step
    assert long.disk - small.disk == pytest.approx(
        5 * 300 * (2 * 21**2 * 3 * 8 + 2 * 700 + 2 * 150)
    )


@pytest.fixture
def tiny_disk(tmp_path):
    """A 2 MB tmpfs (root only; skipped where mounting is not allowed)."""
    mount = tmp_path / "tiny"
    mount.mkdir()
    r = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(mount)], capture_output=True
    )
    if r.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {r.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "--lazy", str(mount)], check=True)


def test_full_disk_is_refused_up_front(tiny_disk):
    r = tissuebench("run", "block", "--end-time", 2, "--out", tiny_disk / "run")
    assert "GB free" in one_line_error(r)
    assert not any(tiny_disk.iterdir())


def test_disk_filling_up_while_writing_ends_in_one_line(tiny_disk, monkeypatch, capsys):
    """With the estimate made blind to the figures, the disk fills while writing: exit 1,
    one line, the partial folder removed."""
    from tissuebench.workflows import cli
    from tissuebench.workflows.io import limits

    monkeypatch.setattr(limits, "FIGURES", 0.0)
    (tiny_disk / "filler").write_bytes(b"\0" * 1_600_000)
    status = cli.main(
        [
            "run",
            "block",
            "--mesh-size",
            "8",
            "--end-time",
            "1",
            "--algorithms",
            "implicit",
            "--out",
            str(tiny_disk / "run"),
        ]
    )
    err = [
        line
        for line in capsys.readouterr().err.replace("\r", "\n").splitlines()
        if line.strip() and "%|" not in line
    ]
    assert status == 1 and len(err) == 1 and "no space left on the device" in err[0], err
    assert sorted(p.name for p in tiny_disk.iterdir()) == ["filler"]


# --- 7, 8. one line instead of a traceback; options that do not apply -----------------------


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ("run", "block", *SMALL, "--petsc", "-implicit_ksp_type nonsense"),
            "Unable to find requested KSP type nonsense",
        ),
        (("run", "block", *SMALL, "--petsc", "implicit_ksp_type cg"), "expected -name [value]"),
        (("convergence", "--end-time", "nan"), "positive multiple"),
        (("run", "rod", "--plane", "stress"), "--plane applies to 2D benchmarks only"),
        (("run", "rod", "--needle-width", "0.1"), "--needle-width does not apply to rod"),
    ],
)
def test_refused_in_one_line(tmp_path, args, message):
    r = tissuebench(*args, "--out", tmp_path / "out")
    assert message in one_line_error(r)
    assert not (tmp_path / "out").exists()


def test_mesh_never_replaces_a_folder_or_a_file_not_ours(tmp_path):
    (tmp_path / "m.msh").mkdir()
    assert "is a folder" in one_line_error(
        tissuebench("mesh", "block", "--out", tmp_path / "m.msh")
    )
    (tmp_path / "b.msh").write_text("mine")
    for force in ((), ("--force",)):
        r = tissuebench("mesh", "block", "--mesh-size", 4, "--out", tmp_path / "b.msh", *force)
        assert "was not written by tissuebench" in one_line_error(r)
    assert (tmp_path / "b.msh").read_text() == "mine"
    ours = tmp_path / "c.msh"
    assert tissuebench("mesh", "block", "--mesh-size", 4, "--out", ours).returncode == 0
    assert "--force replaces it" in one_line_error(
        tissuebench("mesh", "block", "--mesh-size", 2, "--out", ours)
    )
    r = tissuebench("mesh", "block", "--mesh-size", 2, "--out", ours, "--force")
    assert r.returncode == 0 and ours.read_text().startswith("$MeshFormat")
    ours.write_text(ours.read_text() + "% my note\n")  # changed since we wrote it: kept
    r = tissuebench("mesh", "block", "--mesh-size", 4, "--out", ours, "--force")
    assert "was changed since tissuebench wrote it" in one_line_error(r)
    assert ours.read_text().endswith("% my note\n")


@pytest.mark.parametrize(
    "text, message",
    [
        ("E = 1" + "0" * 400 + "\nnu = 0.3\nrho = 1000\n", "E must be a finite number"),
        ("E = " + "[" * 5000 + "]" * 5000 + "\nnu = 0.3\nrho = 1000\n", "nested too deeply"),
        (
            'name = "' + "x" * 100_000 + '"\nE = 1\nnu = 0.3\nrho = 1000\n',
            "bytes; a material takes at most",
        ),
        (
            'name = "' + "x" * 100 + '"\nE = 1\nnu = 0.3\nrho = 1000\n',
            "name must be printable text of 1 to 64",
        ),
        ('name = "a\\u0007b"\nE = 1\nnu = 0.3\nrho = 1000\n', "name must be printable text"),
    ],
)
def test_hostile_material_files(tmp_path, text, message):
    path = tmp_path / "m.toml"
    path.write_text(text)
    r = tissuebench("run", "block", "--material", path, "--out", tmp_path / "out")
    assert message in one_line_error(r)


def test_end_time_that_h_does_not_divide_is_said(tmp_path):
    r = tissuebench(
        "run",
        "block",
        "--mesh-size",
        4,
        "--dt",
        0.03,
        "--end-time",
        0.1,
        "--algorithms",
        "implicit",
        "--out",
        tmp_path / "r",
    )
    assert r.returncode == 0 and "running 3 steps to t = 0.09 s" in r.stdout
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["end_time"] == pytest.approx(
        0.09
    )


# --- 10, 11. ParaView precision; MUMPS failures ----------------------------------------------


def test_xdmf_states_float64_on_every_dataitem(tmp_path):
    out = tmp_path / "r"
    assert (
        tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", out).returncode
        == 0
    )
    items = list(ET.parse(out / "implicit.xdmf").getroot().iter("DataItem"))
    assert len(items) == 2 + 2 * 4  # geometry, topology; displacement and velocity at 4 steps
    assert all(item.get("Precision") == "8" for item in items)
    assert {item.get("NumberType") for item in items} == {"Float", "Int"}


def test_mumps_failure_is_a_divergence_with_its_reason():
    """A singular matrix: MUMPS sets INFOG(1) < 0 without a PETSc error; the solve says so."""
    from petsc4py import PETSc

    from tissuebench.solvers.linear import KSPSolve, SolveError

    A = PETSc.Mat().createAIJ([4, 4], comm=PETSc.COMM_SELF)
    A.setUp()
    for i in range(4):
        A[i, i] = 1.0 if i < 3 else 0.0
    A.assemble()
    solve = KSPSolve(A, "singular_", "direct")
    b = A.createVecLeft()
    b.set(1.0)
    with pytest.raises(
        SolveError, match=r"MUMPS factorisation failed for singular_: INFOG\(1\) = -10"
    ):
        solve(b, b.duplicate())


# --- issue 23, item 1: one output-folder rule for every command that writes -------------------


def small_run(out, *extra):
    r = tissuebench(
        "run", "block", *SMALL, "--algorithms", "implicit,explicit", "--out", out, *extra
    )
    assert r.returncode == 0, r.stderr[-2000:]
    return out


@pytest.fixture(scope="module")
def graded(tmp_path_factory):
    """A small run folder of ours, and its two series to compare."""
    run = small_run(tmp_path_factory.mktemp("graded") / "run")
    return run, run / "implicit.xdmf", run / "explicit.xdmf"


def copy_of_ours(graded, out: Path) -> Path:
    """small_run's folder as a byte-for-byte copy of graded's (a folder of ours is known by what
    it holds, its manifest and files, not by where it was written): a run's seconds saved."""
    shutil.copytree(graded[0], out, symlinks=True)
    return out


@pytest.mark.parametrize("ranks", [1, 2])
def test_compare_never_replaces_a_users_files(tmp_path, graded, ranks):
    _, ref, cand = graded
    user = tmp_path / "user"
    user.mkdir()
    (user / "metrics.csv").write_text("my,data\n")
    (user / "summary.json").write_text('{"mine": 1}')
    before = tree(tmp_path)
    r = tissuebench("compare", ref, cand, "--out", user, ranks=ranks)
    assert "did not write (metrics.csv and 1 more)" in one_line_error(r)
    assert tree(tmp_path) == before


@pytest.mark.parametrize("out", [".", ".."])
def test_compare_refuses_the_current_folder_and_its_parents(tmp_path, graded, out):
    _, ref, cand = graded
    work = tmp_path / "work"
    work.mkdir()
    (work / "metrics.csv").write_text("mine")
    (tmp_path / "metrics.png").write_text("mine")
    before = tree(tmp_path)
    cmd, env = job(["-m", "tissuebench.workflows.cli", "compare", ref, cand, "--out", out])
    r = subprocess.run(cmd, cwd=work, capture_output=True, text=True, env=env)
    assert "holds the current folder" in one_line_error(r)
    assert tree(tmp_path) == before


def test_compare_into_a_run_folder_refuses_and_keeps_it_whole(tmp_path, graded):
    run, ref, cand = graded
    before = tree(run)
    r = tissuebench("compare", ref, cand, "--out", run)
    assert "holds the results of tissuebench run, which compare never replaces" in (
        one_line_error(r)
    )
    assert tree(run) == before
    r = tissuebench("compare", ref, cand, "--out", run, "--force")  # not even on request
    assert "--force or not" in one_line_error(r)
    assert tree(run) == before
    again = tissuebench("run", "block", *SMALL, "--algorithms", "implicit,explicit", "--out", run)
    assert again.returncode == 0 and "skipped" in again.stdout, again.stderr[-2000:]


def test_compare_twice_skips_then_regrades_on_force_or_new_input(tmp_path, graded):
    _, ref, cand = graded
    out = tmp_path / "graded"
    assert tissuebench("compare", ref, cand, "--out", out).returncode == 0
    first = (out / "summary.json").read_bytes()
    r = tissuebench("compare", ref, cand, "--out", out)
    assert r.returncode == 0 and "complete results for the same inputs exist" in r.stdout
    r = tissuebench("compare", ref, cand, "--out", out, "--label", "other")
    assert "holds results of other inputs" in one_line_error(r)
    assert (out / "summary.json").read_bytes() == first
    r = tissuebench("compare", ref, cand, "--out", out, "--label", "other", "--force")
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads((out / "summary.json").read_text())["candidate"]["label"] == "other"


@pytest.mark.parametrize("name", [".partial-out", ".old-out", ".lock-out"])
def test_a_users_folder_beside_the_output_is_never_touched(tmp_path, graded, name):
    mine = tmp_path / name
    mine.mkdir()
    (mine / "thesis.tex").write_text("years of work")
    copy_of_ours(graded, tmp_path / "out")
    small_run(tmp_path / "out", "--force")
    assert (mine / "thesis.tex").read_text() == "years of work"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([name, "out"])


@pytest.mark.parametrize("name", ["partial", "old"])
def test_our_temporary_names_without_our_marker_are_refused(tmp_path, graded, name):
    """A folder under one of our temporary names but without our marker is a user's: refused
    in one line, never removed."""
    out = copy_of_ours(graded, tmp_path / "out")
    mine = tmp_path / f".tissuebench-{name}-out"
    mine.mkdir()
    (mine / "data.txt").write_text("mine")
    r = tissuebench("run", "block", *SMALL, "--algorithms", "implicit", "--out", out, "--force")
    assert "not a temporary folder of tissuebench" in one_line_error(r)
    assert (mine / "data.txt").read_text() == "mine"


@pytest.mark.parametrize("ranks", [1, 2])
@pytest.mark.parametrize("change", ["added", "changed"])
def test_a_run_folder_changed_by_someone_is_refused_force_or_not(tmp_path, graded, ranks, change):
    out = copy_of_ours(graded, tmp_path / "out")
    if change == "added":
        (out / "my-notes.txt").write_text("mine")
    else:
        (out / "metrics.csv").write_text((out / "metrics.csv").read_text() + "# checked\n")
    before = tree(tmp_path)
    for extra in ((), ("--force",), ("--end-time", 0.2, "--force")):
        args = ("run", "block", "--mesh-size", 4, "--algorithms", "implicit,explicit")
        r = tissuebench(*args, "--end-time", 0.1, *extra, "--out", out, ranks=ranks)
        line = one_line_error(r)
        assert ("my-notes.txt added" if change == "added" else "metrics.csv changed") in line
    assert tree(tmp_path) == before


def test_loose_reports_are_replaced_only_if_ours_and_unchanged(tmp_path):
    """stability writes stability.json/.md into a shared folder: a user's file of that name is
    refused, force or not; ours is replaced; ours edited by the user is refused."""
    out = tmp_path / "results"
    out.mkdir()
    (out / "stability.md").write_text("my notes")
    args = ("stability", "block", "--mesh-size", 4, "--no-sweep", "--max-steps", 5, "--out", out)
    assert "stability.md: exists and was not written by tissuebench" in one_line_error(
        tissuebench(*args)
    )
    assert (out / "stability.md").read_text() == "my notes"
    (out / "stability.md").unlink()
    assert tissuebench(*args).returncode == 0
    assert tissuebench(*args).returncode == 0  # ours, unchanged: replaced
    manifest = json.loads((out / ".tissuebench.json").read_text())
    assert {"stability.md", "stability.json"} <= set(manifest["files"])
    (out / "stability.md").write_text((out / "stability.md").read_text() + "my remark\n")
    assert "stability.md: was changed since tissuebench wrote it" in one_line_error(
        tissuebench(*args)
    )
    assert (out / "stability.md").read_text().endswith("my remark\n")


def test_export_refuses_a_users_file_force_or_not(tmp_path):
    (tmp_path / "rod.reference.xdmf").write_text("mine")
    for force in ((), ("--force",)):
        r = tissuebench(
            "export",
            "rod",
            "--mesh-size",
            1,
            "--end-time",
            0.1,
            "--out",
            tmp_path / "rod.json",
            *force,
        )
        assert "rod.reference.xdmf: exists and was not written by tissuebench" in one_line_error(r)
    assert tree(tmp_path) == {"rod.reference.xdmf": b"mine"}


def test_committed_results_are_ours_and_unchanged():
    """Every folder of results/ that tissuebench wrote whole carries its manifest, and every
    committed loose output is listed in its folder's manifest with its present hash: `make
    paper`, `leaderboard` and the other commands may replace them, and nothing else."""
    from tissuebench.workflows.io.manifest import changes, file_hash, read_manifest

    root = Path(__file__).parents[1]
    results = root / "results"
    tracked = subprocess.run(
        ["git", "ls-files", "results"], cwd=root, capture_output=True, text=True, check=True
    ).stdout.split()
    sealed = [(root / p).parent for p in tracked if p.endswith("/summary.json")]
    assert len(sealed) >= 10
    for folder in sealed:
        added, modified, _ = changes(folder)
        assert not added and not modified, (folder, added, modified)
    for folder in (results, results / "leaderboard"):
        listed = read_manifest(folder, "files")
        for path in folder.iterdir():
            if path.is_file() and not path.name.startswith("."):
                assert listed.get(path.name) == file_hash(path), path
