"""The large rod's crease as a finding (SPEC 10; workflows/truth/crease.py): J at the corners
of hexahedra under maps whose J is known, the fold's test on a hierarchy, and its figures on a
grid where chosen cells are squashed."""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from tissuebench.workflows.truth.crease import FOLDED, corner_jacobians, crease_figures, creased


def box_grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit cube in n^3 hexahedra (VTK corner order): vertices (m) and cells."""
    ticks = np.linspace(0.0, 1.0, n + 1)
    x, y, z = np.meshgrid(ticks, ticks, ticks, indexing="ij")
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])

    def at(i: int, j: int, k: int) -> int:
        return (i * (n + 1) + j) * (n + 1) + k

    cells = [
        [at(i + a, j + b, k + c) for a, b, c in ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0),
                                                  (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1))]
        for i in range(n) for j in range(n) for k in range(n)
    ]  # fmt: skip
    return vertices, np.array(cells)


def test_corner_jacobians_of_affine_maps():
    """x = A X + b: J = det A at every corner (a stretch, a shear, a rotation, a reflection)."""
    vertices, cells = box_grid(2)
    theta = 0.7
    rotation = np.array(
        [[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]]
    )
    for A in (np.diag([1.1, 0.9, 0.5]), np.array([[1, 0.4, 0], [0, 1, 0.2], [0, 0, 1]]),
              rotation, np.diag([1.0, 1.0, -1.0])):  # fmt: skip
        u = vertices @ A.T + 0.3 - vertices
        assert np.allclose(corner_jacobians(vertices, cells, u), np.linalg.det(A))


def test_creased_needs_falling_j_and_levels_moving_apart():
    """A fold: the smallest J falls with every level to below 0.1 while the levels move apart;
    a converging hierarchy, or one whose J levels off, is not one."""
    j = [[1.0, 0.6], [1.0, 0.5], [1.0, 0.07]]
    assert creased({"min_jacobian": j, "level_differences": [[1e-3], [2e-3]]})
    assert not creased({"min_jacobian": j, "level_differences": [[1e-3], [2e-4]]})
    level = [[1.0, 0.6], [1.0, 0.5], [1.0, 0.45]]
    assert not creased({"min_jacobian": level, "level_differences": [[1e-3], [2e-3]]})


@pytest.mark.serial  # draws two files in one folder: one process
def test_crease_figures_count_the_squashed_cells(tmp_path: Path):
    """A 4^3 grid of the unit cube whose vertices at z = 0.25 with x <= 0.5 and y <= 0.25 (six
    of them) are pulled down by 0.235 m: every cell of the bottom layer with one of them as a
    corner has its vertical edge there shortened from 0.25 to 0.015 m, so J = 0.06 at that
    corner (the in-plane edges tilt, which leaves the volume form's vertical part as it is):
    those 3 x 2 cells fold, the cells above them are stretched (J = 1.94 there) and the rest
    untouched. The figures are drawn."""
    vertices, cells = box_grid(4)
    u = np.zeros_like(vertices)
    top = (np.isclose(vertices[:, 2], 0.25)) & (vertices[:, 0] <= 0.5) & (vertices[:, 1] <= 0.25)
    assert top.sum() == 6
    u[top, 2] = -0.235
    times = np.array([0.0, 1.0])
    samples = SimpleNamespace(
        case="toy",
        cell_type="hexahedron",
        cells=cells,
        vertices=vertices,
        times=times,
        u_vertices=np.stack([np.zeros_like(u), u]),
        hierarchy={
            "levels": [1, 2, 4],
            "min_jacobian": [[1.0, 0.7], [1.0, 0.4], [1.0, 0.05]],
            "min_jacobian_at": [[1.0, 0, 0, 0], [1.0, 0, 0, 0], [1.0, 0.1, 0.1, 0.1]],
            "level_differences": [[1e-3, 1e-3], [1e-3, 2e-3]],
        },
    )
    drawn = crease_figures(samples, tmp_path / "crease")  # type: ignore[arg-type]
    assert drawn is not None
    for key in ("J", "folded"):
        assert (tmp_path / drawn[key]).stat().st_size > 10_000
    assert drawn["cells"] == 6
    assert drawn["least_corner_J"] == pytest.approx(0.06)
    assert corner_jacobians(vertices, cells, u).max() == pytest.approx(1.94)
    assert drawn["t"] == 1.0 and FOLDED == 0.1


def sweep_summary(smallest: list[float], meets: bool) -> dict:
    """A truth summary of the sweep with these levels' smallest J (each reached at t = 2 s of
    a 3 s run at h = 1 s) and whether it meets the target."""
    series = [[1.0, 0.9, s, s] for s in smallest]
    return {
        "hierarchy": {
            "h": 1.0,
            "levels": [2, 4, 8],
            "min_jacobian": series,
            "level_differences": [[2e-4], [5e-5]],
        },
        "own_error": {"interior_error_max": 1e-5 if meets else 5e-5, "target": 2e-5,
                      "meets_target": meets},
    }  # fmt: skip


def test_sweep_takes_the_largest_load_that_meets_and_says_where_the_rest_folded():
    """SPEC 10's sweep: s = 2 folds on n = 4 (its J below 0.1 from t = 2 s) and misses the
    target, s = 1.75 does not fold but misses, s = 1.5 meets, s = 1.25 is not computed: L = 1.5,
    and truth.md's table says each of it."""
    from tissuebench.workflows.truth.sweep import chosen, folded, sweep_lines

    summaries = {
        "rod-nhb-s2": sweep_summary([0.6, 0.05, 0.01], False),
        "rod-nhb-s1.75": sweep_summary([0.6, 0.5, 0.4], False),
        "rod-nhb-s1.5": sweep_summary([0.7, 0.6, 0.55], True),
    }
    assert folded(summaries["rod-nhb-s2"]["hierarchy"]) == (4, 2.0)
    assert folded(summaries["rod-nhb-s1.75"]["hierarchy"]) is None
    assert chosen(summaries) == "rod-nhb-s1.5"
    text = "\n".join(sweep_lines(summaries))
    assert "| 2 | rod-nhb-s2 | graded | 0.6, 0.05, 0.01 | n = 4 at t = 2 s |" in text
    assert "| 1.25 | rod-nhb-s1.25 | graded | not computed |" in text
    assert "**rod-nhb-s1.5**" in text
    summaries["rod-nhb-s1.5"]["own_error"]["meets_target"] = False
    assert chosen(summaries) is None
    assert "the large rod has no truth" in "\n".join(sweep_lines(summaries))


