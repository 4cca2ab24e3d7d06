"""The leaderboard grades, it does not believe (issue 45, items 1 to 4, 6, 7 and 11): a user's
row's numbers come from its series, graded again at leaderboard time against the case's
reference and its truth, never from its folder's summary.json, whose numbers anyone can write
and whose manifest anyone can compute again. A forged summary (E_i 1e-15 against the truth, the
manifest sealed again as the project seals it) ranks where its series ranks; a summary.json
that is a symbolic link, a folder holding one, and a series changed since compare graded it
are left out with one line each; a frontier.csv row with a negative, NaN or infinite error or
cost, or a text too long, is left out with one line, and so is a row of a frontier.csv cut
mid-row (no traceback); a label is limited at compare time, said why in one line; two
users' folders with the same label are told apart by their folder's name.

The case: the rod to T = 5 h (5 steps), its reference run here as `tissuebench export` runs it
(about a second), and a synthetic truth (an affine field on a grid of the rod's body, at the
case's t_i = i h: nothing is computed for it); the users' series are affine fields on meshes
of that body, each graded by compare against the exported reference."""

import argparse
import csv
import html
import json
import math
import re
import shutil
import subprocess
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import tissuebench
from test_crossmesh import MESHES, write_xdmf
from test_truth_grading import affine, candidate, make_truth

from tissuebench.meshes import get_entry
from tissuebench.metrics.compare import summarize
from tissuebench.metrics.truth import grade_truth
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.grading import GradingError, compare
from tissuebench.workflows.compare.posing import export, reference_path
from tissuebench.workflows.io.manifest import seal
from tissuebench.workflows.io.output import write_owned
from tissuebench.workflows.io.series import read_series
from tissuebench.workflows.leaderboard import build, grading, page, record
from tissuebench.workflows.leaderboard import frontier_rows as frontier_module
from tissuebench.workflows.leaderboard import rows as ranking
from tissuebench.workflows.leaderboard import users as user_folders
from tissuebench.workflows.leaderboard.row import md
from tissuebench.workflows.leaderboard.rows import Board, Row, error_keys

pytestmark = pytest.mark.serial  # rank 0's files, the command run on them

H = get_entry("rod").dt
STEPS = 5
TIMES = np.arange(STEPS + 1) * H
BOARD = Board("rod-tiny", "rod", "MP3", "linear", simulators=(), end_time=STEPS * H,
              truth="rod", description="the rod to 5 h")  # fmt: skip
U = affine(3)
# the users' series: affine fields (of the truth's field) on meshes of the rod's body
SERIES = {
    "close": ("tetrahedra", lambda X, t: 1.01 * U(X, t)),
    "far": ("moved tetrahedra", lambda X, t: 1.3 * U(X, t)),
    "other": ("coarser hexahedra", lambda X, t: 1.1 * U(X, t)),
}
E_I = "interior_error"


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    """The case's exported reference, the users' series and a record of one row of ours (the
    reference, as a rerun records it): {name: path}, the record's folder and the truth."""
    tmp = tmp_path_factory.mktemp("trust-rows")
    export("rod", "json", tmp / "rod.json", mesh_size=3, options={},
           material=get_material("MP3"), model="linear", h=H, steps=STEPS,
           comm=MPI.COMM_SELF, log=lambda line: None)  # fmt: skip
    files = {"reference": reference_path(tmp / "rod.json")}
    for name, (mesh, field) in SERIES.items():
        files[name] = tmp / "series" / name / f"{name}.xdmf"
        files[name].parent.mkdir(parents=True)
        write_xdmf(files[name], MESHES[3][mesh], candidate(MESHES[3][mesh], field, TIMES))
    errors = dict.fromkeys(error_keys(), 0.0)
    truth = dict.fromkeys(ranking.TRUTH_KEYS, 0.5)  # far from every user's: theirs rank first
    ours = Row(BOARD.name, "implicit", "tissuebench", "ours", "reference", 336, "ok", None,
               errors, 0.1, STEPS * H, "this session", reference=True, truth=truth)  # fmt: skip
    board = Board(**{**BOARD.__dict__, "truth_band": 1e-9, "session": "then"})
    doc = record.record_of([board], {BOARD.name: [ours]}, {BOARD.name: []})
    base = tmp / "base"
    write_owned(base / record.RECORD, lambda p: p.write_text(json.dumps(doc)))
    return files, base, make_truth(MESHES[3]["reference"], U, times=TIMES)


