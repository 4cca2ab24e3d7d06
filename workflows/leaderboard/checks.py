"""A user's compare folder under the leaderboard, read and checked (rows.py's docstring says
against what): its label, status, wall time and metrics, its reference's fingerprint against
the case's, its manifest, its links and its series' hashes; what fails is left out with one
line saying why and what to do (user_rows, misplaced). No number of a row is taken from the
folder: the leaderboard grades its series (grading.py)."""

from __future__ import annotations

import hashlib
import math
import os
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, cast

from tissuebench.meshes import get_entry
from tissuebench.workflows.io.manifest import MANIFEST, changes, file_hash
from tissuebench.workflows.io.summary import read_summary
from tissuebench.workflows.leaderboard.boards import Board
from tissuebench.workflows.leaderboard.cases import (
    TOLERANCE,
    board_case,
    options_words,
    same_options,
)
from tissuebench.workflows.leaderboard.force_curve import read_curve
from tissuebench.workflows.leaderboard.row import (
    USER_SOURCE,
    Kind,
    Row,
    error_keys,
    finite,
    one_line,
    real,
)
from tissuebench.workflows.simulators import SIMULATORS

if TYPE_CHECKING:
    from tissuebench.workflows.io.summary import CompareSummary

MAX_LABEL = 64  # characters of a user's label, as compare takes it
STATUSES = ("ok", "diverged", "reference diverged", "missing")  # compare's


def label_problem(label) -> str | None:
    """Why a user's run label cannot be taken (None: it can): compare's rule, printable text
    of 1 to MAX_LABEL characters without leading or trailing spaces."""
    if not isinstance(label, str) or not 0 < len(label) <= MAX_LABEL:
        return f"its label must be text of 1 to {MAX_LABEL} characters"
    if not label.isprintable() or label.strip() != label:
        return "its label has characters that are not printable or leading/trailing spaces"
    return None


RERUN_COMPARE = "rerun tissuebench compare (with --force) into it"


def reference_problem(
    summary: dict, case: dict, board: Board | None = None, home: str | None = None
) -> str | None:
    """Why a compare summary was not graded on the case (None: it was): its h, steps and end
    time, and the fingerprint of its reference (grading.reference_fingerprint: benchmark,
    options, material, model, mesh size, dimension and nodes, or the truth case) against the
    case's. Each reason ends with what to do; `home`, where known, says where the folder
    belongs (the case it was graded for and its user/ folder)."""
    h, steps, end = (summary.get(k) for k in ("h", "steps", "end_time"))
    if not (finite(h) and h > 0 and finite(end) and end > 0):
        return f"its summary.json has no positive numbers h and end_time: {RERUN_COMPARE}"
    if not (isinstance(steps, int) and not isinstance(steps, bool) and steps > 0):
        return f"its summary.json has no positive whole number of steps: {RERUN_COMPARE}"
    close = [
        math.isclose(a, b, rel_tol=TOLERANCE) for a, b in ((h, case["h"]), (end, case["end_time"]))
    ]
    if steps != case["steps"] or not all(close):
        return (
            f"graded over {steps} steps of h = {h:.6g} s to T = {end:.6g} s; the case is "
            f"{case['steps']} steps of h = {case['h']:.6g} s to T = {case['end_time']:.6g} s: "
            "run your simulator with that h and T and compare again"
        )
    reference = summary.get("reference")
    fp = reference.get("fingerprint") if isinstance(reference, dict) else None
    if not isinstance(fp, dict) or "source" not in fp:
        return (
            "graded by an older compare, which records no fingerprint of its reference: "
            f"{RERUN_COMPARE}"
        )
    if board is None:
        return None
    where = f"this case ({board.name}: {board.benchmark} {board.material} {board.model}"
    where += f", {options_words(board.options)}, {case['gdim']}D, {case['nodes']} nodes)"
    move = f"compare against {board.name}'s reference, or move the folder under its own case"
    if home:
        move = f"it belongs to {home}, or compare against {board.name}'s reference"
    if fp.get("source") == "truth":
        if fp.get("truth") != board.truth:
            has = f"the truth {board.truth}" if board.truth else "no truth"
            truth = one_line(fp.get("truth"))[:40]
            return f"graded against the truth {truth}; {where} has {has}: {move}"
        return None
    if fp.get("benchmark") is None:
        assert isinstance(reference, dict)  # fp came from it
        return (
            f"its reference {one_line(reference.get('file'))[:200]} is neither in a run folder "
            "of ours nor an export's (NAME.reference.xdmf beside NAME.json), so its case is "
            f"not known: compare against the reference `tissuebench export` writes for {board.name}"
        )
    options = fp.get("options")
    got = (
        f"{fp.get('benchmark')} {fp.get('material')} {fp.get('model')}, "
        f"{options_words(options if isinstance(options, dict) else {})}, "
        f"{fp.get('dimension')}D, {fp.get('nodes')} nodes"
    )
    size = board.mesh_size or get_entry(board.benchmark).mesh_size
    if (
        fp.get("benchmark") != board.benchmark
        or fp.get("material") != board.material
        or fp.get("model") != board.model
        or not same_options(fp.get("options") or {}, board.options)
        or fp.get("dimension") != case["gdim"]
        or fp.get("nodes") != case["nodes"]
        or (fp.get("mesh_size") is not None and fp.get("mesh_size") != size)
    ):
        return f"graded against {one_line(got)[:160]}, not {where}: {move}"
    return None


