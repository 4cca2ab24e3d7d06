"""The leaderboard across mesh sizes (issue 27, item 2): the cases of one series at several
mesh sizes, each run's E_i max against the truth and cost at each size, in one table."""

import pytest

from tissuebench.workflows.leaderboard.figures import size_series, size_table
from tissuebench.workflows.leaderboard.rows import Board, Row


def row(case: str, label: str, dofs: int, truth_max: float, wall: float, status="ok", **kw) -> Row:
    return Row(
        case, label, kw.get("source", "tissuebench"), "", "reference", dofs, status, None, {},
        wall, 10.0, "this session", reference=kw.get("reference", False),
        truth={"interior_error_max": truth_max},
    )  # fmt: skip


def test_size_table_lines_up_each_run_across_the_sizes():
    boards = [
        Board("fine", "rod", "MP3", "linear", mesh_size=6, truth="rod", sizes="rod"),
        Board("coarse", "rod", "MP3", "linear", truth="rod", sizes="rod"),  # default n = 3
        Board("other", "rod", "MP3", "linear", mesh_size=6, truth="rod"),  # in no series
    ]
    rows = {
        "coarse": [
            row("coarse", "implicit", 336, 3e-4, 0.5, reference=True),
            row("coarse", "explicit", 336, 4e-4, 0.2),
            row("coarse", "only-coarse", 336, 1e-4, 0.1),
            row("coarse", "mine", 336, 1e-9, 0.1, source="user"),
        ],
        "fine": [
            row("fine", "implicit", 1911, 8e-5, 2.0, reference=True),
            row("fine", "explicit", 1911, float("nan"), 0.3, status="diverged"),
        ],
    }
    (series,) = size_series(boards)
    assert [b.name for b in series] == ["coarse", "fine"]  # by mesh size, "other" apart
    lines = size_table(series, rows)
    assert "n = 3 (336 dofs)" in lines[0] and "n = 6 (1,911 dofs)" in lines[0]
    body = lines[2:]
    # the finest size's best E_i first; a run at one size only, and users' rows, left out
    assert [line.split(" | ")[0] for line in body] == ["| implicit", "| explicit"]
    assert body[0] == "| implicit | 0.0003 | 0.05 | 8e-05 | 0.2 |"
    assert body[1] == "| explicit | 0.0004 | 0.02 | diverged | 0.03 |"


def test_what_the_finest_mesh_changes_is_said_from_the_rows():
    """Each run's cost and error ratios from the coarsest to the finest size (exact from the
    rows), an error that fell less than 2x said to have stopped falling, and a run that
    finished coarse but not fine named; runs at one end only left out."""
    from tissuebench.workflows.leaderboard.figures import growth_lines

    boards = [
        Board("coarse", "rod", "MP3", "linear", truth="rod", sizes="rod"),
        Board("fine", "rod", "MP3", "linear", mesh_size=12, truth="rod", sizes="rod"),
    ]
    rows = {
        "coarse": [
            row("coarse", "implicit", 336, 4e-4, 0.1, reference=True),
            row("coarse", "stalled", 336, 1e-3, 1.0),
            row("coarse", "explicit", 336, 4e-4, 0.05),
            row("coarse", "grew", 336, 1e-3, 0.5),
        ],
        "fine": [
            row("fine", "implicit", 12675, 4e-5, 4.0, reference=True),
            row("fine", "stalled", 12675, 8e-4, 20.0),
            row("fine", "explicit", 12675, float("nan"), 0.2, status="diverged"),
            row("fine", "new", 12675, 1e-5, 1.0),
            row("fine", "grew", 12675, 1.25e-3, 5.0),
        ],
    }
    lines = growth_lines(size_series(boards)[0], rows)
    assert lines[0].startswith("What the finest mesh changes (n = 3 to 12;")
    said = [line for line in lines if line.startswith("- ")]
    assert said == [
        "- implicit: cost x40 (to 0.4 s per simulated s), E_i max /10",
        "- grew: cost x10 (to 0.5 s per simulated s), E_i max x1.25 (its error stopped "
        "falling: not its mesh's)",
        "- stalled: cost x20 (to 2 s per simulated s), E_i max /1.25 (its error stopped "
        "falling: not its mesh's)",
    ]
    assert "Finished at n = 3, not at n = 12: explicit." in lines