def results(case, tmp_path) -> Path:
    out = tmp_path / "results"
    shutil.copytree(case[1], out)
    return out


def users(out: Path) -> Path:
    return out / "leaderboard" / BOARD.name / "user"


def graded_by_compare(case, name: str, folder: Path, label: str, wall: float) -> dict:
    """compare of the series `name` against the case's exported reference into folder: its
    summary.json."""
    files = case[0]
    compare(files["reference"], files[name], folder, label=label, wall_time=wall,
            comm=MPI.COMM_SELF)  # fmt: skip
    return json.loads((folder / "summary.json").read_text())


def forge(folder: Path, change) -> None:
    """Change the folder's summary.json and seal it again, as anyone can (manifest.seal: the
    manifest the project writes)."""
    summary = json.loads((folder / "summary.json").read_text())
    change(summary)
    (folder / "summary.json").write_text(json.dumps(summary))
    seal(folder)


def claim_perfect(summary: dict) -> None:
    """E_i 1e-15 (and every other metric) against the truth of the case."""
    summary["reference"]["fingerprint"].update(source="truth", truth=BOARD.truth)
    (run,) = summary["runs"].values()
    run.update(dict.fromkeys(error_keys(), 1e-15))


def render(out: Path, truth, monkeypatch, committed: bool = False) -> int:
    """`tissuebench leaderboard --out OUT` on the one case, its truth the synthetic one; the
    frontier's rows those committed in the clone made by committed_frontier where `committed`,
    else none (the project's own are graded against the real truth, not this one)."""
    from tissuebench.solvers.truth import store

    monkeypatch.setattr(build, "BOARDS", [BOARD])
    if not committed:
        monkeypatch.setattr(frontier_module, "committed_frontier", lambda warn=None, root=None: {})
    monkeypatch.setattr(store, "load_cached", lambda case, quick=False, comm=None: truth)
    args = argparse.Namespace(out=out, solver="direct", petsc="", force=False)
    return build.main(args)


def table(out: Path) -> dict[str, dict]:
    with open(out / "leaderboard.csv", newline="") as f:
        return {r["label"]: r for r in csv.DictReader(f)}


def ranks(out: Path) -> dict[str, str]:
    """{label: rank} in the page's Open division (any mesh), as a reader sees it."""
    text = (out / "leaderboard" / "index.html").read_text()
    opened = text.split("Open division")[1].split("</table>")[0]
    found = re.findall(r"<tr class=\"f[^\"]*\"[^>]*><td>([^<]*)</td><td>([^<]*)</td>", opened)
    return {html.unescape(label).removesuffix(" (the reference)"): rank for rank, label in found}


def against_truth(truth, path: Path) -> tuple[float, float]:
    g = grade_truth(truth, read_series(path), MPI.COMM_SELF, surface=False)
    peak, mean = summarize(g.curves[E_I])
    return peak, mean