def test_sweep_says_where_a_computation_failed():
    """A sweep case whose Newton failed (store.record_failure's record) is in the table with
    its level, time and smallest J, and is not taken as L."""
    from tissuebench.workflows.truth.sweep import chosen, sweep_lines

    failure = {"level": 8, "t": 4.3, "error": "truth: Newton did not converge at t = 4.3 s (-6)",
               "smallest_J": 0.08, "smallest_J_at": [0.01, 0.0, 0.0],
               "levels_done_smallest_J": [0.6, 0.5]}  # fmt: skip
    text = "\n".join(sweep_lines({}, {"rod-nhb-s2": failure}))
    assert "| 2 | rod-nhb-s2 | graded | 0.6, 0.5, then: Newton fails on n = 8 at t = 4.3 s" in text
    assert "smallest J before it 0.08 at X = (0.010, 0.000, 0.000) m" in text
    assert chosen({}) is None
    # every graded load fails; the uniform levels' truth meets: it is taken, and said to be
    uniform = {"rod-nhb-s1.75-uniform": sweep_summary([0.7, 0.6, 0.55], True)}
    text = "\n".join(sweep_lines(uniform, {"rod-nhb-s2": failure}))
    assert "| 1.75 | rod-nhb-s1.75-uniform | uniform | 0.7, 0.6, 0.55 | no |" in text
    assert "**rod-nhb-s1.75-uniform** meets it" in text
