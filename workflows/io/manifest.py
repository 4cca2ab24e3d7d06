"""The manifests of what tissuebench writes (workflows/io/output.py's rules, README "Output
folders"): `.tissuebench.json` in a folder written whole ("folder": every file below it with its
SHA-256) or in a shared folder of loose files ("files": those it wrote), read, staged, written
and checked against the files in place.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Iterator
from pathlib import Path

from tissuebench.workflows.io.summary import read_summary

MANIFEST = ".tissuebench.json"  # what we wrote, with hashes
MARK = ".tissuebench-temporary"  # inside our temporary and backup folders


def file_hash(path: Path) -> str:
    """The SHA-256 of a file's bytes, as hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_manifest(folder: Path, kind: str) -> dict[str, str] | None:
    """{relative path: SHA-256} of the folder's manifest of this kind ("folder": every file
    below it; "files": loose files in a shared folder), or None if there is none."""
    try:
        data = json.loads((Path(folder) / MANIFEST).read_text())
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(data, dict) or data.get("tissuebench") != kind:
        return None
    files = data.get("files")
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        return None
    return files


def stage_manifest(folder: Path, kind: str, files: dict[str, str]) -> Path:
    """The manifest written whole under a staging name beside its place, which
    os.replace(staged, folder / MANIFEST) puts in place (removed again if writing it fails)."""
    text = json.dumps({"tissuebench": kind, "files": dict(sorted(files.items()))}, indent=1)
    tmp = folder / f"{MANIFEST}.{os.getpid()}.tmp"
    try:
        tmp.write_text(text + "\n")
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return tmp


def _write_manifest(folder: Path, kind: str, files: dict[str, str]) -> None:
    tmp = stage_manifest(folder, kind, files)
    try:
        os.replace(tmp, folder / MANIFEST)
    finally:
        tmp.unlink(missing_ok=True)


def _below(folder: Path) -> Iterator[tuple[str, Path]]:
    """(relative path, path) of every file and link below folder, the manifest and our
    temporary marker left out."""
    for root, dirs, files in os.walk(folder):
        for name in sorted(files) + sorted(d for d in dirs if Path(root, d).is_symlink()):
            path = Path(root, name)
            rel = path.relative_to(folder).as_posix()
            if rel not in (MANIFEST, MARK):
                yield rel, path


def seal(folder: Path) -> None:
    """Write the manifest of a folder that we wrote whole: every file below it, hashed."""
    _write_manifest(folder, "folder", {rel: file_hash(path) for rel, path in _below(folder)})


def changes(folder: Path) -> tuple[list[str], list[str], list[str]] | None:
    """(added, modified, missing) relative paths since we sealed the folder, or None if the
    folder has no manifest of ours. A link, or anything that is not a plain file, counts as
    added."""
    listed = read_manifest(folder, "folder")
    if listed is None:
        return None
    added, modified, seen = [], [], set()
    for rel, path in _below(folder):
        seen.add(rel)
        if rel not in listed or path.is_symlink() or not path.is_file():
            added.append(rel)
        elif file_hash(path) != listed[rel]:
            modified.append(rel)
    return added, modified, sorted(set(listed) - seen)


def unchanged(path: Path) -> bool:
    """Whether a loose file of ours is in place as we wrote it (listed in its folder's
    manifest of files with its present hash)."""
    listed = read_manifest(path.parent, "files") or {}
    return path.is_file() and listed.get(path.name) == file_hash(path)


def is_ours(folder: Path) -> bool:
    """True if the folder carries our manifest and nothing in it was added or changed."""
    found = changes(folder)
    return found is not None and not found[0] and not found[1]


def is_complete(folder: Path) -> bool:
    """A folder of ours is complete when no file of its manifest is gone and every file its
    summary lists exists."""
    found = changes(folder)
    summary = read_summary(folder)
    if found is None or any(found) or summary is None:
        return False
    try:
        return all((Path(folder) / f).is_file() for f in summary["files"])
    except (KeyError, TypeError):
        return False
