"""An unreadable truth-cache entry (issue 36): cut short, a header claiming 1e12 entries (a
MemoryError before), bad JSON, arrays that do not fit, anything a read raises. Every reader of
the cache (solvers/truth/store.py: `truth`, `compare truth:CASE`, the leaderboard, `paper`)
treats it as missing: one line naming the file, then computed again, or for a reader that
only reads, reported as not computed with the command to run; under mpiexec every rank
agrees. A killed write's temporary file is removed at the next write.

The entries are small synthetic truths at the quick rod key (store.cache_path("rod", True)),
in a cache of the test's own ($TISSUEBENCH_CACHE); the computation itself is replaced where
only the cache is under test, and run for real (quick) by the command-line tests."""

import io
import os
import subprocess
import sys
import zipfile
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import tissuebench

from tissuebench.solvers.truth import store
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.compare.grading import load_truth

COMM = MPI.COMM_WORLD


def agreed(failures: list) -> list:
    """Every rank's failures, on every rank."""
    return [f for part in COMM.allgather(failures) for f in part]


def synthetic(case: str = "rod", quick: bool = True, steps: int = 3) -> TruthSamples:
    """A small truth of one hexahedron carrying today's inputs of the case (so that the cache
    takes it as that case's)."""
    cube = np.array([[i & 1, (i >> 1) & 1, (i >> 2) & 1] for i in range(8)], dtype=float)
    points = np.full((27, 3), 0.5)
    times = np.arange(steps + 1) / 30
    return TruthSamples(
        case=case,
        cell_type="hexahedron",
        times=times,
        vertices=cube,
        cells=np.array([[0, 1, 3, 2, 4, 5, 7, 6]]),
        boundary=np.array([[0, 2, 3, 1]]),
        points=points,
        weights=np.full(27, 1 / 27),
        u_vertices=np.zeros((steps + 1, 8, 3)),
        u_points=np.zeros((steps + 1, 27, 3)),
        own_error={"interior_error_max": 1e-6, "units": "m^3"},
        inputs=store.inputs(case, quick),
        hierarchy={"levels": [1, 2, 4]},
    )


def npz_member(path: Path, name: str, data: bytes) -> None:
    """Replace one member of an .npz by `data`, the others kept."""
    with zipfile.ZipFile(path) as archive:
        members = {info.filename: archive.read(info) for info in archive.infolist()}
    members[name] = data
    with zipfile.ZipFile(path, "w") as archive:
        for member, content in members.items():
            archive.writestr(member, content)


def huge_header(path: Path) -> None:
    """times.npy's header claims 1e12 float64 entries (8 TB); its data stay as they were."""
    f = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        f, {"descr": "<f8", "fortran_order": False, "shape": (10**12,)}
    )
    npz_member(path, "times.npy", f.getvalue() + np.arange(4.0).tobytes())


def bad_json(path: Path) -> None:
    f = io.BytesIO()
    np.save(f, np.array('{"case": "rod", "cell_type":'))
    npz_member(path, "meta.npy", f.getvalue())


def misfit(path: Path) -> None:
    """u_points one step short: every header true, the arrays not of one truth."""
    f = io.BytesIO()
    np.save(f, np.zeros((3, 27, 3)))
    npz_member(path, "u_points.npy", f.getvalue())


def cut_short(path: Path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])


def garbage(path: Path) -> None:
    path.write_bytes(os.urandom(4096))


CORRUPTIONS = {
    "huge header": (huge_header, "times.npy: its header claims 1,000,000,000,000 entries"),
    "bad JSON": (bad_json, "JSONDecodeError"),
    "arrays that do not fit": (misfit, "u_points has shape (3, 27, 3), not (4, 27, 3)"),
    "cut short": (cut_short, "cannot be read (BadZipFile"),
    "garbage": (garbage, "cannot be read (BadZipFile"),
}


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty truth cache of the test's own; its quick rod entry's path."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))
    return store.cache_path("rod", quick=True)


def corrupt_entry(path: Path, corrupt) -> None:
    """A synthetic quick rod truth written at `path` (rank 0), then corrupted."""
    if COMM.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        synthetic().save(path)
        corrupt(path)
    COMM.barrier()


def lines_of(capsys) -> list[str]:
    captured = capsys.readouterr()
    return (captured.out + captured.err).strip().splitlines()


@pytest.mark.parallel
@pytest.mark.parametrize("kind", list(CORRUPTIONS))
def test_a_reader_says_it_in_one_line_and_counts_it_not_computed(cache, capsys, kind):
    corrupt, why = CORRUPTIONS[kind]
    corrupt_entry(cache, corrupt)
    failures = []
    capsys.readouterr()
    if store.load_cached("rod", quick=True) is not None:
        failures.append("loaded")
    if store.is_cached("rod", quick=True):
        failures.append("is_cached")
    lines = lines_of(capsys)
    if COMM.rank == 0:  # load_cached's line (is_cached says nothing: its reader does)
        if len(lines) != 1:
            failures.append(f"{len(lines)} lines: {lines}")
        elif not (str(cache) in lines[0] and why in lines[0]):
            failures.append(f"the line does not name the file and why: {lines[0]}")
        elif "`tissuebench truth rod --quick` computes it again" not in lines[0]:
            failures.append(f"the line names no command: {lines[0]}")
    assert agreed(failures) == []


