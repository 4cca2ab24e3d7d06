"""What the clone's git holds at HEAD. The leaderboard takes the numbers it does not grade
itself (the rows of ours and of the simulators, the SPEC 11 frontier's table) from here, never
from a file that anyone can write: OUT's record, the working copy's, a frontier.csv (issue 60)."""

from __future__ import annotations

import subprocess
from pathlib import Path

from tissuebench.workflows.leaderboard.rows import one_line


def clone_root() -> Path:
    """The folder of the clone tissuebench runs from (an editable install: the package's
    source tree is the repository), found from the package's own path."""
    import tissuebench.workflows

    return Path(tissuebench.workflows.__file__).resolve().parent.parent


def head_text(path: str, root: Path) -> tuple[str | None, str]:
    """(the text of `path` (relative to the repository) as committed at git's HEAD in `root`,
    "") or (None, why not, one line): no git, no repository, no such file committed."""
    try:
        done = subprocess.run(
            ["git", "-C", str(root), "-c", f"safe.directory={root}", "show", f"HEAD:{path}"],
            capture_output=True,
            timeout=60,
            check=False,
        )
    except (OSError, subprocess.SubprocessError) as exc:
        return None, f"git show HEAD:{path}: {type(exc).__name__}: {one_line(exc)[:120]}"
    if done.returncode != 0:
        why = one_line(done.stderr.decode(errors="replace").strip())[:160]
        return None, f"git show HEAD:{path}: {why or 'failed'}"
    return done.stdout.decode("utf-8", errors="replace"), ""