def test_a_forged_summary_ranks_where_its_series_ranks(case, tmp_path, monkeypatch):
    """Two users: `honest` (its series 1 % off the truth's field) and `forged` (30 % off,
    its summary.json made to claim E_i 1e-15 against the truth, the manifest sealed again).
    Before: forged ranked #1 on the page with 1e-15. Now both rows carry the numbers of
    their series, graded here against the case's reference (compare's own numbers, to
    round-off) and against the truth, and rank by them: honest #1, forged #2. Rendered again
    from the record, nothing is graded again (the grades kept by the series' hash)."""
    files, _, truth = case
    out = results(case, tmp_path)
    honest = graded_by_compare(case, "close", users(out) / "honest", "honest", 2.0)
    before = graded_by_compare(case, "far", users(out) / "forged", "forged", 1.0)
    forge(users(out) / "forged", claim_perfect)
    assert render(out, truth, monkeypatch) == 0
    assert ranks(out)["honest"] == "1" and ranks(out)["forged"] == "2", ranks(out)
    rows = table(out)
    for label, series, summary in (("honest", "close", honest), ("forged", "far", before)):
        row, graded = rows[label], summary["runs"][label]
        assert row["status"] == "ok"
        for key in error_keys():  # against the case's reference: compare's numbers
            assert float(row[key]) == pytest.approx(graded[key], rel=1e-9), (label, key)
        peak, mean = against_truth(truth, files[series])
        assert float(row[f"truth_{E_I}_max"]) == pytest.approx(peak, rel=1e-12)
        assert float(row[f"truth_{E_I}_mean"]) == pytest.approx(mean, rel=1e-12)
    assert float(rows["forged"][f"truth_{E_I}_mean"]) > 1e-6  # not the 1e-15 it claimed
    md = (out / "leaderboard.md").read_text()
    assert md.index("honest") < md.index("forged")

    def graded_again(*args, **kwargs):
        raise AssertionError("a row of the record was graded again")

    written = {n: (out / n).read_bytes() for n in record.OWNED}
    monkeypatch.setattr(grading, "grade_row_reference", graded_again)
    monkeypatch.setattr(grading, "grade_row_truth", graded_again)
    assert render(out, truth, monkeypatch) == 0
    assert {n: (out / n).read_bytes() for n in record.OWNED} == written


def test_the_same_label_is_told_apart_and_one_series_graded_once(case, tmp_path, monkeypatch):
    """Three folders label their run `my-solver`: alice's and bob's of one series, carol's of
    another. On the page, in leaderboard.md and .csv they are `my-solver (alice)`, `(bob)`,
    `(carol)`, each with its own colour and legend entry; the one series is graded once (by
    its content hash), and both its rows get its numbers."""
    _, _, truth = case
    out = results(case, tmp_path)
    for name, series in (("alice", "close"), ("bob", "close"), ("carol", "other")):
        graded_by_compare(case, series, users(out) / name, "my-solver", 1.0)
    graded, grade = [], grading.grade_row_reference

    def counted(board, row, caches):
        graded.append(row.label)
        return grade(board, row, caches)

    monkeypatch.setattr(grading, "grade_row_reference", counted)
    assert render(out, truth, monkeypatch) == 0
    labels = [f"my-solver ({name})" for name in ("alice", "bob", "carol")]
    rows = table(out)
    assert set(labels) <= set(rows) and "my-solver" not in rows
    assert len(graded) == 2  # alice's series and carol's: bob's is alice's
    for key in error_keys() + [f"truth_{k}" for k in ranking.TRUTH_KEYS]:
        assert rows[labels[0]][key] == rows[labels[1]][key] != ""
    assert rows[labels[0]][f"truth_{E_I}_mean"] != rows[labels[2]][f"truth_{E_I}_mean"]
    text = (out / "leaderboard" / "index.html").read_text()
    legend = re.findall(r'<b style="color:([^"]+)">&#9733; ([^<]+)</b>', text)
    assert sorted(label for _, label in legend) == labels
    assert len({colour for colour, _ in legend}) == 3
    md = (out / "leaderboard.md").read_text()
    assert all(label in md for label in labels)


def test_two_folders_of_one_label_are_two_entries_each_tip_naming_its_folder(
    case, tmp_path, monkeypatch
):
    """Issue 60: two users' folders whose names begin with the same 40 characters and more,
    each labelling its run `my-solver`: two rows, two legend entries in two colours, each
    point's tooltip naming its folder; leaderboard.md has both labels."""
    _, _, truth = case
    out = results(case, tmp_path)
    common = "a-folder-name-longer-than-forty-characters-from-"
    names = [common + "alice", common + "bob"]
    for name, series in zip(names, ("close", "other"), strict=True):
        graded_by_compare(case, series, users(out) / name, "my-solver", 1.0)
    assert render(out, case[2], monkeypatch) == 0
    rows = {label: r for label, r in table(out).items() if label.startswith("my-solver")}
    assert len(rows) == 2 and "my-solver" not in rows
    text = (out / "leaderboard" / "index.html").read_text()
    legend = re.findall(r'<b style="color:([^"]+)">&#9733; ([^<]+)</b>', text)
    assert sorted(html.unescape(label) for _, label in legend) == sorted(rows)
    assert len({colour for colour, _ in legend}) == 2
    tips = {
        html.unescape(label): json.loads(html.unescape(tip))
        for label, tip in re.findall(
            r'class="pt f user"[^>]*data-label="([^"]*)"[^>]*data-tip="([^"]*)"', text
        )
    }
    assert sorted(tips) == sorted(rows)
    folders = sorted(line for tip in tips.values() for line in tip if line.startswith("folder: "))
    assert folders == [f"folder: {name}" for name in sorted(names)]
    text = (out / "leaderboard.md").read_text()
    assert all(md(label) in text for label in rows)


