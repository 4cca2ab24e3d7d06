"""Output folders and files that tissuebench owns, and only those.

Rules (README, "Output folders"):
- Every folder tissuebench writes whole (a run, a case, a compare, an external simulator)
  holds a manifest, `.tissuebench.json`: every file below it with its SHA-256. The folder is
  ours while the manifest is there and nothing was added to it or changed in it since; a file
  of ours that is gone only makes the folder incomplete (nothing of anyone's is lost by
  rewriting it). The manifest is a guard against accidents, not a signature: anyone can
  compute it again (seal), so it proves nothing about a folder's numbers. Its summary.json
  carries a `fingerprint`: the hash of every input that changes its numbers (`inputs`, kept
  beside it).
- `--out` may name a new folder, an empty one, or one of ours, unchanged. A folder that holds
  anything else is refused in one line, `--force` or not; so are the current folder and its
  parents. Ours and complete with the same fingerprint: skipped. Ours with another
  fingerprint: refused with what differs, unless `--force`.
- Loose files in a shared folder (results/README.md, leaderboard.md, stability.md, an export's
  files, ...) are listed in that folder's manifest when written; an existing file is replaced
  only if the manifest lists it with its present hash.
- One writer per folder: a lock file `.tissuebench-lock-NAME` beside it, created atomically,
  removed on every exit path (a lock left by a process that no longer runs on this host is
  taken over).
- Everything is written into `.tissuebench-partial-NAME` beside the target and renamed into
  place only when complete; the replaced folder passes through `.tissuebench-old-NAME`.
  Both carry a marker file (`.tissuebench-temporary`, naming the target) while they are
  temporary. Only a folder with our marker, or with our manifest and unchanged, is ever
  removed: anything else under those names is refused in one line.

Rank 0 does every file operation; errors are broadcast so that every rank raises the same.
The manifests themselves (written, read, checked) are workflows/io/manifest.py's.
"""

from __future__ import annotations

import errno
import json
import os
import shutil
import socket
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TypeVar

from mpi4py import MPI

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.core.fingerprint import fingerprint
from tissuebench.core.waiting import wait_for_rank0
from tissuebench.workflows.io.manifest import (
    MANIFEST,
    MARK,
    changes,
    file_hash,
    is_complete,
    is_ours,
    read_manifest,
    seal,
    stage_manifest,
)
from tissuebench.workflows.io.summary import read_summary

PREFIX = ".tissuebench-"  # of our temporary, backup and lock names beside a target

T = TypeVar("T")  # what a collective action returns


class OutputError(UserError):
    """An output folder that cannot or must not be written: one line, exit status 2."""


class WriteFailure(RuntimeError):
    """The environment failed while writing (disk full, permission lost): one line, exit 1."""


# --- a folder of ours, checked ------------------------------------------------------------------


def _listing(names: list[str]) -> str:
    return names[0] + (f" and {len(names) - 1} more" if len(names) > 1 else "")


def check_foreign(path: Path) -> None:
    """Refuse (OutputError) a folder that holds anything but what we wrote there, unchanged."""
    if not path.is_dir():
        return
    names = sorted(p.name for p in path.iterdir())
    if not names:
        return
    found = changes(path)
    if found is None:
        if read_manifest(path, "files") is not None:
            what = "other outputs of tissuebench (a shared folder)"
        else:
            what = "files that tissuebench did not write"
        old = (read_summary(path) or {}).get("fingerprint")
        hint = " (a summary with no manifest: an older tissuebench's?)" if old else ""
        raise OutputError(
            f"{path}: holds {what} ({_listing(names)}){hint}; name a new or empty folder"
        )
    added, modified, _ = found
    if added or modified:
        what = [f"{_listing(added)} added"] if added else []
        what += [f"{_listing(modified)} changed"] if modified else []
        raise OutputError(
            f"{path}: {' and '.join(what)} since tissuebench wrote it; move that out or name "
            "another folder (nothing is replaced, --force or not)"
        )


