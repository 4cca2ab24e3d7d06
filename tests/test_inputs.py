"""Issue 23, item 6: input checks.

A run that diverges at step 0 is recorded as diverged (serial and under mpiexec -n 2); load
scales and material values that would overflow float64 are refused in one line with their
range; --petsc is part of external's fingerprint; PETSc options are checked before anything
runs; argument errors are one line. Each test reproduces one case of the issue.
"""

import json
import math
import re

import pytest
from helpers import needs_ccx, tissuebench
from test_cli import curves, statuses

from tissuebench.meshes.benchmark import check_load_scale
from tissuebench.meshes.gmshio import MeshError
from tissuebench.solvers.materials import LARGEST, SMALLEST, Material, MaterialError

# a minute or more in all: make test starts it first; its runs are not graded against a cached
# truth
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("empty_truth_cache")]

ROD = ("rod", "--mesh-size", 2, "--end-time", 0.1)  # 3 steps of 1/30 s
# CG + Jacobi with one iteration cannot solve M a0 = f: the initial state (step 0) fails
MASS_FAILS = "-{}_mass_ksp_max_it 1"


def one_line(result, status=2):
    """The command ended with `status`, one line on stderr, nothing from PETSc on stdout."""
    lines = result.stderr.strip().splitlines()
    assert result.returncode == status, (result.returncode, result.stderr[-2000:])
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr[-2000:]
    assert "PETSC ERROR" not in result.stdout and "WARNING" not in result.stdout, result.stdout
    return lines[0]


def files(path):
    return sorted(str(p.relative_to(path)) for p in path.rglob("*"))


