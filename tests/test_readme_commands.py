"""The README's "## Commands" block, every line run (issue 35), as tests/test_recipe.py runs the
recipe: parsed out of README.md, so that a line that stops working fails this test.

Each line runs in one fresh folder (`results` starts empty there: the quick runs below never
replace a full study's reports, which the committed results/ hold), in the README's order (a
line may read what an earlier one wrote). A line runs as written except for these
substitutions (`small`), which keep the whole block to a few minutes on one core:

- `tissuebench run ...` (also under `mpiexec -n 2`): `--end-time 0.1` (3 steps; added where the
  line has none) and `--mesh-size` at most 4 (block) or 2 (rod);
- `tissuebench export rod ... --end-time 2`: `--end-time 0.2` (the CalculiX line runs that deck);
- `compare ref.xdmf mine.pvd`: ref.xdmf is the second line's rod run's implicit.xdmf, mine.pvd
  its explicit-lumped series written here as a .pvd of .vtu files;
- `compare truth:rod mine.xdmf`: mine.xdmf is that run's explicit-lumped.xdmf (3 steps: the
  truth's later steps count as missing);
- `--material my_tissue.toml`: a my_tissue.toml written here as the README describes it;
- `sensitivity`, `truth all`, `frontier`: their `--quick`; for frontier also `--cases rod`
  (its four cases took 2 minutes here); `truth all --quick` only where every quick truth is
  cached already, else `truth rod --quick` (the six took 3 minutes here to compute, the rod's
  seconds);
- `stability block ...`: `--mesh-size 4 --no-sweep`; `convergence`: `--end-time 0.1`;
- `paper --out results`: as written, only with TISSUEBENCH_README_PAPER=1 set: it has no quick
  form and runs the whole study (about 3 minutes on a quiet core, 5 or more under load,
  beyond this test's few minutes); without it the line is not run and a warning says so;
- `make bench`: `tissuebench bench --quick` (what it runs), where the bench extra is installed;
  `bench --only explicit-models`: its `--quick`; `bench --only paths` times the user's commands
  whole (a first `paper` among them: about 30 minutes, no quick form) and is not run.

A line whose tool is missing here (ccx for the CalculiX line, the bench extra for `make bench`)
or whose truths are not computed here (`paper`, `frontier` and `compare truth:rod` grade
against the cached truths, which take 1 to 17 minutes to compute) is not run, and the test
says which and why in a warning; the other lines still run and must pass. The mpiexec line
runs under the venv's mpiexec; the test itself is serial.
"""

import os
import shlex
import shutil
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest
from helpers import job

pytestmark = pytest.mark.slow  # a minute or more in all: make test starts it first

ROOT = Path(__file__).resolve().parents[1]
HEADING = "## Commands"
SIZES = {"block": 4, "rod": 2, "cylinder": 3}  # at most, for --mesh-size
END_TIME = "0.1"  # s, each run's end time: 3 steps of the benchmarks' h = 1/30 s
TOML = 'name = "my tissue"\nE = 5000.0\nnu = 0.45\nrho = 1000.0\nalpha = 0.5\nbeta = 0.005\n'


def block_lines() -> list[str]:
    """The lines of the first ```sh block after the README's "## Commands" heading, comments and
    blank lines dropped, continuation lines joined."""
    text = (ROOT / "README.md").read_text()
    assert HEADING in text, f"README.md has no section {HEADING!r}"
    section = text[text.index(HEADING + "\n") :]
    start = section.index("```sh\n") + len("```sh\n")
    block = section[start : section.index("```", start)].replace("\\\n", " ")
    return [line for line in block.splitlines() if shlex.split(line, comments=True)]


def commands(line: str) -> list[list[str]]:
    """A line's commands (split at &&), each as its argv."""
    argv, out = shlex.split(line, comments=True), [[]]
    for word in argv:
        if word == "&&":
            out.append([])
        else:
            out[-1].append(word)
    return [c for c in out if c]


def option(argv: list[str], name: str, value: str | None, add: bool = True) -> list[str]:
    """argv with --name set to value (replaced where given, appended where not and `add`);
    value None: a flag, added once."""
    argv = list(argv)
    if value is None:
        return argv if name in argv else [*argv, name]
    if name in argv:
        argv[argv.index(name) + 1] = value
    elif add:
        argv += [name, value]
    return argv


def not_cached(*cases: str) -> list[str]:
    """The full truths among `cases` that are not computed here."""
    from mpi4py import MPI

    from tissuebench.solvers.truth.store import is_cached

    return [c for c in cases if not is_cached(c, comm=MPI.COMM_SELF)]