def user_mesh(mesh: dict | None) -> tuple[str, int]:
    """A user's run's mesh ("TYPE: C cells, N nodes") and dofs from its series' mesh
    (grading.mesh_of: cell_type, cells, nodes, dofs); ("?", 0) when it is not known."""
    if not isinstance(mesh, dict):
        return "?", 0
    cells, nodes, dofs = (mesh.get(k) for k in ("cells", "nodes", "dofs"))
    kind = mesh.get("cell_type")
    if not (
        isinstance(kind, str) and all(isinstance(x, int) and x > 0 for x in (cells, nodes, dofs))
    ):
        return "?", 0
    plural = {"hexahedron": "hexahedra", "tetrahedron": "tetrahedra"}.get(kind, f"{kind}s")
    return f"{one_line(plural)[:40]}: {cells:,} cells, {nodes:,} nodes", cast(int, dofs)


def run_problem(label, run) -> str | None:
    """Why one run of a compare summary cannot be a row (None: it can): its label, status,
    wall time (s; null when none was given) and every metric (null, or a number >= 0; an
    infinite one only for a run that did not finish)."""
    problem = label_problem(label)
    if problem:
        return f"{problem}: rerun compare with --label NAME (and --force)"
    if not isinstance(run, dict):
        return f"not a run (an object) in summary.json: {RERUN_COMPARE}"
    if run.get("status") not in STATUSES:
        return (
            f"status {one_line(repr(run.get('status')))[:40]} is not one of "
            f"{', '.join(STATUSES)}: {RERUN_COMPARE}"
        )
    if "wall_time_s" not in run:
        return f"no wall_time_s: {RERUN_COMPARE}"
    wall = run["wall_time_s"]
    if wall is not None and not (finite(wall) and wall >= 0):
        return (
            f"wall_time_s {one_line(repr(wall))[:40]} is not a finite number of seconds >= 0: "
            "rerun compare with --wall-time SECONDS (and --force)"
        )
    for key in error_keys():
        if key not in run:
            return f"no {key}: {RERUN_COMPARE}"
        value = run[key]
        if value is None:
            continue
        if not real(value) or math.isnan(value) or value < 0:
            return f"{key} {one_line(repr(value))[:40]} is not a number >= 0: {RERUN_COMPARE}"
        if math.isinf(value) and run["status"] == "ok":
            return f"{key} is infinite in a run whose status is ok: {RERUN_COMPARE}"
    return None


def owners(summary: dict, boards: list[Board]) -> list[Board]:
    """The cases among `boards` that take a compare summary (graded against their reference or
    their truth)."""
    return [b for b in boards if reference_problem(summary, board_case(b), b) is None]


def home_of(summary: dict, boards: list[Board], leaderboard: Path, name: str) -> str | None:
    """Where a compare folder called `name` belongs under the leaderboard folder, in words
    ("rod-MP3-s3: move it to OUT/leaderboard/rod-MP3-s3/user/NAME"), or None when it was
    graded for none of `boards`."""
    found = owners(summary, boards)
    if not found:
        return None
    names = " or ".join(b.name for b in found)
    return f"{names}: move it to {one_line(leaderboard / found[0].name / 'user' / name)}"


def is_compare(folder: Path) -> bool:
    """Whether a folder holds a summary.json that compare wrote."""
    summary = read_summary(folder)
    return summary is not None and summary.get("kind") == "compare"


def _folders(folder: Path) -> list[Path]:
    """The folders in folder, sorted, without hidden ones (ours: partial, old, locks)."""
    try:
        return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return []


