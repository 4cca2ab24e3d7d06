"""Output folders that tissuebench owns, and only those.

Rules (README, "Output folders"):
- A run or case folder is ours when its summary.json carries a `fingerprint`: the hash of
  every input that changes its numbers (`inputs`, kept beside it).
- `--out` may name a new folder, an empty one, or one of ours. A folder that holds anything
  else is refused; `--force` replaces only a folder of ours.
- Ours and complete with the same fingerprint: skipped. Ours with another fingerprint: refused
  with what differs, unless `--force`.
- One writer per folder: a lock file `.lock-NAME` beside it, created atomically, removed on
  every exit path (a lock left by a process that no longer runs on this host is taken over).
- Everything is written into `.partial-NAME` beside the target and renamed into place only
  when complete; on any failure or signal the partial folder is removed.

Rank 0 does every file operation; errors are broadcast so that every rank raises the same.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import shutil
import socket
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from mpi4py import MPI
from tissuebench.workflows.errors import UserError

SUMMARY = "summary.json"


class OutputError(UserError):
    """An output folder that cannot or must not be written: one line, exit status 2."""


class WriteFailure(RuntimeError):
    """The environment failed while writing (disk full, permission lost): one line, exit 1."""


def fingerprint(inputs: dict) -> str:
    """The SHA-256 of the inputs as canonical JSON."""
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def read_summary(folder: Path) -> dict | None:
    """The folder's summary.json as a dict, or None if absent or unreadable."""
    try:
        summary = json.loads((Path(folder) / SUMMARY).read_text())
    except (OSError, ValueError, RecursionError):
        return None
    return summary if isinstance(summary, dict) else None


def is_ours(folder: Path) -> bool:
    """True if the folder's summary.json carries a tissuebench fingerprint."""
    summary = read_summary(folder)
    return summary is not None and isinstance(summary.get("fingerprint"), str)