# --- names beside a target ----------------------------------------------------------------------


def partial_path(target: Path) -> Path:
    """The temporary folder that becomes target."""
    return target.parent / f"{PREFIX}partial-{target.name}"


def old_path(target: Path) -> Path:
    """Where target's previous content waits while the new one moves in."""
    return target.parent / f"{PREFIX}old-{target.name}"


def lock_path(target: Path) -> Path:
    """The lock file of target."""
    return target.parent / f"{PREFIX}lock-{target.name}"


def _mark(folder: Path, target: Path) -> None:
    (folder / MARK).write_text(json.dumps({"tissuebench": "temporary", "target": str(target)}))


def _marked(folder: Path) -> bool:
    try:
        data = json.loads((folder / MARK).read_text())
    except (OSError, ValueError, RecursionError):
        return False
    return isinstance(data, dict) and data.get("tissuebench") == "temporary"


def remove_temporary(folder: Path) -> None:
    """Remove one of our temporary or backup folders; refuse anything else of that name."""
    if not folder.exists() and not folder.is_symlink():
        return
    if folder.is_symlink() or not folder.is_dir() or not (_marked(folder) or is_ours(folder)):
        raise OutputError(
            f"{folder}: exists and is not a temporary folder of tissuebench (no marker); "
            "move it away"
        )
    shutil.rmtree(folder)


def make_temporary(folder: Path) -> Path:
    """A fresh, marked temporary folder (an earlier one of ours of that name is removed)."""
    remove_temporary(folder)
    folder.mkdir(parents=True)
    _mark(folder, folder)
    return folder


def _flatten(value, prefix=""):
    if isinstance(value, dict):
        out = {}
        for key, item in value.items():
            out.update(_flatten(item, f"{prefix}.{key}" if prefix else str(key)))
        return out
    if isinstance(value, list):
        out = {}
        for k, item in enumerate(value):
            out.update(_flatten(item, f"{prefix}[{k}]"))
        return out
    return {prefix: value}


def differences(old: dict, new: dict, most: int = 4) -> str:
    """The inputs that differ, as 'key: old -> new' (at most `most` of them)."""
    a, b = _flatten(old or {}), _flatten(new)
    keys = [k for k in dict.fromkeys([*a, *b]) if a.get(k, "absent") != b.get(k, "absent")]
    text = ", ".join(f"{k}: {a.get(k, 'absent')!r} -> {b.get(k, 'absent')!r}" for k in keys[:most])
    return text + (f" and {len(keys) - most} more" if len(keys) > most else "")


def resolve(out: Path | str) -> Path:
    """The absolute, symlink-free path of an output folder, refused if it cannot be ours."""
    if str(out).strip() == "":
        raise OutputError("--out is empty: name a folder")
    path = Path(out)
    if path.is_symlink() and not path.exists():
        raise OutputError(f"{out}: a symbolic link to nothing ({os.readlink(path)}); name a folder")
    path = path.resolve()
    if path.parent == path:
        raise OutputError(f"{out}: the root folder cannot be an output folder")
    cwd = Path.cwd().resolve()
    if cwd == path or path in cwd.parents:
        raise OutputError(f"{out}: holds the current folder; name a folder beside or below it")
    if path.exists() and not path.is_dir():
        raise OutputError(f"{out}: exists and is not a folder")
    if path.name.startswith(PREFIX):
        raise OutputError(
            f"{out}: names starting with {PREFIX} are tissuebench's own; pick another"
        )
    return path


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