def misplaced(leaderboard: Path, boards: list[Board]) -> list[str]:
    """One line for every folder under the leaderboard folder (OUT/leaderboard) that is not
    read although it may be meant to be: a folder that is not one of the cases (each compare
    folder in it, up to two levels down, else the folder itself), and a compare folder directly
    in a case's folder instead of its user/. Each line says what to do. Reads files only."""
    known = [b.name for b in boards]
    ours = {"ours", "user", *SIMULATORS}
    cases = ", ".join(known)
    lines = []
    for sub in _folders(leaderboard):
        if sub.name in known:
            for inner in _folders(sub):
                if inner.name in ours or inner.name.startswith("ours-") or not is_compare(inner):
                    continue
                home = home_of(read_summary(inner) or {}, boards, leaderboard, inner.name)
                lines.append(
                    f"{one_line(inner)}: a compare folder outside {sub.name}/user/, not read: "
                    f"move it to {one_line(sub / 'user' / inner.name)}"
                    + (f" (it was graded for {home.split(':')[0]})" if home else "")
                )
            continue
        inside = [sub] + _folders(sub) + [p for q in _folders(sub) for p in _folders(q)]
        found = [p for p in inside if is_compare(p)]
        why = f"{sub.name!r} is not a leaderboard case (cases: {cases})"
        for folder in found:
            home = home_of(read_summary(folder) or {}, boards, leaderboard, folder.name)
            lines.append(
                f"{one_line(folder)}: {one_line(why)}, not read: "
                + (f"it belongs to {home}" if home else f"move it under {leaderboard}/CASE/user/")
            )
        if not found:
            lines.append(
                f"{one_line(sub)}: {one_line(why)}, not read: put each compare folder under "
                f"{one_line(leaderboard)}/CASE/user/NAME"
            )
    return lines


UNGRADED = "not graded"  # a user's row's status until the leaderboard grades its series


def user_rows(
    board: Board, folder: Path, boards: list[Board] | None = None
) -> tuple[list[Row], list[str]]:
    """Rows of the compare folders in folder (CASE/user/NAME/summary.json, kind "compare"),
    and one line for each folder or run left out and why (see reference_problem, run_problem,
    links, edited and series_problem); a folder graded for another of `boards` is told where it
    belongs. No number of a row is taken from the folder: each row names its series (found and
    hashed here: series_hash), field, label and wall time, with no grade (status UNGRADED, every
    error None): the leaderboard grades the series (grading.py). Rows of the same label are
    told apart by their folder's name (told_apart). Reads files only; rank 0."""
    rows: list[Row] = []
    skipped: list[str] = []
    folders: list[str] = []  # each row's folder name
    folder = Path(folder)
    if not folder.is_dir():
        return rows, skipped
    case = board_case(board)
    for sub in sorted(p for p in folder.iterdir() if p.is_dir() or p.is_symlink()):
        where = one_line(sub)
        problem = links(sub)
        if problem:
            skipped.append(f"{where}: left out: {problem}")
            continue
        summary = read_summary(sub)
        if summary is None:
            skipped.append(
                f"{where}: left out: no readable summary.json of compare: grade the run with "
                f"`tissuebench compare REFERENCE CANDIDATE --out {where}`"
            )
            continue
        if summary.get("kind") != "compare":
            skipped.append(
                f"{where}: left out: its summary.json is not compare's: put only folders that "
                "`tissuebench compare --out` wrote under user/"
            )
            continue
        problem = reference_problem(summary, case, board)
        if problem and boards:
            others = [b for b in boards if b.name != board.name]
            home = home_of(summary, others, folder.parent.parent, sub.name)
            problem = reference_problem(summary, case, board, home)
        runs = summary.get("runs")
        if problem is None and (not isinstance(runs, dict) or not runs):
            problem = f"its summary.json has no runs: {RERUN_COMPARE}"
        if problem is None:
            problem = edited(sub)
        found: dict = {}
        if problem is None:
            found = candidate_of(summary, sub)
            problem = series_problem(summary, found) or model_problem(summary)
        if problem:
            skipped.append(f"{where}: left out: {problem}")
            continue
        assert isinstance(runs, dict)  # a summary with runs: checked above
        given = user_force(summary)  # a contact case's: the force file compare graded
        curve = None  # its force, read once here (force_curve.py): the record carries it
        if given is not None:
            try:
                curve = read_curve(given)
                if user_force(summary) != given:  # changed while read: not the one graded
                    raise ValueError("it changed while it was read")
            except ValueError as exc:
                curve = None
                skipped.append(
                    f"{where}: its needle force {one_line(given)[:80]} cannot be read "
                    f"({' '.join(str(exc).split())[:120]}): its runs have no force error"
                )
        for label, run in runs.items():
            problem = run_problem(label, run)
            if problem:
                skipped.append(f"{where}: run {one_line(label)[:80]} left out: {problem}")
                continue
            if run["wall_time_s"] is None:
                skipped.append(
                    f"{where}: run {one_line(label)[:80]} is listed but not ranked: compare was "
                    "given no wall time; rerun it with --wall-time SECONDS (and --force)"
                )
            rows.append(
                Row(
                    board.name,
                    label,
                    USER_SOURCE,
                    f"{one_line(sub.name)[:80]}: its series graded by the leaderboard",
                    "?",
                    0,
                    UNGRADED,
                    None,
                    dict.fromkeys(error_keys()),
                    None if run["wall_time_s"] is None else float(run["wall_time_s"]),
                    float(case["end_time"]),
                    "reported by the user",
                    **found,
                    force=given,
                    force_curve=curve,
                    folder=sub.name,
                    kind=Kind.USER,  # whatever its label says
                )
            )
            folders.append(sub.name)
    told_apart(rows, folders)
    return rows, skipped


