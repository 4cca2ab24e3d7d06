"""A newcomer's way onto the leaderboard (issue 36): the truth step named where it is missing,
every folder under OUT/leaderboard that is not read named in one line with what to do, a
folder graded for another case told which case it belongs to (not a Python dict), and which
export options pose which case (`tissuebench export` says it; the README's table is
ranking.BOARDS). The compare folders are summary.json files as compare writes them, for the
cases' own inputs; nothing is computed."""

import json
import re
from dataclasses import replace
from pathlib import Path

from mpi4py import MPI

import pytest
from helpers import tissuebench

from tissuebench.solvers.truth import store
from tissuebench.workflows.io.manifest import seal
from tissuebench.workflows.leaderboard import build as leaderboard
from tissuebench.workflows.leaderboard import rows as ranking
from tissuebench.workflows.leaderboard.rows import BOARDS, board_case, error_keys, export_options

ROOT = Path(__file__).resolve().parents[1]
COMM = MPI.COMM_WORLD
CASES = {b.name: b for b in BOARDS}


def compare_summary(board: ranking.Board, label: str = "mine", series: Path | None = None) -> dict:
    """A compare summary.json of a run graded against the reference `tissuebench export`
    writes for the board's case; its candidate `series` (a file, recorded with its hashes as
    compare records them; none without it)."""
    from tissuebench.meshes import get_entry
    from tissuebench.workflows.compare.grading import series_files

    case = board_case(board)
    size = board.mesh_size or get_entry(board.benchmark).mesh_size
    return {
        "kind": "compare",
        "h": case["h"],
        "steps": case["steps"],
        "end_time": case["end_time"],
        "reference": {
            "file": "rod.reference.xdmf",
            "fingerprint": {
                "source": "export",
                "truth": None,
                "benchmark": board.benchmark,
                "case": None,
                "options": dict(board.options),
                "material": board.material,
                "model": board.model,
                "mesh_size": size,
                "nodes": case["nodes"],
                "dimension": case["gdim"],
            },
        },
        "candidate": {"file": str(series) if series else "mine.xdmf", "field": None},
        "inputs": {
            "candidate": {
                "file": str(series) if series else "mine.xdmf",
                "files": series_files(series) if series else {},
            }
        },
        "runs": {label: {"status": "ok", "wall_time_s": 2.0, **dict.fromkeys(error_keys(), 1e-4)}},
    }


def compare_folder(folder: Path, board: ranking.Board) -> Path:
    """A compare folder as compare writes it, its candidate series a file in it (not a
    readable series: what is read here is its hash)."""
    folder.mkdir(parents=True)
    series = folder / "mine.xdmf"
    series.write_text("<Xdmf/>\n")
    (folder / "summary.json").write_text(json.dumps(compare_summary(board, series=series)))
    seal(folder)  # as compare writes it: with its manifest
    return folder


@pytest.mark.serial
def test_every_folder_not_read_is_named_in_one_line(tmp_path, capsys):
    board = tmp_path / "leaderboard"
    rod = CASES["rod-MP3"]
    typo = compare_folder(board / "rod" / "user" / "mine", rod)  # a misspelt case
    loose = compare_folder(board / "rod-MP3" / "mine", rod)  # not under user/
    stray = compare_folder(board / "mine-s3", CASES["rod-MP3-s3"])  # a compare folder alone
    (board / "notes").mkdir()  # a folder of nothing read
    compare_folder(board / "rod-MP3" / "user" / "good", rod)  # read: not named
    for ours in ("ours", "ours-tetrahedron-grid", "calculix", ".tissuebench-partial-x"):
        (board / "rod-MP3" / ours).mkdir()
    (board / "rod-MP3.png").write_bytes(b"")
    lines = ranking.misplaced(board, BOARDS)
    assert len(lines) == 4, lines
    by = {line.split(": ")[0]: line for line in lines}
    assert set(by) == {str(typo), str(loose), str(stray), str(board / "notes")}
    assert all("\n" not in line for line in lines)
    cases = ", ".join(CASES)
    assert by[str(typo)] == (
        f"{typo}: 'rod' is not a leaderboard case (cases: {cases}), not read: it belongs to "
        f"rod-MP3: move it to {board / 'rod-MP3' / 'user' / 'mine'}"
    )
    assert by[str(loose)] == (
        f"{loose}: a compare folder outside rod-MP3/user/, not read: move it to "
        f"{board / 'rod-MP3' / 'user' / 'mine'} (it was graded for rod-MP3)"
    )
    assert f"it belongs to rod-MP3-s3: move it to {board / 'rod-MP3-s3' / 'user'}" in by[str(stray)]
    assert "not a leaderboard case" in by[str(board / "notes")]
    assert f"put each compare folder under {board}/CASE/user/NAME" in by[str(board / "notes")]
    # the leaderboard says them on stderr, with the user folders it reads
    users, left_out = leaderboard.read_users(tmp_path, BOARDS)
    assert [r.label for r in users["rod-MP3"]] == ["mine"]
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"tissuebench leaderboard: {line}" for line in lines]