class Lock:
    """An exclusive lock file, created atomically (O_EXCL); a stale one is taken over. With
    `wait` > 0 s, a lock held by a live process is waited for that long before refusing."""

    def __init__(self, path: Path, what: Path, wait: float = 0.0):
        self.path, self.what, self.held, self.wait = path, what, False, wait

    def acquire(self) -> None:
        host = socket.gethostname()
        record = json.dumps(
            {
                "tissuebench": "lock",
                "pid": os.getpid(),
                "host": host,
                "since": time.strftime("%Y-%m-%d %H:%M:%S"),
            }
        )
        deadline = time.monotonic() + self.wait
        while True:
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                try:
                    holder = json.loads(self.path.read_text())
                except (OSError, ValueError):
                    holder = None
                if not isinstance(holder, dict) or holder.get("tissuebench") != "lock":
                    if holder is None and time.monotonic() < deadline:
                        time.sleep(0.05)  # being written by its taker
                        continue
                    raise OutputError(
                        f"{self.path}: exists and is not a tissuebench lock; move it away"
                    ) from None
                pid = holder.get("pid")
                if isinstance(pid, int) and holder.get("host") == host and not _pid_alive(pid):
                    self.path.unlink(missing_ok=True)  # its writer is gone: stale
                    continue
                if time.monotonic() < deadline:
                    time.sleep(0.05)
                    continue
                since = f" since {holder['since']}" if "since" in holder else ""
                raise OutputError(
                    f"{self.what}: another tissuebench run is writing it (pid {pid} on "
                    f"{holder.get('host', '?')}{since}); "
                    f"wait for it, or remove {self.path} if that run is gone"
                ) from None
            except OSError as err:
                raise OutputError(
                    f"{self.what}: cannot write in {self.path.parent} ({err.strerror or err})"
                ) from None
            try:
                os.write(fd, record.encode())
            finally:
                os.close(fd)
            self.held = True
            return

    def release(self) -> None:
        if self.held:
            self.path.unlink(missing_ok=True)
            self.held = False


def collective(comm: MPI.Comm, action: Callable[[], T], where: Path | None = None) -> T:
    """Run action() on rank 0 and broadcast its result. An exception on rank 0 is raised on
    every rank (an OSError as a WriteFailure naming `where`), so that none is left waiting.
    A signal that any rank received is raised on every rank first (core/interrupt.py)."""
    interrupt.checkpoint(comm)  # a signal received before: nothing more is written
    result = error = None
    if comm.rank == 0:
        try:
            result = action()
        except OSError as err:
            error = write_failure(where or Path(err.filename or "."), err)
        except Exception as err:
            error = err
    wait_for_rank0(comm)
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


def command_of(inputs: object) -> str | None:
    """The command whose folder a summary's inputs belong to: compare's name it, external's
    name a simulator, run's (and paper's cases, which run writes) neither; None when there are
    no inputs to read."""
    if not isinstance(inputs, dict):
        return None
    if "command" in inputs:
        return str(inputs["command"])
    return "external" if "simulator" in inputs else "run"