# --- a run that diverges at step 0 --------------------------------------------------------------


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_reference_diverging_at_step_0_is_recorded(tmp_path, ranks):
    """The reference's initial acceleration fails: it is diverged at step 0 (t = 0), every
    metric is NaN from step 0 on, the other run goes on to the end; exit 0."""
    out = tmp_path / "o"
    r = tissuebench(
        "run", *ROD, "--algorithms", "implicit,explicit", "--petsc", MASS_FAILS.format("implicit"),
        "--out", out, ranks=ranks,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    runs = json.loads((out / "summary.json").read_text())["runs"]
    ref, other = runs["implicit"], runs["explicit"]
    assert (ref["status"], ref["diverged_step"], ref["diverged_time"]) == ("diverged", 0, 0.0)
    assert "implicit_mass_" in ref["reason"]
    assert ref["relative_error_max"] is None and ref["interior_error_mean"] is None
    assert other["status"] == "ok" and other["steps"] == 3
    s = statuses(out / "metrics.csv")
    assert s == {"implicit": ["diverged"] * 4, "explicit": ["reference diverged"] * 4}
    c = curves(out / "metrics.csv")
    assert all(math.isnan(x) for x in c["explicit"][:, 2:].ravel())
    assert "deformed.png" not in files(out)  # no reference shape to draw
    assert {"implicit.xdmf", "explicit.xdmf", "tip.csv", "errors.png"} <= set(files(out))


@pytest.mark.serial
def test_other_runs_diverging_at_step_0_with_models(tmp_path):
    """Explicit runs failing at step 0 beside a reference that does not: both models' explicit
    runs are diverged at step 0, the references measure nothing against them, the models'
    figures (the tip's path) are drawn."""
    out = tmp_path / "o"
    r = tissuebench(
        "run", *ROD, "--algorithms", "implicit,explicit", "--models", "linear,neo-hookean",
        "--petsc", MASS_FAILS.format("explicit"), "--out", out,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-3000:]
    runs = json.loads((out / "summary.json").read_text())["runs"]
    assert {k: (v["status"], v["diverged_step"]) for k, v in runs.items()} == {
        "implicit": ("ok", None),
        "explicit": ("diverged", 0),
        "implicit+neo-hookean": ("ok", None),
        "explicit+neo-hookean": ("diverged", 0),
    }
    assert runs["explicit"]["tip_displacement_final"] is None
    s = statuses(out / "metrics.csv")
    assert s["explicit"] == ["diverged"] * 4 and s["implicit"] == ["ok"] * 4
    assert "tip_path.png" in files(out)


# --- values that overflow ----------------------------------------------------------------------


@pytest.mark.serial
def test_a_scheme_parameter_beyond_its_range_is_refused_in_one_line(tmp_path):
    """Issue 45, item 14: before, a SystemError traceback from SLEPc ("EPS.solve returned a
    result with an exception set") once the run had begun. --help states each range."""
    block = ("block", "--mesh-size", 4, "--end-time", 0.1, "--algorithms", "explicit-lumped")
    r = tissuebench(
        "run", *block, "--scheme", "hourglass:c_hg=1e200", "--substeps", "auto",
        "--out", tmp_path / "o",
    )  # fmt: skip
    line = one_line(r)
    assert "c_hg" in line and "0 <= c_hg <= 100" in line and "1e200" in line, line
    assert files(tmp_path) == []
    usage = " ".join(tissuebench("run", "--help").stdout.split())
    assert "0 <= c_hg <= 100" in usage and "-1 < nu_p < 0.5" in usage, usage


@pytest.mark.serial
def test_substeps_without_an_explicit_algorithm_or_beyond_reason_are_refused(tmp_path):
    """Issue 45, item 15: `--substeps auto --algorithms implicit` was taken silently (no run
    takes sub-steps), and `--substeps 1000000000` ran without saying its sub-step or its
    count (3e9 sub-steps on 3 steps: a day or more). Now the first is refused in one line, the
    second too, with its sub-step h/k and its count in all."""
    block = ("block", "--mesh-size", 4, "--end-time", 0.1)
    r = tissuebench(
        "run", *block, "--algorithms", "implicit", "--substeps", "auto", "--out", tmp_path / "a"
    )
    line = one_line(r)
    assert "--substeps auto" in line and "explicit" in line, line
    r = tissuebench(
        "run", *block, "--algorithms", "explicit-lumped", "--substeps", "1000000000",
        "--out", tmp_path / "b",
    )  # fmt: skip
    line = one_line(r)
    assert "h/1000000000 = 3.333e-11 s" in line and "3,000,000,000 sub-steps" in line, line
    assert files(tmp_path) == []


@pytest.mark.serial
def test_a_run_says_its_substeps_before_it_starts(tmp_path):
    """Issue 45, item 15: the sub-step and the count in all, on stdout before any run."""
    r = tissuebench(
        "run", "block", "--mesh-size", 4, "--end-time", 0.1, "--algorithms",
        "explicit,explicit-lumped", "--substeps", 10, "--out", tmp_path / "o",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    first = r.stdout.splitlines()[0]
    assert "10 sub-steps of h/10 = 0.003333 s in each of 3 steps" in first, r.stdout
    assert "30 sub-steps per explicit run, 60 in all (2 runs)" in first, r.stdout


@pytest.mark.serial
@pytest.mark.parametrize("scale", ["1e308"])  # 1e200, 1e-41: test_range_bounds_are_inclusive
def test_overflowing_load_scale_is_refused_with_its_range(tmp_path, scale):
    r = tissuebench("run", *ROD, "--load-scale", scale, "--out", tmp_path / "o")
    line = one_line(r)
    assert "load scale must be within 1e-40 to 1e+40" in line and "float64" in line, line
    assert files(tmp_path) == []


@pytest.mark.serial
@pytest.mark.parametrize(
    "toml, message",
    [
        ("E = 1e308\nnu = 0.3\nrho = 1000\n", "E must be within 1e-40 to 1e+40 Pa"),
    ],
)
def test_overflowing_material_is_refused_with_its_range(tmp_path, toml, message):
    material = tmp_path / "m.toml"
    material.write_text(toml)
    line = one_line(tissuebench("run", *ROD, "--material", material, "--out", tmp_path / "o"))
    assert message in line and "float64" in line, line
    assert files(tmp_path) == ["m.toml"]


def test_range_bounds_are_inclusive():
    """The documented range: its ends are taken, just beyond them refused."""
    for value in (SMALLEST, LARGEST):
        assert Material("x", E=value, nu=0.3, rho=value, alpha=LARGEST, beta=LARGEST).E == value
        check_load_scale(value)
    for value in (SMALLEST / 2, LARGEST * 2, 1e200, 1e308, 1e-41):
        with pytest.raises(MaterialError, match="must be within"):
            Material("x", E=value, nu=0.3, rho=1000.0)
        with pytest.raises(MaterialError, match="must be within"):
            Material("x", E=1000.0, nu=0.3, rho=value)
        with pytest.raises(MeshError, match="must be within"):
            check_load_scale(value)
    with pytest.raises(MaterialError, match="alpha must be at most"):
        Material("x", E=1000.0, nu=0.3, rho=1000.0, alpha=LARGEST * 2)
    with pytest.raises(MaterialError, match="beta must be at most 1e"):
        Material("x", E=1000.0, nu=0.3, rho=1000.0, beta=1e300)


# --- PETSc options --------------------------------------------------------------------------------


@pytest.mark.serial
@pytest.mark.parametrize(
    "solver, petsc, message",
    [
        ("cg", "--petsc=-implicit_ksp_rtol abc", "Input string abc has no numeric value"),
        (
            "direct",
            "--petsc=-implicit_pc_factor_mat_solver_type pastix",
            "Could not locate solver type pastix",
        ),
        ("direct", "--petsc=-log_view :FILE", "-log_view: not under a solver's prefix"),
        ("direct", "--petsc=--", "expected -name [value], got '--'"),
    ],
)
def test_petsc_options_are_checked_before_anything_runs(tmp_path, solver, petsc, message):
    """The issue's cases, end to end: exit 2, one line, no PETSc output, nothing written."""
    r = tissuebench("run", *ROD, "--algorithms", "implicit", "--solver", solver, petsc,
                    "--out", tmp_path / "o")  # fmt: skip
    assert message in one_line(r)
    assert files(tmp_path) == []  # no run folder, no FILE of -log_view


@pytest.mark.parametrize(
    "solver, petsc, message",
    [
        ("direct", "-implicit_ksp_rtol abc", "-implicit_ksp_rtol: read by no solver"),
        ("direct", "-explicit_ksp_rtol 1e-3", "-explicit_ksp_rtol: read by no solver"),
        ("direct", "-help", "-help: not under a solver's prefix"),
        ("direct", "-implict_ksp_type cg", "-implict_ksp_type: not under"),
        ("cg", "-implicit_ksp_max_it 1.5", "no integer value"),
        ("cg", "-quasi_static_pc_type nonsense", "Unable to find requested PC type nonsense"),
        ("direct", "-implicit_snes_type nonsense", "Unable to find requested SNES type nonsense"),
    ],
)
def test_petsc_option_checks(solver, petsc, message):
    """Collective; the options refused are left out of PETSc's database."""
    from petsc4py import PETSc

    from tissuebench.solvers.linear import OptionsError
    from tissuebench.solvers.options import check_petsc_options

    with pytest.raises(OptionsError, match=re.escape(message)):
        check_petsc_options(petsc, solver)
    assert not any(PETSc.Options().hasName(w.lstrip("-")) for w in petsc.split()[:1])


def test_petsc_check_is_silent_and_reads_solve_time_options(capfd):
    """Options read at a solve (a converged reason, a view) pass, and the check's own small
    solve prints nothing: only the run's solves do."""
    from petsc4py import PETSc

    from tissuebench.solvers.options import check_petsc_options

    options = "-implicit_ksp_converged_reason -implicit_mass_ksp_view"
    try:
        check_petsc_options(options, "direct")
    finally:
        for word in options.split():
            PETSc.Options().delValue(word[1:])
    assert capfd.readouterr().out == ""


@pytest.mark.serial
def test_petsc_options_refused_in_one_line_under_mpiexec(tmp_path):
    petsc = "--petsc=-implicit_pc_factor_mat_solver_type pastix"
    r = tissuebench("run", *ROD, "--algorithms", "implicit", petsc, "--out", tmp_path / "o",
                    ranks=2)  # fmt: skip
    assert "Could not locate solver type pastix" in one_line(r)
    assert files(tmp_path) == []


@pytest.mark.serial
def test_petsc_options_that_a_run_reads_are_taken(tmp_path):
    """Options of the step solve, the mass solve and the Newton solver pass the check."""
    out = tmp_path / "o"
    petsc = (
        "-implicit_ksp_type cg -implicit_pc_type jacobi -implicit_ksp_rtol 1e-10 "
        "-implicit_mass_ksp_rtol 1e-13 -implicit_snes_rtol 1e-9"
    )
    r = tissuebench("run", *ROD, "--algorithms", "implicit", "--models", "linear,svk",
                    "--petsc", petsc, "--out", out)  # fmt: skip
    assert r.returncode == 0 and "WARNING" not in r.stdout, r.stderr[-2000:] + r.stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary["inputs"]["petsc"] == petsc
    assert {v["status"] for v in summary["runs"].values()} == {"ok"}


# --- every input that changes a result is in the fingerprint -------------------------------------


@pytest.mark.serial
@needs_ccx
def test_external_fingerprint_holds_petsc(tmp_path):
    """A loose reference tolerance, then none: the folder holds results of other inputs; it
    is refused (not skipped as the same), and --force reruns with the fresh reference."""
    out = tmp_path / "ext"
    common = ("external", "calculix", *ROD, "--variants", "implicit-C3D8", "--solver", "cg")
    loose = tissuebench(*common, "--petsc=-implicit_ksp_rtol 1e-1", "--out", out)
    assert loose.returncode == 0, loose.stderr[-2000:]
    before = json.loads((out / "summary.json").read_text())
    assert before["inputs"]["petsc"] == "-implicit_ksp_rtol 1e-1"
    again = tissuebench(*common, "--out", out)
    line = one_line(again)
    assert "holds results of other inputs" in line and "petsc" in line, line
    assert "skipped" not in again.stdout
    fresh = tissuebench(*common, "--out", out, "--force")
    assert fresh.returncode == 0, fresh.stderr[-2000:]
    after = json.loads((out / "summary.json").read_text())
    assert "petsc" not in after["inputs"]
    assert after["fingerprint"] != before["fingerprint"]
    label = "calculix:implicit-C3D8"
    loose_e, fresh_e = (s["runs"][label]["relative_error_max"] for s in (before, after))
    assert fresh_e != loose_e  # the reference changed with the tolerance


# --- argument errors ---------------------------------------------------------------------------


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_argument_error_is_one_line(ranks):
    """The issue's case, 13 lines before: one line, from rank 0 only under mpiexec."""
    first = one_line(tissuebench("export", "block", "--format", "xdmf", "--out", "d", ranks=ranks))
    assert first.startswith("tissuebench export: error: argument --format: invalid choice: 'xdmf'")
    assert first.endswith("(usage: tissuebench export -h)"), first


@pytest.mark.parallel
@pytest.mark.parametrize(
    "args, line",
    [
        (("run", "rod"), "tissuebench run: error: the following arguments are required: --out"),
        (
            ("run", "rod", "--mesh-size", "x", "--out", "d"),
            "tissuebench run: error: argument --mesh-size: invalid int value: 'x'",
        ),
        ((), "tissuebench: error: the following arguments are required: COMMAND"),
        (("frobnicate",), "tissuebench: error: argument COMMAND: invalid choice: 'frobnicate'"),
    ],
)
def test_argument_errors_are_one_line(capsys, args, line):
    from mpi4py import MPI

    from tissuebench.workflows.cli import parser

    with pytest.raises(SystemExit) as exit:
        parser().parse_args(list(args))
    assert exit.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    if MPI.COMM_WORLD.rank == 0:
        assert len(err) == 1 and err[0].startswith(line) and err[0].endswith("-h)"), err
    else:
        assert err == []  # only rank 0 prints


@pytest.mark.serial
def test_usage_is_on_help():
    r = tissuebench("export", "-h")
    assert r.returncode == 0 and r.stdout.startswith("usage: tissuebench export")
