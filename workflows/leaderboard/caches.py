"""What the gradings of a leaderboard run build once and share (grading.py): the meshes
located in each truth, our implicit runs on the users' meshes, the last series read, the
cases' references (case_reference: found under OUT or run here) and the grades by series'
content hash, each keeping its last used entries (Recent)."""

from __future__ import annotations

import tempfile
from collections import OrderedDict
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI

from tissuebench.workflows.leaderboard.record import FOLDER
from tissuebench.workflows.leaderboard.rows import Board, board_case

if TYPE_CHECKING:
    from tissuebench.metrics.series import Series


class Recent(OrderedDict):
    """A dict that keeps its `most` last used entries (get and set count as uses), so that a
    leaderboard of many users' meshes, each located and run on, does not keep them all."""

    def __init__(self, most: int):
        super().__init__()
        self.most = most

    def get(self, key, default=None):
        if key in self:
            self.move_to_end(key)
            return self[key]
        return default

    def __setitem__(self, key, value):
        super().__setitem__(key, value)
        self.move_to_end(key)
        while len(self) > self.most:
            self.popitem(last=False)


class Caches:
    """What the gradings of a leaderboard run build once and share (one process): each truth's
    candidate meshes checked and located (`located`, {truth case: {mesh key: TruthMetrics}},
    metrics/truth.py's located_on), our implicit runs on the users' meshes and the budget
    parts that depend on the mesh alone (`on_mesh`, user_mesh.budget_on_mesh's cache), the
    last series read (rows read their series once for every grading), the last cases'
    references (`reference`: case_reference, found under `out` or run here) and every user's
    row graded, by its series' content hash (`grades`: a row of the same series takes them).
    The numbers are the same as without it. Each keeps its MESHES last used meshes: a mesh
    met again after that is located and run on again (the same numbers)."""

    MESHES = 16
    REFERENCES = 2  # the rows come case by case

    def __init__(self, out: Path | None = None):
        self.out = out
        self.located: dict[str, Recent] = {}
        self.on_mesh = Recent(self.MESHES)
        self._series: tuple[tuple[str, str | None], Series] | None = None
        self.references = Recent(self.REFERENCES)
        self.grades: dict[tuple, dict] = {}

    def reference(self, board: Board) -> Series:
        """case_reference(board, out), found or run once per case (a failure too: raised
        again)."""
        found = self.references.get(board.name)
        if found is None:
            try:
                found = case_reference(board, self.out)
            except Exception as exc:  # anything a run or a file can do: said for each row
                found = exc
            self.references[board.name] = found
        if isinstance(found, BaseException):
            raise found
        return found

    def located_for(self, truth) -> Recent | None:
        if truth is None:
            return None
        return self.located.setdefault(truth.case, Recent(self.MESHES))

    def series(self, path: str, field: str | None):
        """read_series(path, field), read once for consecutive asks of the same file."""
        from tissuebench.workflows.io.series import read_series

        key = (str(path), field)
        if self._series is None or self._series[0] != key:
            self._series = None  # the old one is let go before the new one is read
            self._series = (key, read_series(path, field))
        return self._series[1]


def case_reference(board: Board, out: Path | None = None) -> Series:
    """The case's reference series: our implicit with the case's model on its mesh, h and
    steps. OUT/leaderboard/CASE/ours/LABEL.xdmf where a rerun of the case left it as we wrote
    it (its folder is ours, unchanged: manifest.is_ours) and of the case's steps and nodes;
    else run here as `tissuebench export` runs the reference it writes beside the benchmark
    (posing.export into a temporary folder, read back, removed): the series a user compared
    against. Rank 0's (one process)."""
    from tissuebench.meshes import get_entry
    from tissuebench.solvers.materials import get_material
    from tissuebench.solvers.models import run_label
    from tissuebench.workflows.compare.posing import export, reference_path
    from tissuebench.workflows.io.manifest import is_ours
    from tissuebench.workflows.io.series import read_series

    case = board_case(board)
    if out is not None:
        folder = Path(out) / FOLDER / board.name / "ours"
        path = folder / f"{run_label('implicit', board.model)}.xdmf"
        if path.is_file() and not path.is_symlink() and is_ours(folder):
            series = read_series(path)
            if len(series.times) == case["steps"] + 1 and len(series.points) == case["nodes"]:
                return series
    with tempfile.TemporaryDirectory(prefix="tissuebench-reference-") as tmp:
        posed = Path(tmp) / f"{board.name}.json"
        export(
            board.benchmark,
            "json",
            posed,
            mesh_size=board.mesh_size or get_entry(board.benchmark).mesh_size,
            options=dict(board.options),
            material=get_material(board.material),
            model=board.model,
            h=case["h"],
            steps=case["steps"],
            comm=MPI.COMM_SELF,
            log=lambda line: None,
        )
        return read_series(reference_path(posed))