class RunFolder:
    """A folder to (re)write whole, held by its lock while the context is open.

    with RunFolder(out) as folder:
        if folder.prepare(inputs, force) == "complete": ...skip...
        with folder.writing() as tmp: ...write into tmp...
    """

    def __init__(self, out: Path | str, comm: MPI.Comm = MPI.COMM_WORLD):
        self.comm = comm
        self.path = collective(comm, lambda: resolve(out))
        self.partial = partial_path(self.path)
        self.old = old_path(self.path)
        self.lock = Lock(lock_path(self.path), self.path)

    def __enter__(self) -> RunFolder:
        def take():
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as err:
                raise OutputError(
                    f"{self.path}: cannot create {self.path.parent} ({err.strerror or err})"
                ) from None
            self.lock.acquire()
            if self.old.exists() and not self.path.exists() and is_ours(self.old):
                self.old.rename(self.path)  # a move into place that was cut short: undone
                (self.path / MARK).unlink(missing_ok=True)
            remove_temporary(self.old)
            check_foreign(self.path)

        try:
            collective(self.comm, take)
        except BaseException:
            if self.comm.rank == 0:
                self.lock.release()
            raise
        return self

    def __exit__(self, *exc) -> None:
        if self.comm.rank == 0:
            self.lock.release()

    def prepare(self, inputs: dict, force: bool) -> str:
        """'complete' if the folder holds complete results of the same inputs and not force;
        'write' otherwise. Refuses results of other inputs without force."""

        def decide():
            if not self.path.exists() or not any(self.path.iterdir()):
                return "write"  # new or empty
            summary = read_summary(self.path) or {}
            theirs, ours = command_of(summary.get("inputs")), command_of(inputs)
            if theirs not in (None, ours):  # another command's results: never ours to replace
                raise OutputError(
                    f"{self.path}: holds the results of tissuebench {theirs}, which {ours} "
                    "never replaces, --force or not; name another folder with --out"
                )
            if force or not is_complete(self.path):  # ours, and replaced on request or broken
                return "write"
            if summary.get("fingerprint") == fingerprint(inputs):
                return "complete"
            raise OutputError(
                f"{self.path}: holds results of other inputs "
                f"({differences(summary.get('inputs'), inputs)}); --force replaces them"
            )

        return collective(self.comm, decide)

    @contextmanager
    def writing(self) -> Iterator[Path]:
        """Yield a fresh partial folder; on success it replaces the target, on any failure it
        is removed. Collective."""

        def fresh():
            try:
                remove_temporary(self.partial)  # an earlier run's leftover (we hold the lock)
                self.partial.mkdir()
                _mark(self.partial, self.path)
            except OSError as err:
                raise OutputError(
                    f"{self.path}: cannot write in {self.path.parent} ({err.strerror or err})"
                ) from None

        collective(self.comm, fresh)
        try:
            yield self.partial
            collective(self.comm, self._commit, self.path)
        finally:
            if self.comm.rank == 0 and _marked(self.partial):
                shutil.rmtree(self.partial, ignore_errors=True)

    def _commit(self) -> None:
        check_foreign(self.path)  # something of a user's may have appeared meanwhile
        seal(self.partial)
        try:
            remove_temporary(self.old)
            if self.path.is_dir():
                _mark(self.path, self.path)  # ours (checked above): marked before it moves
                self.path.rename(self.old)
            (self.partial / MARK).unlink()
            self.partial.rename(self.path)
        except OSError as err:
            if self.old.exists() and not self.path.exists():
                self.old.rename(self.path)
                (self.path / MARK).unlink(missing_ok=True)
            raise WriteFailure(
                f"{self.path}: cannot move the results into place ({err.strerror or err})"
            ) from None
        if self.old.exists():
            shutil.rmtree(self.old, ignore_errors=True)


def write_failure(path: Path, err: OSError) -> WriteFailure:
    """A one-line WriteFailure for an OSError met while writing into path."""
    if err.errno == errno.ENOSPC:
        reason = "no space left on the device"
    else:
        reason = err.strerror or str(err)
    return WriteFailure(f"{path}: cannot write the results ({reason})")


# --- loose files in a shared folder -------------------------------------------------------------


def check_owned(path: Path, force: bool = True) -> None:
    """Refuse (OutputError) to replace `path` unless it is absent, or listed in its folder's
    manifest with its present hash (ours, unchanged) and `force`."""
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return
    if path.is_symlink() or not path.is_file():
        raise OutputError(f"{path}: exists and is not a file tissuebench wrote; move it away")
    listed = read_manifest(path.parent, "files") or {}
    if path.name not in listed:
        raise OutputError(
            f"{path}: exists and was not written by tissuebench; move it or choose another --out"
        )
    if listed[path.name] != file_hash(path):
        raise OutputError(
            f"{path}: was changed since tissuebench wrote it; move it or choose another --out"
        )
    if not force:
        raise OutputError(f"{path}: exists: --force replaces it")


def write_owned(path: Path, write: Callable[[Path], object]) -> None:
    """write(tmp) into a temporary file beside path, rename it into place and list it with
    its hash in the folder's manifest (rank 0). Refuses a file that is not ours. The new
    manifest is staged too before anything is renamed, and both renames are done with signals
    deferred: a full disk or a signal leaves the old file with its manifest (write_set)."""
    write_set({Path(path): write}, done=False)