def test_a_symbolic_link_in_a_user_folder_is_refused(case, tmp_path):
    """summary.json replaced by a link to a forged file outside the folder (the manifest
    untouched); a folder that is itself a link; a series that is a link: each left out with
    one line that names the link; the honest folder beside them is read."""
    out = results(case, tmp_path)
    graded_by_compare(case, "close", users(out) / "honest", "honest", 1.0)
    linked = users(out) / "linked"
    graded_by_compare(case, "far", linked, "linked", 1.0)
    forged = tmp_path / "forged-summary.json"
    summary = json.loads((linked / "summary.json").read_text())
    claim_perfect(summary)
    forged.write_text(json.dumps(summary))
    (linked / "summary.json").unlink()
    (linked / "summary.json").symlink_to(forged)
    (users(out) / "elsewhere").symlink_to(users(out) / "honest", target_is_directory=True)
    series = tmp_path / "link" / "far.xdmf"
    graded_by_compare(case, "other", users(out) / "via-link", "via-link", 1.0)
    summary = json.loads((users(out) / "via-link" / "summary.json").read_text())
    series.parent.mkdir()
    series.symlink_to(summary["candidate"]["file"])
    forge(users(out) / "via-link", lambda s: s["candidate"].update(file=str(series)))
    rows, skipped = ranking.user_rows(BOARD, users(out), [BOARD])
    assert [r.label for r in rows] == ["honest"]
    assert len(skipped) == 3 and all("\n" not in line for line in skipped), skipped
    said = {line.split(": ")[0]: line for line in skipped}
    assert said[str(linked)].startswith(
        f"{linked}: left out: its summary.json is a symbolic link (to {forged})"
    )
    assert "which the leaderboard does not follow" in said[str(linked)]
    assert said[str(users(out) / "elsewhere")].startswith(
        f"{users(out) / 'elsewhere'}: left out: it is a symbolic link"
    )
    assert f"its series {series} is a symbolic link" in said[str(users(out) / "via-link")]


def test_a_series_changed_since_compare_is_left_out(case, tmp_path, monkeypatch, capsys):
    """A series rewritten after compare graded it (the hashes summary.json records are not its
    files' now: graded, it would be another run than compare's), and one that is gone: each
    folder left out with one line on stderr that says so; the folder beside them is read."""
    files, _, truth = case
    out = results(case, tmp_path)
    mesh = MESHES[3]["tetrahedra"]
    for name in ("changed", "gone", "kept"):
        series = tmp_path / name / "mine.xdmf"
        series.parent.mkdir()
        write_xdmf(series, mesh, candidate(mesh, SERIES["close"][1], TIMES))
        compare(files["reference"], series, users(out) / name, label=name, wall_time=1.0,
                comm=MPI.COMM_SELF)  # fmt: skip
    write_xdmf(tmp_path / "changed" / "mine.xdmf", mesh, candidate(mesh, SERIES["far"][1], TIMES))
    for path in (tmp_path / "gone").iterdir():
        path.unlink()
    capsys.readouterr()
    assert render(out, truth, monkeypatch) == 0
    err = capsys.readouterr().err.strip().splitlines()
    changed = [line for line in err if f"{users(out) / 'changed'}: left out" in line]
    gone = [line for line in err if f"{users(out) / 'gone'}: left out" in line]
    assert len(changed) == 1 and len(gone) == 1 and len(err) == 2, err
    assert (
        f"its series {tmp_path / 'changed' / 'mine.xdmf'} is not the one compare graded ("
        in (changed[0])
    )
    assert "mine.h5" in changed[0] and "grade the run again with tissuebench compare" in changed[0]
    assert "is not on this machine" in gone[0]
    assert "kept" in table(out) and not {"changed", "gone"} & set(table(out))


