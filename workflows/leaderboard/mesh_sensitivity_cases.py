"""The cases of the mesh-sensitivity study (mesh_sensitivity.py): each a benchmark, material
and options with its grid sizes (Study; STUDIES, and QUICK for --quick), and the three mesh
shapes its runs take (shapes)."""

from __future__ import annotations

from dataclasses import dataclass, field

from tissuebench.meshes.benchmark import CELLS

NAME = "mesh-sensitivity"
MARKER = "# Mesh sensitivity"
GRADED = ("relative_error", "interior_error", "interior_error_nodal")


@dataclass(frozen=True)
class Study:
    """One case of the study: a benchmark, material and options; the runs' finest grid size N
    (N/4 must be a valid size) and the reference on 2N; h and T are the benchmark's."""

    name: str
    benchmark: str
    material: str
    size: int
    options: dict = field(default_factory=dict)
    end_time: float | None = None  # s; None: the benchmark's

    @property
    def sizes(self) -> tuple[int, int, int]:
        return (self.size // 4, self.size // 2, self.size)


STUDIES = (
    Study("block-MP1", "block", "MP1", 40, {"needle_width": 0.2}),
    Study("rod-MP3", "rod", "MP3", 8),
)
# --quick: the same cases on small grids and 1 s (a check of the workflow, never the results)
QUICK = (
    Study("block-MP1", "block", "MP1", 8, {"needle_width": 0.2}, end_time=1.0),
    Study("rod-MP3", "rod", "MP3", 4, end_time=1.0),
)


def shapes(gdim: int) -> dict[str, dict]:
    """The three mesh shapes of the study: {label: benchmark options}."""
    grid, simplex = CELLS[gdim]
    return {
        f"{grid} grid": {},
        f"{simplex} grid": {"cell": simplex},
        f"{simplex} unstructured": {"cell": simplex, "mesh": "unstructured"},
    }
