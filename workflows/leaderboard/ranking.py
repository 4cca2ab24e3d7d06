"""The leaderboard's rows, their checks and their ranking now live in the leaderboard's package
(workflows/leaderboard/rows.py); this name stays for its readers (export, the mesh-sensitivity
study, user_mesh) and for anyone who imported it."""

from tissuebench.workflows.leaderboard.rows import *  # noqa: F403
from tissuebench.workflows.leaderboard.rows import (  # noqa: F401 (the names read through here)
    BOARDS,
    E_I,
    E_N,
    TRUTH_KEYS,
    Board,
    Row,
    board_case,
    candidate_of,
    error_keys,
    export_options,
    finite,
    fmt,
    mark_pareto,
    md,
    misplaced,
    one_line,
    pareto,
    plain,
    posed_board,
    real,
    user_rows,
    write_csv,
)