# --- the frontier's rows -----------------------------------------------------------------------


def frontier_rows(**bad) -> list[dict]:
    """Rows of a frontier.csv of the rod (text): a good one, then one per entry of `bad`
    (the good one's cells changed so)."""
    good = {
        "case": "rod", "benchmark": "rod", "material": "MP3", "cell": "hexahedron",
        "scheme": "standard", "algorithm": "implicit", "requested": "1", "substeps": "1",
        "mesh_size": "2", "dofs": "135", "critical_dt_s": "", "status": "ok",
        "diverged_time": "", "setup_s": "0.01", "loop_s": "0.03", "cost": "0.003",
        "interior_error_mean": "0.0005", "interior_error_max": "0.0008",
        "relative_error_mean": "0.09", "relative_error_max": "0.16",
        "truth_own_error": "4.7e-06", "truth_size": "0.006", "timings": "",
    }  # fmt: skip
    return [good] + [{**good, "scheme": name, **cells} for name, cells in bad.items()]


def write_frontier(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as f:
        out = csv.DictWriter(f, list(rows[0]))
        out.writeheader()
        out.writerows(rows)


def committed_frontier(where: Path, monkeypatch, rows: list[dict]) -> Path:
    """A clone (a git repository in `where`) whose HEAD commits `rows` as its
    results/frontier/frontier.csv, made the clone tissuebench runs from
    (frontier_rows.clone_root): the frontier rows the leaderboard shows. Its root."""
    if shutil.which("git") is None:
        pytest.skip("needs git: the leaderboard reads the committed frontier from it")
    clone = where / "clone"
    write_frontier(clone / frontier_module.COMMITTED, rows)
    git = ["git", "-C", str(clone), "-c", "user.name=test", "-c", "user.email=test@localhost"]
    for words in (["init", "-q"], ["add", "results"], ["commit", "-q", "-m", "frontier"]):
        subprocess.run([*git, "-c", "commit.gpgsign=false", *words], check=True)
    monkeypatch.setattr(frontier_module, "clone_root", lambda: clone)
    return clone


BAD_FRONTIER = {  # scheme (the row's name) -> its bad cells, what the line says
    "negative": ({"interior_error_mean": "-1"}, "interior_error_mean '-1' is not a finite"),
    "nan": ({"interior_error_max": "nan"}, "interior_error_max 'nan' is not a finite number"),
    "infinite": ({"cost": "inf"}, "cost 'inf' is not a finite number >= 0"),
    "no-error": ({"interior_error_mean": ""}, "(the run finished: it has one)"),
    "no-dofs": ({"dofs": "many"}, "dofs 'many' is not a whole number >= 1"),
}


def test_frontier_rows_are_checked_before_they_rank(tmp_path, case, monkeypatch, capsys):
    """A frontier.csv row of the rod with E_i -1 m^3 (ranked #1 before), NaN, an infinite
    cost, no error though it finished, or text for its dofs: each left out with one line
    naming its row and why; a scheme of 100,000 characters too. On the page, the good row
    ranks and none of the bad ones is there."""
    path = tmp_path / "frontier.csv"
    bad = {name: cells for name, (cells, _) in BAD_FRONTIER.items()}
    long = "x" * 100_000
    write_frontier(path, frontier_rows(**bad) + [{**frontier_rows()[0], "scheme": long}])
    lines = []
    found = page.read_frontier(path, lines.append)
    assert [f["scheme"] for f in found["rod"]] == ["standard"]
    assert len(lines) == len(BAD_FRONTIER) + 1 and all("\n" not in x for x in lines)
    for k, (name, (_, why)) in enumerate(BAD_FRONTIER.items(), start=3):  # row 2: the good one
        assert lines[k - 3].startswith(f"{path}, row {k}: not a run of the frontier (")
        assert why in lines[k - 3], lines[k - 3]
    assert "scheme 'xxxx" in lines[-1] and "is not printable text of 1 to 80" in lines[-1]
    assert len(lines[-1]) < 400
    # the leaderboard: the committed frontier's bad rows said on stderr, the good one ranked
    out = results(case, tmp_path)
    committed_frontier(tmp_path, monkeypatch, frontier_rows(**bad))
    capsys.readouterr()
    assert render(out, case[2], monkeypatch, committed=True) == 0
    err = capsys.readouterr().err
    assert sum("not a run of the frontier" in line for line in err.splitlines()) == len(bad)
    text = (out / "leaderboard" / "index.html").read_text()
    assert "standard implicit" in text and not any(f">{name} implicit" in text for name in bad)


def test_a_frontier_row_planted_by_hand_is_never_ranked(tmp_path, case, monkeypatch, capsys):
    """Issue 60: a row of E_i 1e-15 added by hand to OUT/frontier/frontier.csv, and another to
    the clone's own results/frontier/frontier.csv (its working copy, not committed), rank
    first nowhere: the page and leaderboard.csv have the committed rows only, and each of the
    two files is said in one line; the committed rows are there as committed."""
    perfect = {"interior_error_mean": "1e-15", "interior_error_max": "1e-15"}
    clone = committed_frontier(tmp_path, monkeypatch, frontier_rows(anp={}))
    out = results(case, tmp_path)
    write_frontier(out / "frontier" / "frontier.csv", frontier_rows(planted=perfect))
    write_frontier(clone / frontier_module.COMMITTED, frontier_rows(anp={}, edited=perfect))
    capsys.readouterr()
    assert render(out, case[2], monkeypatch, committed=True) == 0
    err = capsys.readouterr().err
    committed = {"standard implicit, hexahedron n=2", "anp implicit, hexahedron n=2"}
    ranked = ranks(out)
    assert committed <= set(ranked) and committed <= set(table(out))
    assert not any(s in label for label in [*ranked, *table(out)] for s in ("planted", "edited"))
    assert ranked["implicit"] == "3"  # ours (E_i 0.5 against this truth) after the two runs
    assert f"{out / 'frontier' / 'frontier.csv'}: not read" in err
    assert f"{clone / frontier_module.COMMITTED} is not as committed" in err


def test_the_committed_frontier_is_the_clones_as_git_holds_it():
    """Without a clone of its own, the leaderboard's frontier rows are those of the project's
    results/frontier/frontier.csv at git's HEAD (as the working copy reads where it is
    unchanged)."""
    root = frontier_module.clone_root()
    if shutil.which("git") is None or not (root / ".git").exists():
        pytest.skip("needs the project's git checkout")
    shown = subprocess.run(
        ["git", "-C", str(root), "show", f"HEAD:{frontier_module.COMMITTED}"],
        capture_output=True,
        check=True,
    ).stdout.decode()
    lines = []
    found = frontier_module.committed_frontier(lines.append)
    assert found == frontier_module.frontier_of(shown, "HEAD")
    assert sum(len(v) for v in found.values()) == len(shown.splitlines()) - 1 > 0
    if (root / frontier_module.COMMITTED).read_text() == shown:
        assert lines == []


def test_a_frontier_cut_mid_row_is_one_line(tmp_path):
    """frontier.csv cut inside its last row (as a kill or a full disk leaves a file written in
    place; a TypeError traceback before): the leaderboard leaves that row out in one line and
    draws the whole rows; a row short of cells in the middle is one line too."""
    path = tmp_path / "frontier.csv"
    write_frontier(path, frontier_rows(a={}, b={}))
    text = path.read_text()
    path.write_text(text[: text.rindex("hexahedron") + 4])  # cut inside the third row (b)
    lines = []
    found = page.read_frontier(path, lines.append)
    assert [f["scheme"] for f in found["rod"]] == ["standard", "a"]
    assert lines == [
        f"{path}, row 4: cut mid-row (the file's last line is not ended), left out: "
        "`tissuebench frontier` runs it again"
    ]
    whole = text.splitlines(keepends=True)
    path.write_text("".join(whole[:2]) + whole[2][: whole[2].index("hexahedron") + 10] + "\n")
    lines.clear()
    assert page.read_frontier(path, lines.append) == {"rod": [frontier_row_of(whole[1])]}
    assert len(lines) == 1 and "row 3: not a run of the frontier (its number of cells" in lines[0]


def frontier_row_of(line: str) -> dict:
    """A frontier.csv line of frontier_rows as the page takes it."""
    cells = next(csv.reader([line]))
    return page.frontier_row(dict(zip(frontier_rows()[0], cells, strict=True)))


# --- labels -------------------------------------------------------------------------------------


def test_a_label_is_limited_at_compare_time(case, tmp_path):
    """`--label` of 100,000 characters, of 65, with a tab, or with a leading space, and a
    candidate whose file name (the default label) holds a newline: each refused in one line
    that says why, before anything is read or written; 64 printable characters are taken."""
    files = case[0]
    cases = {
        "x" * 100_000: "is 100,000 characters long (at most 64)",
        "y" * 65: "is 65 characters long (at most 64)",
        "a\tb": "has characters that are not printable",
        " mine": "has leading or trailing spaces",
    }
    for label, why in cases.items():
        with pytest.raises(GradingError) as caught:
            compare(files["reference"], files["close"], tmp_path / "out", label=label,
                    comm=MPI.COMM_SELF)  # fmt: skip
        line = str(caught.value)
        assert "\n" not in line and len(line) < 400 and why in line, line
        assert line.startswith("--label must be printable text of 1 to 64 characters")
    odd = tmp_path / "my\nrun.xdmf"
    mesh, field = SERIES["close"]
    write_xdmf(odd, MESHES[3][mesh], candidate(MESHES[3][mesh], field, TIMES))
    with pytest.raises(GradingError, match="the candidate's file name gives the label") as caught:
        compare(files["reference"], odd, tmp_path / "out", comm=MPI.COMM_SELF)
    assert "has characters that are not printable" in str(caught.value)
    assert "name the run with --label" in str(caught.value)
    assert not (tmp_path / "out").exists()
    compare(files["reference"], odd, tmp_path / "out", label="z" * 64, comm=MPI.COMM_SELF)
    done = tissuebench("compare", files["reference"], files["close"], "--out", tmp_path / "cli",
                       "--label", "x" * 100_000)  # fmt: skip
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "is 100,000 characters long (at most 64)" in done.stderr
    assert len(done.stderr) < 500 and not (tmp_path / "cli").exists()
    # the leaderboard's rule is compare's
    from tissuebench.workflows.compare import grading as compare_grading

    assert ranking.MAX_LABEL == compare_grading.MAX_LABEL


def test_a_record_row_with_an_infinite_or_overlong_value_is_refused(case, tmp_path, monkeypatch):
    """The record's rows are checked before anything ranks: an infinite wall time or error,
    a label of 300 characters, or one with a right-to-left override, each refuse the record in
    one line naming the row."""
    for k, (field, value, said) in enumerate((
        ("wall_time_s", math.inf, "wall_time_s inf is not a finite number"),
        ("errors", {**dict.fromkeys(error_keys(), 0.0), E_I + "_mean": math.inf},
         "errors.interior_error_mean inf is not a finite number"),
        ("label", "x" * 300, "is not printable text of 1 to 200 characters"),
        ("label", "a\u202eb", "is not printable text of 1 to 200 characters"),
    )):  # fmt: skip
        out = results(case, tmp_path / str(k))
        doc = json.loads((out / record.RECORD).read_text())
        doc["cases"][0]["rows"][0][field] = value
        write_owned(out / record.RECORD, lambda p, d=doc: p.write_text(json.dumps(d)))
        with pytest.raises(record.LeaderboardError) as caught:
            render(out, case[2], monkeypatch)
        line = str(caught.value)
        assert "\n" not in line and said in line and "case rod-tiny, row 1" in line, line
        assert len(line) < 600


def test_the_manifest_is_said_to_be_no_signature():
    """Where the README and the leaderboard describe the manifest, they say that it guards
    against accidents and proves nothing about the numbers."""
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    assert "not a signature" in " ".join(readme.split())
    assert "not a signature" in " ".join(ranking.__doc__.split())
    assert "no signature" in " ".join(user_folders.__doc__.split())