def write_set(
    files: dict[Path, Callable[[Path], object]], staged_hook=None, done: bool = True
) -> None:
    """Several loose files written as one set (rank 0): each write(tmp) staged into a
    temporary beside its target; then, every folder's manifest lock held and every target
    checked as ours (check_owned), all renamed into place and listed in their folders'
    manifests with signals deferred (core/interrupt.py), so that a signal or an error
    before the renames leaves the old set whole, and one during them is raised once the whole
    new set is in place. What interrupt.will_write named is said written when the renames are
    done. `staged_hook()`, if given, runs once everything is staged (tests send a signal there).
    """
    staged: dict[Path, Path] = {}
    manifests: dict[Path, Path] = {}  # folder: its new manifest, staged
    locks: list[Lock] = []
    try:
        for path, write in files.items():
            path = Path(path)
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.parent / f"{PREFIX}{path.name}.{os.getpid()}.tmp{path.suffix}"
            staged[path] = tmp
            write(tmp)
            interrupt.check()  # a signal while staging: raised here, nothing replaced
        if staged_hook is not None:
            staged_hook()
        folders = sorted({path.parent for path in staged})
        for folder in folders:
            lock = Lock(folder / f"{PREFIX}lock-{MANIFEST}", folder, wait=30.0)
            lock.acquire()
            locks.append(lock)
        for path in staged:
            check_owned(path)
        digests = {path: file_hash(tmp) for path, tmp in staged.items()}
        for folder in folders:  # every manifest written whole before any file moves
            listed = read_manifest(folder, "files") or {}
            mine = {p.name: digests[p] for p in staged if p.parent == folder}
            manifests[folder] = stage_manifest(folder, "files", {**listed, **mine})
        interrupt.check()  # the last point at which a signal leaves the old set whole
        with interrupt.deferred():  # renames only: no disk space needed
            for folder in folders:
                for path, tmp in staged.items():
                    if path.parent == folder:
                        os.replace(tmp, path)
                os.replace(manifests[folder], folder / MANIFEST)
            if done:
                interrupt.will_write([])  # the whole set is in place
    finally:
        for lock in locks:
            lock.release()
        for tmp in [*staged.values(), *manifests.values()]:
            tmp.unlink(missing_ok=True)


def check_file_target(out: Path, suffix: str, force: bool, also: tuple | list = ()) -> None:
    """Refuse, before any work, a file output that does not end in .suffix, or that (or one of
    the files written beside it, `also`) is a folder or exists and is not ours unchanged (or
    without force), or whose folder cannot be written."""
    if out.suffix.lower() != f".{suffix}":
        raise OutputError(f"output {out} must end in .{suffix}")
    for path in [out, *also]:
        if path.is_dir():
            raise OutputError(f"output {path} is a folder: name a .{suffix} file")
        check_owned(path, force)
    existing = next(p for p in out.absolute().parents if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"output {out}: cannot write there ({existing} is not a writable folder)")


def check_writable(
    out_dir: Path | str, comm: MPI.Comm = MPI.COMM_WORLD, owned: Iterable[str] = ()
) -> None:
    """Raise OutputError on every rank unless rank 0 can create and write out_dir (a shared
    folder of loose outputs such as stability.md; nothing is created) and every file of
    `owned` (names in it) that exists is ours, unchanged."""

    def check():
        out = Path(out_dir)
        if str(out_dir).strip() == "":
            raise OutputError("--out is empty: name a folder")
        if out.exists() and not out.is_dir():
            raise OutputError(f"{out}: exists and is not a folder")
        existing = next(p for p in [out.absolute(), *out.absolute().parents] if p.exists())
        if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
            raise OutputError(f"{out}: cannot write there ({existing} is not writable)")
        for name in owned:
            check_owned(out / name)

    collective(comm, check)