def test_the_rod_mp2_boards_are_the_linear_rods_at_three_sizes():
    """issue 32, item 1: rod-MP2 is a leaderboard case at the three rod sizes, graded against
    the truth rod-MP2, with the same simulators and variants as the MP3 rod at each size."""
    from tissuebench.workflows.leaderboard.rows import BOARDS

    cases = {b.name: b for b in BOARDS}
    mp2 = [cases[name] for name in ("rod-MP2", "rod-MP2-n6", "rod-MP2-n12")]
    mp3 = [cases[name] for name in ("rod-MP3", "rod-MP3-n6", "rod-MP3-n12")]
    assert [b.mesh_size or 3 for b in mp2] == [3, 6, 12]
    for b, same in zip(mp2, mp3, strict=True):
        assert (b.benchmark, b.material, b.model, b.models) == ("rod", "MP2", "linear", ("linear",))
        assert (b.truth, b.sizes, b.options) == ("rod-MP2", "rod-MP2", {})
        assert (b.simulators, b.variants, b.mesh_size) == (
            same.simulators,
            same.variants,
            same.mesh_size,
        )
    series = {s[0].sizes: [b.name for b in s] for s in size_series(BOARDS)}
    assert series["rod-MP2"] == ["rod-MP2", "rod-MP2-n6", "rod-MP2-n12"]


def test_the_contact_boards_are_three_cases_at_three_sizes():
    """SPEC 12 on the leaderboard: contact-MP1, contact-MP1-nhb and contact-MP2-s0.5 (the
    fallback of contact-MP2, whose truth does not converge), each a series of N = 10, 20 (the
    main board) and 40 with kappa = 10, graded against its truth; the nhb one runs every model
    of ours against implicit+neo-hookean-barrier and gives the simulators neo-hookean."""
    from tissuebench.workflows.leaderboard.rows import BOARDS

    series = {s[0].sizes: s for s in size_series(BOARDS)}
    assert "contact-MP2" not in series
    for case, scale in (("contact-MP1", 1.0), ("contact-MP1-nhb", 1.0), ("contact-MP2-s0.5", 0.5)):
        boards = series[case]
        assert [b.name for b in boards] == [f"{case}-n10", case, f"{case}-n40"]
        assert [b.mesh_size for b in boards] == [10, None, 40]  # 20: the benchmark's default
        for b in boards:
            assert (b.benchmark, b.options) == ("contact", {"kappa": 10.0, "load_scale": scale})
            assert b.truth == case
    nhb = series["contact-MP1-nhb"][1]
    assert (nhb.model, nhb.simulator_model, nhb.truth) == (
        "neo-hookean-barrier",
        "neo-hookean",
        "contact-MP1-nhb",
    )
    assert len(nhb.models) == 5
    mp2 = series["contact-MP2-s0.5"][1]
    assert mp2.material == "MP2" and "fallback for contact-MP2" in mp2.description


def test_a_registered_board_is_a_case_of_the_leaderboard_until_it_is_taken_out():
    """A benchmark defined elsewhere (tests/toy_benchmark.py) adds its leaderboard case with
    boards.register: in BOARDS wherever it was imported, so --rerun names it; a name taken is
    refused; unregister takes it out again."""
    from tissuebench.workflows.leaderboard import boards, build
    from tissuebench.workflows.leaderboard.record import LeaderboardError
    from tissuebench.workflows.leaderboard.rows import BOARDS

    before = [b.name for b in BOARDS]
    mine = Board("rod-MP3-mine", "rod", "MP3", "linear", simulators=(), truth="rod")
    boards.register(mine)
    try:
        assert [b.name for b in build.BOARDS] == [*before, mine.name]
        assert build.check_rerun([mine.name]) == [mine.name]
        with pytest.raises(ValueError, match="already has a case 'rod-MP3'"):
            boards.register(Board("rod-MP3", "rod", "MP3", "linear"))
    finally:
        boards.unregister(mine.name)
    assert [b.name for b in BOARDS] == before
    with pytest.raises(LeaderboardError, match="--rerun rod-MP3-mine: no such case"):
        build.check_rerun([mine.name])