@pytest.mark.parallel
def test_a_memory_error_while_reading_is_an_unreadable_entry(cache, capsys, monkeypatch):
    """Whatever the read raises, MemoryError included, is the entry's fault, not a crash."""
    corrupt_entry(cache, lambda path: None)

    def exhausted(path):
        raise MemoryError("Unable to allocate 7.28 TiB for an array with shape (1000000000000,)")

    monkeypatch.setattr(TruthSamples, "load", staticmethod(exhausted))
    capsys.readouterr()
    failures = []
    if store.load_cached("rod", quick=True) is not None:
        failures.append("loaded")
    lines = lines_of(capsys)
    if COMM.rank == 0 and not (len(lines) == 1 and "(MemoryError: Unable to allocate" in lines[0]):
        failures.append(f"not one line with the MemoryError: {lines}")
    assert agreed(failures) == []


@pytest.mark.parallel
@pytest.mark.parametrize("kind", ["huge header", "cut short"])
def test_truth_and_compare_compute_it_again(cache, capsys, monkeypatch, kind):
    """truth_samples (the `truth` command's reader) and compare's load_truth: one line naming
    the file, then computed again and cached readable, on every rank together."""
    corrupt, _ = CORRUPTIONS[kind]
    computed = []

    def compute(case, quick=False, comm=COMM, log=None):
        computed.append(case)
        return synthetic(case, quick) if comm.rank == 0 else None

    monkeypatch.setattr(store, "compute", compute)
    failures = []
    for read in (lambda: store.truth_samples("rod", quick=True, log=print), None):
        corrupt_entry(cache, corrupt)
        capsys.readouterr()
        if read is None:  # compare truth:rod reads the full truth: the same path, its own key
            corrupt_entry(store.cache_path("rod"), corrupt)
            full = store.cache_path("rod")
            samples = load_truth("rod")
        else:
            full = cache
            samples = read()
        lines = lines_of(capsys)
        if COMM.rank == 0:
            said = [line for line in lines if str(full) in line and "cannot be read" in line]
            if len(said) != 1 or not said[0].endswith("computed again"):
                failures.append(f"{kind}: not one line naming {full}: {lines}")
            if samples is None or samples.case != "rod":
                failures.append(f"{kind}: no truth returned")
            if store.load_cached("rod", quick=read is not None) is None:
                failures.append(f"{kind}: not cached again")
        elif samples is not None:
            failures.append("a truth on rank > 0")
    if computed != ["rod", "rod"]:
        failures.append(f"computed {computed}")
    assert agreed(failures) == []


@pytest.mark.parallel
def test_a_killed_writes_temporary_is_removed_at_the_next_write(cache, capsys, monkeypatch):
    """TruthSamples.save writes .NAME.npz.PID.tmp.npz and renames it: a write killed before
    the rename leaves it. The next write removes those of processes no longer running, and
    keeps a write under way (a live process) and files not of that form."""
    folder = cache.parent
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    pid = int(dead.stdout)
    killed = folder / f".{cache.name}.{pid}.tmp.npz"
    running = folder / f".{cache.name}.{os.getppid()}.tmp.npz"
    mine = folder / "notes.tmp.npz"
    if COMM.rank == 0:
        folder.mkdir(parents=True, exist_ok=True)
        for path in (killed, running, mine):
            path.write_bytes(b"x" * 1000)
    COMM.barrier()
    monkeypatch.setattr(
        store,
        "compute",
        lambda case, quick=False, comm=COMM, log=None: (
            synthetic(case, quick) if comm.rank == 0 else None
        ),
    )
    capsys.readouterr()
    store.truth_samples("rod", quick=True, log=print)
    failures = []
    if COMM.rank == 0:
        left = sorted(p.name for p in folder.iterdir())
        if killed.exists() or not (running.exists() and mine.exists()):
            failures.append(f"left: {left}")
        if not cache.is_file():
            failures.append("the truth was not written")
        said = [line for line in lines_of(capsys) if str(killed) in line]
        if len(said) != 1 or "left by a write that was killed" not in said[0]:
            failures.append(f"not said in one line: {said}")
    assert agreed(failures) == []


# --- the command line, serial and under mpiexec -----------------------------------------------


@pytest.mark.serial
@pytest.mark.parametrize("ranks", [1, 2])
def test_the_truth_command_recomputes_a_corrupt_entry(tmp_path, monkeypatch, ranks):
    """`tissuebench truth rod --quick` with a times.npy claiming 1e12 entries in its cache
    entry: before, a MemoryError traceback (MPI_Abort under mpiexec); now one line naming the
    file, the quick truth computed again, exit 0, on one rank or two."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))
    path = store.cache_path("rod", quick=True)
    path.parent.mkdir(parents=True)
    synthetic().save(path)
    huge_header(path)
    done = tissuebench("truth", "rod", "--quick", "--out", tmp_path / "out", ranks=ranks)
    assert done.returncode == 0, done.stderr[-2000:]
    said = [line for line in (done.stdout + done.stderr).splitlines() if "cannot be read" in line]
    assert len(said) == 1 and str(path) in said[0] and "times.npy" in said[0], said
    assert "Traceback" not in done.stderr and "MPI_Abort" not in done.stderr
    again = store.load_cached("rod", quick=True)
    assert again is not None and len(again.vertices) > 8  # the real quick truth, not ours