@pytest.mark.serial
def test_a_folder_of_another_case_is_told_which_case_it_belongs_to(tmp_path):
    """Before: "graded against rod MP3 neo-hookean, {'load_scale': 3.0}, 3D, 64 nodes, not this
    case (...)": a Python dict, and no case named."""
    user = tmp_path / "leaderboard" / "rod-MP3" / "user"
    compare_folder(user / "big", CASES["rod-MP3-s3"])
    compare_folder(user / "fine", CASES["rod-MP3-n6"])
    compare_folder(user / "alone", ranking.Board("x", "rod", "MP1", "linear", simulators=()))
    rows, skipped = ranking.user_rows(CASES["rod-MP3"], user, BOARDS)
    assert rows == [] and len(skipped) == 3
    line = {x.split(": ")[0]: x for x in skipped}
    big, fine, alone = (line[str(user / name)] for name in ("big", "fine", "alone"))
    assert not any("{" in x for x in skipped), skipped
    assert "graded against rod MP3 neo-hookean-barrier, load scale s = 3, 3D" in big
    assert big.endswith(
        f"it belongs to rod-MP3-s3: move it to {tmp_path / 'leaderboard/rod-MP3-s3/user/big'}, "
        "or compare against rod-MP3's reference"
    )
    assert "it belongs to rod-MP3-n6: move it to" in fine
    assert alone.endswith(
        "compare against rod-MP3's reference, or move the folder under its own case"
    )  # graded for no case of the leaderboard
    rows, skipped = ranking.user_rows(CASES["rod-MP3-s3"], user, BOARDS)  # its own case takes it
    assert [r.label for r in rows] == ["mine"] and len(skipped) == 2


@pytest.mark.serial
def test_a_missing_truth_names_the_command_that_computes_it(tmp_path, monkeypatch, capsys):
    """A user's row on rod-MP3 with no truth on this machine: its note and one line on stderr
    name `tissuebench truth rod` and its time; an unreadable cache entry is one more line
    naming the file, and the same note."""
    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))
    board = CASES["rod-MP3"]
    compare_folder(tmp_path / "leaderboard" / "rod-MP3" / "user" / "mine", board)
    out = tmp_path / "results"
    for corrupt in (False, True):
        if corrupt:
            path = store.cache_path("rod")
            path.parent.mkdir(parents=True)
            path.write_bytes(b"PK\x03\x04 not a whole zip file")
        users, _ = leaderboard.read_users(tmp_path, [board])
        capsys.readouterr()
        rows = {board.name: []}
        leaderboard.grade_users([board], rows, users, {}, out)
        (mine,) = rows[board.name]
        assert mine.truth == {} and mine.truth_note == (
            "the truth rod is not computed on this machine: `tissuebench truth rod` computes it "
            f"(about 65 s on one core, once), then `tissuebench leaderboard --out {out}` grades "
            "against it"
        )
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 + corrupt, err
        assert err[-1].startswith("tissuebench leaderboard: rod-MP3: 1 user row(s) not graded")
        assert "`tissuebench truth rod` computes it (about 65 s" in err[-1]
        if corrupt:
            assert str(store.cache_path("rod")) in err[0] and "cannot be read" in err[0]


# --- which options pose which case -------------------------------------------------------------


def test_the_readme_table_is_the_leaderboard_cases():
    """README.md's recipe lists every case folder with the export options that pose it and
    its truth, as ranking.BOARDS has them. A truth whose levels do not converge (one that
    solvers/truth/fallbacks.py falls back from: rod-nhb-s3) grades no run, so the case has
    none (issue 59, item 7c: the table gave rod-MP3-s3 the truth rod-nhb-s3)."""
    from tissuebench.solvers.truth.fallbacks import FALLBACKS

    diverging = {origin for origin, _ in FALLBACKS.values()}
    text = (ROOT / "README.md").read_text()
    recipe = text[text.index("### Grade your own simulator") :]
    table = re.findall(r"^\| `([^`]+)` \| `([^`]+)` \| (.+) \|$", recipe, flags=re.M)
    assert [(name, options) for name, options, _ in table] == [
        (b.name, export_options(b)) for b in BOARDS
    ]
    assert any(b.truth in diverging for b in BOARDS)
    for (_, _, truth), b in zip(table, BOARDS, strict=True):
        none = (
            "none (a point needle)"
            if b.benchmark == "block"
            else "none (its levels do not converge)"
        )
        if b.truth in diverging:
            none = (
                f"none (`{b.truth}`'s levels do not converge: graded against our implicit on "
                "your mesh)"
            )
        assert truth == (f"`{b.truth}`" if b.truth and b.truth not in diverging else none)
    assert "`tissuebench truth rod` computes it once" in recipe.split("\n## ")[0]