def small(argv: list[str], folder: Path) -> tuple[list[str] | None, str | None]:
    """The command as the test runs it (SUBSTITUTIONS in the module docstring), or None and why
    it is not run here."""
    from tissuebench.solvers.truth.cases import CASES

    tool, words = argv[0], argv[1:]
    if tool == "mpiexec":
        inner, why = small(words[2:], folder)
        mpiexec = Path(sys.executable).with_name("mpiexec")
        return (None if inner is None else [str(mpiexec), *words[:2], *inner]), why
    if tool == "make":
        if words != ["bench"]:
            return None, f"make {' '.join(words)}: not a target this test knows"
        try:
            import skfem  # noqa: F401
        except ImportError:
            return None, "make bench: the bench extra (scikit-fem) is not installed here"
        return ["tissuebench", "bench", "--quick"], None
    if tool == "ccx":
        if shutil.which("ccx") is None:
            return None, "ccx (CalculiX) is not installed here (make external-tools installs it)"
        return argv, None
    if tool != "tissuebench":
        return argv, None
    command = words[0]
    if command == "run":
        argv = option(argv, "--end-time", END_TIME)
        if "--mesh-size" in argv:
            size = int(argv[argv.index("--mesh-size") + 1])
            argv = option(argv, "--mesh-size", str(min(size, SIZES[words[1]])))
        return argv, None
    if command == "export" and "--end-time" in argv:
        return option(argv, "--end-time", "0.2"), None
    if command == "compare":
        argv = [
            "runs/rod/implicit.xdmf"
            if w == "ref.xdmf"
            else "runs/rod/explicit-lumped.xdmf"
            if w == "mine.xdmf"
            else w
            for w in argv
        ]
        if "truth:rod" in argv and not_cached("rod"):
            return None, "compare truth:rod: the truth rod is not computed here (about 65 s)"
        if "mine.pvd" in argv:
            write_pvd(folder / "mine.pvd", folder / "runs" / "rod" / "explicit-lumped.xdmf")
        return argv, None
    if words[:2] == ["truth", "all"]:
        from mpi4py import MPI

        from tissuebench.solvers.truth.store import is_cached

        if not all(is_cached(c, quick=True, comm=MPI.COMM_SELF) for c in CASES):
            argv = [*argv[:2], "rod", *argv[3:]]  # the cheapest truth, computed here
        return option(argv, "--quick", None), None
    if command == "frontier":
        if not_cached("rod"):
            return None, "frontier: the truth rod is not computed here (about 65 s)"
        return option(option(argv, "--quick", None), "--cases", "rod"), None
    if command == "sensitivity":
        return option(argv, "--quick", None), None
    if command == "stability":
        return option(option(argv, "--mesh-size", "4"), "--no-sweep", None), None
    if command == "convergence":
        return option(argv, "--end-time", END_TIME), None
    if command == "paper":
        if os.environ.get("TISSUEBENCH_README_PAPER") != "1":
            return None, (
                "paper: the whole study (no quick form; minutes): set TISSUEBENCH_README_PAPER=1 "
                "to run it here"
            )
        missing = not_cached("rod", "block-MP1-w0.2", "block-MP2-w0.2")  # the paper's truths
        if missing:
            return None, f"paper: the truths {', '.join(missing)} are not computed here"
        return argv, None
    if command == "bench" and "paths" in argv:
        return None, (
            "bench --only paths: the user's commands timed whole, a first paper among them (about "
            "30 minutes; no quick form: its committed run is results/performance-paths.md)"
        )
    if command == "bench":
        return option(argv, "--quick", None), None
    return argv, None


def write_pvd(path: Path, series: Path) -> None:
    """A series (xdmf) written again as a ParaView .pvd of .vtu files (test_crossmesh's)."""
    from test_crossmesh import write_pvd as pvd

    from tissuebench.workflows.io.series import read_series

    s = read_series(series)
    pvd(path, (s.points, s.cells, s.cell_type), s)


@pytest.mark.serial
def test_every_line_of_the_readmes_commands_runs(tmp_path):
    lines = block_lines()
    assert len(lines) >= 20, lines
    (tmp_path / "my_tissue.toml").write_text(TOML)
    _, env = job([])
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    skipped, times = [], []
    for line in lines:
        start = time.perf_counter()
        for argv in commands(line):
            run, why = small(argv, tmp_path)
            if run is None:
                skipped.append(f"{line.split('#')[0].strip()}: {why}")
                break
            done = subprocess.run(
                run, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
            )
            assert done.returncode == 0, (
                f"README line `{line.split('#')[0].strip()}` (run as `{shlex.join(run)}`) "
                f"failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
            )
        times.append((time.perf_counter() - start, line.split("#")[0].strip()))
        print(f"{times[-1][0]:6.1f} s  {times[-1][1]}", flush=True)
    print(f"{sum(t for t, _ in times):6.1f} s  in all")
    for line in skipped:  # said in the run's warnings summary; the other lines passed
        warnings.warn(f"README line not run here: {line}", stacklevel=1)
