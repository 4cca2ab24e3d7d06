"""The contact benchmark (SPEC 12) posed from its export alone, the sibling of test_recipe.py:
`tissuebench export contact` states the needle as data, tests/recipe_contact.py (numpy and scipy,
its own Q1 grid, its own penalty contact and Newton; nothing of tissuebench) solves it
quasi-statically from the JSON, and its needle force and displacement are graded against
`tissuebench run contact` on the same mesh size and kappa."""

import ast
import csv
import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from helpers import job, tissuebench

SOLVER = Path(__file__).with_name("recipe_contact.py")
N, KAPPA, END = 10, 10.0, 2.0  # mesh size, penalty, end time (s): the needle 0.16 m in

# Tolerances. The solver's grid, penalty (k = kappa E / h_e with the JSON's kappa and its own
# h_e) and edge quadrature (3 Gauss points, the JSON's degree 4) are ours, so the two solutions
# differ only by the Newton tolerances (ours 1e-10 relative, its 1e-12 E h_e absolute):
# measured 2.5e-13 relative in F and E_i max 2.7e-14 m^2 here. The bounds leave room for
# another BLAS, not for another law: kappa 10 -> 20 moves F at t = 2 s by 8.6 %.
FORCE_RTOL = 1e-8
EI_MAX = 1e-10  # m^2
DEPTH_ATOL = 1e-9  # m


def imported(path: Path) -> set[str]:
    """The top-level modules a Python file imports."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module.split(".")[0])
    return names


def forces(path: Path, label: str | None = None) -> dict[float, tuple[float, float, float]]:
    """{t: (F_x, F_y, interpenetration)} of a contact.csv (of run `label`) or the solver's CSV."""
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if label is None or r["algorithm"] == label]
    key = "time" if label is not None else "t"
    return {
        round(float(r[key]), 9): tuple(
            float(r[k]) for k in ("force_x", "force_y", "interpenetration")
        )
        for r in rows
    }


@pytest.mark.serial
def test_an_independent_solver_poses_the_contact_case_from_the_export(tmp_path):
    common = ["--mesh-size", str(N), "--kappa", str(KAPPA), "--end-time", str(END)]
    r = tissuebench(
        "export", "contact", *common, "--procedure", "static", "--out", tmp_path / "contact.json"
    )
    assert r.returncode == 0, r.stderr[-2000:]
    doc = json.loads((tmp_path / "contact.json").read_text())

    # the JSON states the fixed regions and the needle as data
    assert doc["version"] == 2 and doc["benchmark"] == "contact"
    assert doc["geometry"]["regions"] == {"left": "x = 0", "bottom": "y = 0", "top": "y = 1"}
    assert [c["set"] for c in doc["constraints"]] == ["left", "bottom", "top"]
    assert all(c["fixed"] for c in doc["constraints"])
    contact = doc["contact"]
    shape, motion, law, penalty = (contact[k] for k in ("shape", "motion", "law", "penalty"))
    assert shape["kind"] == "half-stadium" and shape["radius"] == 0.1
    assert law["surface"] == "x = 1" and law["friction"] == "none"
    x = np.array(doc["nodes"])
    assert law["surface_nodes"] == np.flatnonzero(np.isclose(x[:, 0], 1.0)).tolist()
    E = doc["material"]["E"]
    assert (penalty["kappa"], penalty["h_e"]) == (KAPPA, 1 / N)
    assert penalty["k"] == pytest.approx(KAPPA * E / (1 / N), rel=1e-15)
    t = np.array(doc["time"]["t"])
    g = np.stack([motion["v_x"] * np.minimum(t, motion["t_stop"]), 0 * t], 1)
    assert motion["c0"] == [1.1, 0.5] and motion["t_stop"] == 2.0
    assert np.allclose(motion["c"], np.array(motion["c0"]) + motion["load_scale"] * g, atol=1e-15)
    units = doc["units"]
    assert units["contact.graded.force"] == "N/m" and units["contact.shape.radius"] == "m"
    assert units["contact.penalty.k"] == "Pa/m" and units["reference.contact.force"] == "N/m"

    # the independent solver, from the JSON alone
    cmd, env = job([SOLVER, tmp_path / "contact.json", "--out", tmp_path / "mine.xdmf",
                    "--forces", tmp_path / "mine.csv"])  # fmt: skip
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    assert imported(SOLVER) | imported(SOLVER.with_name("recipe_solver.py")) <= {
        "argparse", "itertools", "json", "math", "re", "sys", "time", "pathlib", "numpy",
        "scipy", "recipe_solver", "__future__",
    }  # fmt: skip
    mine = forces(tmp_path / "mine.csv")

    # our quasi-static run of the same mesh size and kappa
    r = tissuebench("run", "contact", *common, "--algorithms", "quasi-static",
                    "--out", tmp_path / "runs")  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    ours = forces(tmp_path / "runs" / "contact.csv", "quasi-static")
    Fx, Fy, depth = ours[END]
    assert Fx > 10.0  # N/m: the tissue pushes back on the needle
    assert mine[END][0] == pytest.approx(Fx, rel=FORCE_RTOL)
    assert abs(mine[END][1] - Fy) <= FORCE_RTOL * Fx  # ~0: the block is symmetric about y = 0.5
    assert mine[END][2] == pytest.approx(depth, abs=DEPTH_ATOL) and depth > 0
    # the export's own reference states the same force
    reference = doc["reference"]["contact"]
    assert reference["force"][-1][0] == pytest.approx(Fx, rel=1e-12)

    # its displacement, graded against our run
    r = tissuebench("compare", tmp_path / "runs" / "quasi-static.xdmf", tmp_path / "mine.xdmf",
                    "--out", tmp_path / "graded", "--label", "independent")  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    graded = json.loads((tmp_path / "graded" / "summary.json").read_text())["runs"]["independent"]
    assert graded["status"] == "ok" and graded["steps"] == round(END * 30)
    assert graded["interior_error_max"] < EI_MAX