SUFFIX = 40  # characters of a folder's name added to a label that another row has too


def suffix_of(name: str) -> str:
    """A folder's name as told_apart adds it to a label: made one line, and where longer than
    SUFFIX characters, its first ones and 8 hex digits of its hash (so that two long names
    that begin alike still differ)."""
    name = one_line(name)
    if len(name) <= SUFFIX:
        return name
    return f"{name[: SUFFIX - 9]}~{hashlib.sha256(name.encode()).hexdigest()[:8]}"


def told_apart(rows: list[Row], folders: list[str]) -> None:
    """Give each row whose label another row has too its folder's name after it, `label
    (NAME)` (suffix_of: at most SUFFIX characters, one line), twice at most; a label that is
    still another's then (a folder whose own labels end in another's name) gets its place
    among the rows, `label #k`, so that every label differs: each user's run is its own entry
    of the legend, in its own colour."""
    for _ in range(2):
        seen = Counter(r.label for r in rows)
        same = [(r, name) for r, name in zip(rows, folders, strict=True) if seen[r.label] > 1]
        if not same:
            return
        for r, name in same:
            r.label = f"{r.label} ({suffix_of(name)})"
    every = {r.label for r in rows}
    used: set[str] = set()
    for k, r in enumerate(rows, start=1):
        if r.label in used:
            label = f"{r.label} #{k}"
            while label in every or label in used:
                label += "'"
            r.label = label
        used.add(r.label)


def links(folder: Path) -> str | None:
    """Why a user's folder is not read for the links in it (None: it has none): the folder
    itself, or anything in it (summary.json, the manifest, any file), a symbolic link. The
    leaderboard follows none, wherever it points: compare writes none."""
    if folder.is_symlink():
        return (
            f"it is a symbolic link (to {one_line(os.readlink(folder))[:120]}), which the "
            "leaderboard does not follow: put the compare folder itself there"
        )
    try:
        for root, dirs, files in os.walk(folder):
            for name in sorted(files + dirs):
                path = Path(root, name)
                if path.is_symlink():
                    rel = one_line(path.relative_to(folder).as_posix())[:80]
                    return (
                        f"its {rel} is a symbolic link (to {one_line(os.readlink(path))[:120]}), "
                        "which the leaderboard does not follow (compare writes none): move the "
                        "folder away and grade the run again with tissuebench compare"
                    )
    except OSError as exc:
        return f"it cannot be read ({type(exc).__name__}: {one_line(exc)[:120]})"
    return None


def series_hash(files: dict) -> str:
    """The hash of a series by its files ({name: SHA-256}, grading.series_files)."""
    from tissuebench.core.fingerprint import fingerprint

    return fingerprint({"series": files})