def test_each_cases_export_options_pose_it():
    from tissuebench.meshes import get_entry
    from tissuebench.solvers.materials import get_material

    for b in BOARDS:
        case = board_case(b)
        size = b.mesh_size or get_entry(b.benchmark).mesh_size
        material = get_material(b.material)
        posed = (b.benchmark, material, b.model, dict(b.options), size, case["h"], case["steps"])
        assert ranking.posed_board(*posed) is b
        sizes = {o.mesh_size or get_entry(o.benchmark).mesh_size for o in BOARDS}
        absent = max(sizes) + 1  # a size no case is posed at (theirs may be consecutive)
        assert ranking.posed_board(*posed[:4], absent, *posed[5:]) is None
        assert ranking.posed_board(*posed[:6], case["steps"] - 1) is None
        assert ranking.posed_board(*posed, plane="stress") is None
    stiffer = replace(get_material("MP3"), E=2 * get_material("MP3").E)
    assert ranking.posed_board("rod", stiffer, "linear", {}, 3, 1 / 30, 300) is None


@pytest.mark.serial
def test_export_says_its_case_and_the_compare_line(tmp_path, monkeypatch):
    from tissuebench.solvers.truth.store import cache_path

    monkeypatch.setenv("TISSUEBENCH_CACHE", str(tmp_path / "cache"))  # none cached
    done = tissuebench("export", "rod", "--material", "MP3", "--out", tmp_path / "rod.json")
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.strip().splitlines()
    assert lines[-2] == (
        "leaderboard case: rod-MP3; its truth rod is computed once by `tissuebench truth rod` "
        "(about 65 s on one core) before the leaderboard grades against it"
    )
    # issue 59: a truth already cached is not to be computed again
    cache_path("rod").parent.mkdir(parents=True, exist_ok=True)
    cache_path("rod").touch()
    again = tissuebench("export", "rod", "--material", "MP3", "--out", tmp_path / "again.json")
    assert again.stdout.strip().splitlines()[-2] == (
        "leaderboard case: rod-MP3; its truth rod is cached here, and the leaderboard grades "
        "against it"
    )
    assert lines[-1].startswith(
        f"next: run your simulator; tissuebench compare {tmp_path / 'rod.reference.xdmf'} "
        "YOUR_SERIES --out results/leaderboard/rod-MP3/user/NAME --label NAME --wall-time "
        "SECONDS; tissuebench leaderboard --out results (these two in the same folder, any: "
        "its results/ is yours, and the leaderboard renders the record of "
    )  # the clone's results/ (tests/test_recipe.py runs the lines from a folder outside it)
    # a relative --out: the reference's path in the line is absolute, to run from anywhere
    done = tissuebench("export", "rod", "--material", "MP3", "--end-time", "0.1", "--out",
                       "rel.json", cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"tissuebench compare {tmp_path / 'rel.reference.xdmf'} YOUR_SERIES" in done.stdout
    s3 = ["--material", "MP3", "--load-scale", "3", "--no-reference"]
    done = tissuebench("export", "rod", *s3, "--models", "neo-hookean-barrier", "--out",
                       tmp_path / "s3.json")  # fmt: skip
    assert done.returncode == 0 and done.stdout.splitlines()[-1].startswith(
        "leaderboard case: rod-MP3-s3; its truth case rod-nhb-s3 has levels that do not "
        "converge (`tissuebench truth` says why): the leaderboard grades a run against our "
        "implicit on your mesh only"
    )  # issue 59: not "computed once ... before the leaderboard grades against it"
    done = tissuebench("export", "rod", *s3, "--models", "neo-hookean", "--out",
                       tmp_path / "s3-nh.json")  # fmt: skip
    assert done.returncode == 0 and done.stdout.splitlines()[-1].startswith(
        "leaderboard case: none"
    )  # SPEC 8: the large rod's law is the barrier's
    done = tissuebench("export", "rod", "--mesh-size", "4", "--no-reference", "--out",
                       tmp_path / "rod4.json")  # fmt: skip
    last = done.stdout.strip().splitlines()[-1]
    assert done.returncode == 0 and last.startswith("leaderboard case: none (these options")
    assert "rod-MP3-n6: export rod --material MP3 --mesh-size 6" in last
    done = tissuebench("export", "rod", "--material", "MP3", "--procedure", "static",
                       "--no-reference", "--out", tmp_path / "static.json")  # fmt: skip
    assert done.returncode == 0 and done.stdout.strip().splitlines()[-1].startswith(
        "leaderboard case: none (a static export is graded against quasi-static"
    )