def is_complete(folder: Path) -> bool:
    """A folder of ours is complete when every file its summary lists exists."""
    summary = read_summary(folder)
    try:
        return is_ours(folder) and all((Path(folder) / f).is_file() for f in summary["files"])
    except (KeyError, TypeError):
        return False


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
    """An exclusive lock file, created atomically (O_EXCL); a stale one is taken over."""

    def __init__(self, path: Path, what: Path):
        self.path, self.what, self.held = path, what, False

    def acquire(self) -> None:
        host = socket.gethostname()
        record = json.dumps(
            {"pid": os.getpid(), "host": host, "since": time.strftime("%Y-%m-%d %H:%M:%S")}
        )
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
            except FileExistsError:
                try:
                    holder = json.loads(self.path.read_text())
                except (OSError, ValueError):
                    holder = {}
                pid = holder.get("pid") if isinstance(holder, dict) else None
                if isinstance(pid, int) and holder.get("host") == host and not _pid_alive(pid):
                    self.path.unlink(missing_ok=True)  # its writer is gone: stale
                    continue
                since = (
                    f" since {holder['since']}"
                    if isinstance(holder, dict) and "since" in holder
                    else ""
                )
                raise OutputError(
                    f"{self.what}: another tissuebench run is writing it (pid {pid} on "
                    f"{holder.get('host', '?') if isinstance(holder, dict) else '?'}{since}); "
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
        raise OutputError(f"{self.what}: cannot take the lock {self.path}")

    def release(self) -> None:
        if self.held:
            self.path.unlink(missing_ok=True)
            self.held = False


def collective(comm: MPI.Comm, action, where: Path | None = None):
    """Run action() on rank 0 and broadcast its result. An exception on rank 0 is raised on
    every rank (an OSError as a WriteFailure naming `where`), so that none is left waiting."""
    result = error = None
    if comm.rank == 0:
        try:
            result = action()
        except OSError as err:
            error = write_failure(where or Path(err.filename or "."), err)
        except Exception as err:
            error = err
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


class RunFolder:
    """A run or case folder to (re)write, held by its lock while the context is open.

    with RunFolder(out) as folder:
        if folder.prepare(inputs, force) == "complete": ...skip...
        with folder.writing() as tmp: ...write into tmp...
    """

    def __init__(self, out: Path | str, comm: MPI.Comm = MPI.COMM_WORLD):
        self.comm = comm
        self.path = collective(comm, lambda: resolve(out))
        self.partial = self.path.parent / f".partial-{self.path.name}"
        self.lock = Lock(self.path.parent / f".lock-{self.path.name}", self.path)

    def __enter__(self) -> RunFolder:
        def take():
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as err:
                raise OutputError(
                    f"{self.path}: cannot create {self.path.parent} ({err.strerror or err})"
                ) from None
            self.lock.acquire()
            self.check_foreign()

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

    def check_foreign(self) -> None:
        """Refuse a folder that holds files and is not ours (rank 0)."""
        if self.path.is_dir() and not is_ours(self.path):
            names = sorted(p.name for p in self.path.iterdir())
            if names:
                old = (
                    " (its summary.json has no fingerprint: written by an older tissuebench?)"
                    if (self.path / SUMMARY).exists()
                    else ""
                )
                raise OutputError(
                    f"{self.path}: holds files that tissuebench did not write ({names[0]}"
                    f"{' and more' if len(names) > 1 else ''}){old}; name a new or empty folder"
                )

    def prepare(self, inputs: dict, force: bool) -> str:
        """'complete' if the folder holds complete results of the same inputs and not force;
        'write' otherwise. Refuses results of other inputs without force."""

        def decide():
            if not self.path.exists() or not is_ours(self.path):
                return "write"  # new or empty
            summary = read_summary(self.path)
            if force or not is_complete(self.path):  # ours, and replaced on request or broken
                return "write"
            if summary.get("fingerprint") == fingerprint(inputs):
                return "complete"
            raise OutputError(
                f"{self.path}: holds results of other inputs ({differences(summary.get('inputs'), inputs)}); "
                "--force replaces them"
            )

        return collective(self.comm, decide)

    @contextmanager
    def writing(self) -> Iterator[Path]:
        """Yield a fresh partial folder; on success it replaces the target, on any failure it
        is removed. Collective."""

        def fresh():
            try:
                shutil.rmtree(
                    self.partial, ignore_errors=True
                )  # an earlier run's leftover: ours (we hold the lock)
                self.partial.mkdir()
            except OSError as err:
                raise OutputError(
                    f"{self.path}: cannot write in {self.path.parent} ({err.strerror or err})"
                ) from None

        collective(self.comm, fresh)
        try:
            yield self.partial
            collective(self.comm, self._commit)
        finally:
            if self.comm.rank == 0:
                shutil.rmtree(self.partial, ignore_errors=True)

    def _commit(self) -> None:
        self.check_foreign()  # something of a user's may have appeared meanwhile
        old = self.path.parent / f".old-{self.path.name}"
        try:
            shutil.rmtree(old, ignore_errors=True)
            if self.path.is_dir():
                self.path.rename(old)
            self.partial.rename(self.path)
        except OSError as err:
            if old.exists() and not self.path.exists():
                old.rename(self.path)
            raise WriteFailure(
                f"{self.path}: cannot move the results into place ({err.strerror or err})"
            ) from None
        shutil.rmtree(old, ignore_errors=True)


def write_failure(path: Path, err: OSError) -> WriteFailure:
    """A one-line WriteFailure for an OSError met while writing into path."""
    if err.errno == errno.ENOSPC:
        reason = "no space left on the device"
    else:
        reason = err.strerror or str(err)
    return WriteFailure(f"{path}: cannot write the results ({reason})")


def check_file_target(out: Path, suffix: str, force: bool, also: tuple | list = ()) -> None:
    """Refuse, before any work, a file output that does not end in .suffix, or that (or one of
    the files written beside it, `also`) is a folder or exists (unless force), or whose folder
    cannot be written."""
    if out.suffix.lower() != f".{suffix}":
        raise OutputError(f"output {out} must end in .{suffix}")
    for path in [out, *also]:
        if path.is_dir():
            raise OutputError(f"output {path} is a folder: name a .{suffix} file")
        if path.exists() and not force:
            raise OutputError(f"output {path} exists: --force replaces it")
    existing = next(p for p in out.absolute().parents if p.exists())
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"output {out}: cannot write there ({existing} is not a writable folder)")


def check_writable(out_dir: Path | str, comm: MPI.Comm = MPI.COMM_WORLD) -> None:
    """Raise OutputError on every rank unless rank 0 can create and write out_dir (a folder
    of loose outputs such as stability.md; nothing is created)."""

    def check():
        out = Path(out_dir)
        if str(out_dir).strip() == "":
            raise OutputError("--out is empty: name a folder")
        if out.exists() and not out.is_dir():
            raise OutputError(f"{out}: exists and is not a folder")
        existing = next(p for p in [out.absolute(), *out.absolute().parents] if p.exists())
        if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
            raise OutputError(f"{out}: cannot write there ({existing} is not writable)")

    collective(comm, check)
