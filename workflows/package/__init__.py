"""tissuebench: benchmarks, algorithms and accuracy metrics for fast soft-tissue simulation.

`import tissuebench` gives the Python API (workflows/api.py): `export_case` (the benchmark as
arrays, with our reference's series beside its JSON), `read_case`, `read_series`, and `grade`
(a simulation given as numpy arrays graded as `tissuebench compare` grades a file, writing the
same compare folder, which the leaderboard reads as a user's row). The code itself is in
tissuebench.core, .meshes, .solvers, .metrics and .workflows.

This file is the package `tissuebench` itself (pyproject.toml's package-dir maps it here). Its
names load on first use, so that importing any of the subpackages (the command line, which
handles signals before its heavy imports) does not import MPI, DOLFINx or the API first.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from tissuebench.workflows.api import (
        Exported,
        Graded,
        UserError,
        export_case,
        grade,
        read_case,
        read_series,
    )

__all__ = ["Exported", "Graded", "UserError", "export_case", "grade", "read_case", "read_series"]


def __getattr__(name: str) -> Any:
    """The API's names (workflows/api.py), imported when first asked for."""
    if name in __all__:
        from tissuebench.workflows import api

        return getattr(api, name)
    raise AttributeError(f"module 'tissuebench' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