def series_problem(summary: dict, found: dict) -> str | None:
    """Why a compare folder's series cannot be graded here (None: it can, and `found`, its
    candidate_of, gets its series_hash): it names none, it is not on this machine, it or a
    file of it is a symbolic link, or its files are not the ones compare graded (the hashes
    summary.json records, inputs.candidate.files: a series changed since would be graded as
    another run than compare's)."""
    from tissuebench.workflows.compare.grading import series_files

    again = "grade the run again with tissuebench compare (with --force)"
    inputs = summary.get("inputs")
    cand = inputs.get("candidate") if isinstance(inputs, dict) else None
    recorded = cand.get("files") if isinstance(cand, dict) else None
    if not found or not isinstance(recorded, dict) or not recorded:
        return f"its summary.json records no series file with its hashes: {again}"
    path = Path(found["series"])
    shown = one_line(path)[:200]
    try:
        if path.is_symlink():
            return (
                f"its series {shown} is a symbolic link, which the leaderboard does not follow: "
                f"put the series file itself there and {again}"
            )
        if not path.is_file():
            return (
                f"its series {shown} is not on this machine, and nothing of the folder is "
                "believed without grading it: put the series there, or grade it with "
                "tissuebench compare on this machine"
            )
        stem = path.name.split(".")[0]
        for p in path.parent.iterdir():
            if p.name.startswith((f"{stem}.", f"{stem}_")) and p.is_symlink():
                return (
                    f"its series' file {one_line(p)[:200]} is a symbolic link, which the "
                    f"leaderboard does not follow: put the file itself there and {again}"
                )
        now = series_files(path)
    except OSError as exc:
        return f"its series {shown} cannot be read ({type(exc).__name__}: {one_line(exc)[:120]})"
    if now != recorded:
        changed = sorted(
            n for n in {*now, *recorded} if now.get(n) != recorded.get(n) and isinstance(n, str)
        )
        named = ", ".join(one_line(n)[:60] for n in changed[:3]) + (
            f" and {len(changed) - 3} more" if len(changed) > 3 else ""
        )
        return (
            f"its series {shown} is not the one compare graded ({named} changed, added or gone "
            f"since: the hashes summary.json records differ): {again}"
        )
    found["series_hash"] = series_hash(now)
    return None


def edited(folder: Path) -> str | None:
    """Why a compare folder is not as compare wrote it (None: it is): a file of it changed
    since compare wrote it (its manifest, manifest.MANIFEST, holds another hash: compare itself
    refuses such a folder), or no manifest to check it against. A file added beside them
    changes nothing read and is let be. The manifest is a guard against accidents (a file
    edited by hand, a copy cut short), not a signature: anyone can compute it again, so the
    leaderboard takes no number from the folder and grades its series itself."""
    found = changes(folder)
    again = "move the folder away and grade the run again with tissuebench compare"
    if found is None:
        return f"it has no manifest of compare's ({MANIFEST}) to check its numbers against: {again}"
    modified = found[1]
    if modified:
        more = f" and {len(modified) - 1} more" if len(modified) > 1 else ""
        return (
            f"its {one_line(modified[0])[:80]}{more} was changed since tissuebench wrote it "
            f"(its manifest {MANIFEST} holds another hash), so its numbers are not compare's: "
            + again
        )
    return None


def candidate_of(summary: dict, folder: Path | None = None) -> dict:
    """The series file and field a compare summary records as its candidate ({} when it names
    none): {"series": path, "series_field": field or None}. With the compare `folder`, the
    path is one found from any working folder (grading.candidate_file: an older compare's
    relative path is taken from its inputs or its folder)."""
    cand = summary.get("candidate")
    file = cand.get("file") if isinstance(cand, dict) else None
    if not isinstance(file, str) or not file:
        return {}
    if folder is not None:
        from tissuebench.workflows.compare.grading import candidate_file

        file = candidate_file(cast("CompareSummary", summary), folder) or file
    assert isinstance(cand, dict)  # file came from it
    field, model = cand.get("field"), cand.get("model")  # model: as its user stated it
    return {
        "series": file,
        "series_field": field if isinstance(field, str) else None,
        "model": model if isinstance(model, str) else None,
    }


def model_problem(summary: dict) -> str | None:
    """Why a compare summary's stated candidate model cannot be taken (None: it states none,
    or one of solvers.MODELS)."""
    from tissuebench.solvers.models import MODELS

    cand = summary.get("candidate")
    model = cand.get("model") if isinstance(cand, dict) else None
    if model is None or (isinstance(model, str) and model in MODELS):
        return None
    return f"its candidate's model {one_line(repr(model))[:40]} is not one of {', '.join(MODELS)}"


def user_force(summary: dict) -> str | None:
    """The needle force file that a user's compare graded (--needle-force, a contact case),
    where it is still the file compare hashed (its inputs' sha256); None otherwise (the row
    then has no force error, and says so)."""
    inputs = summary.get("inputs")
    given = inputs.get("needle_force") if isinstance(inputs, dict) else None
    if not isinstance(given, dict) or not isinstance(given.get("file"), str):
        return None
    path = Path(given["file"])
    try:
        same = path.is_file() and file_hash(path) == given.get("sha256")
    except OSError:
        same = False
    return str(path) if same else None
