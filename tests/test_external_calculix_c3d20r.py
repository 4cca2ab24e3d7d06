"""CalculiX's C3D20R on the export's hexahedra (workflows/io/calculix_deck.py quadratic_hexahedra,
workflows/simulators/calculix.py): each check against something independent of the code it
tests: the natural coordinates of C3D20's nodes as CalculiX's shape20h.f defines them, an
affine field that every isoparametric element reproduces exactly, and the truth's Q2 and
Taylor-Hood solutions (solvers/truth), computed here on finer grids."""

import shutil
import subprocess
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import needs_ccx

from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth.cases import case_truth
from tissuebench.workflows.compare.posing import build
from tissuebench.workflows.io.calculix import read_dat, read_frd
from tissuebench.workflows.io.calculix_deck import (
    HEX20_EDGES,
    inp_text,
    number,
    quadratic_hexahedra,
)
from tissuebench.workflows.simulators import calculix

CCX = shutil.which("ccx")
H = 1 / 30  # s
TIP = (0.5, 0.25, 0.125)  # the rod's probe, m (a node at even n)

# C3D20's nodes in natural coordinates (xi, eta, zeta), where shape20h.f's shape function of
# each is 1: corners 1-8, then the midside nodes 9-20
NATURAL = np.array(
    [
        (-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
        (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1),
        (0, -1, -1), (1, 0, -1), (0, 1, -1), (-1, 0, -1),
        (0, -1, 1), (1, 0, 1), (0, 1, 1), (-1, 0, 1),
        (-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0),
    ],
    dtype=float,
)  # fmt: skip


def trilinear(corners: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """The points at natural coordinates xi (k, 3) of the hexahedron with these 8 corners
    (C3D8 order: NATURAL[:8])."""
    weights = np.prod(1 + xi[:, None, :] * NATURAL[None, :8, :], axis=2) / 8
    return weights @ corners


def rod(material: str, n: int, steps: int, procedure: str):
    data, _, _ = build(
        "rod", n, {}, get_material(material), "linear", H, steps, "strain", procedure,
        MPI.COMM_SELF,
    )  # fmt: skip
    return data


def ccx(folder: Path, deck: str) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "job.inp").write_text(deck)
    r = subprocess.run([CCX, "-i", "job"], cwd=folder, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "*ERROR" not in r.stdout, r.stdout[-2000:]


def tip_of(path: Path) -> np.ndarray:
    """The tip's displacement (m) at every step of a .frd, read at the corners."""
    points, _, cell_type, _, values, _ = read_frd(path)
    assert cell_type == "hexahedron"
    k = np.argmin(np.linalg.norm(points - TIP, axis=1))
    assert np.allclose(points[k], TIP)
    return np.array([v[k] for v in values])


def test_midside_nodes_sit_where_calculix_numbers_them():
    """Every cell's 20 nodes at the natural coordinates of C3D20's nodes (its 8 corners
    mapped trilinearly), on a grid with its inner nodes moved; each edge's midside node is
    one node shared by the cells around it; the clamped face holds its midside nodes."""
    data = rod("MP3", 2, 1, "dynamic")
    rng = np.random.default_rng(7)
    inner = np.all((data.nodes > 1e-9) & (data.nodes < np.array([0.5, 0.25, 0.25]) - 1e-9), 1)
    data.nodes[inner] += rng.uniform(-0.02, 0.02, (inner.sum(), 3))
    quad = quadratic_hexahedra(data)
    first = len(data.nodes)
    assert np.array_equal(quad.nodes[:first], data.nodes)
    assert np.array_equal(quad.cells[:, :8], data.cells)
    for cell in quad.cells:
        corners = quad.nodes[cell[:8]]
        assert np.allclose(quad.nodes[cell], trilinear(corners, NATURAL), atol=1e-14)
    # 4 x 2 x 2 cells: 5 * 3 * 3 corners and 4*3*3 + 5*2*3 + 5*3*2 edges, each one node
    assert len(quad.nodes) == 45 + 36 + 30 + 30 and np.all(quad.cells[:, 8:] >= first)
    assert len(np.unique(quad.cells)) == len(quad.nodes)
    clamped = quad.node_sets["clamped"]
    assert len(clamped) == 9 + 12 and np.allclose(quad.nodes[clamped, 0], 0)
    on_face = np.flatnonzero(np.isclose(quad.nodes[:, 0], 0))
    assert np.array_equal(np.sort(clamped), on_face)
    assert HEX20_EDGES[8] == (0, 4)  # node 17 on the edge 1-5, as in the CalculiX manual


@needs_ccx
@pytest.mark.serial
def test_patch_test_reproduces_an_affine_field(tmp_path):
    """An affine displacement prescribed on every boundary node (midside ones included) of a
    distorted 4 x 2 x 2 grid of C3D20R, statically: CalculiX's inner nodes, corners and
    midside nodes, take the same affine field to round-off (read from the .dat and .frd)."""
    data = rod("MP2", 2, 1, "static")
    rng = np.random.default_rng(11)
    extent = np.array([0.5, 0.25, 0.25])
    inner = np.all((data.nodes > 1e-9) & (data.nodes < extent - 1e-9), 1)
    assert inner.sum() == 3
    data.nodes[inner] += rng.uniform(-0.03, 0.03, (inner.sum(), 3))
    quad = quadratic_hexahedra(data)
    # the boundary: on the box's faces (the inner nodes moved, the midside ones too)
    boundary = np.any(np.isclose(quad.nodes, 0) | np.isclose(quad.nodes, extent), axis=1)
    free = np.flatnonzero(~boundary)
    assert len(free) == 3 + 16  # the inner corners and the midside nodes of their 16 edges
    A = np.array([[1e-3, 2e-3, -1e-3], [-2e-3, 0.5e-3, 1e-3], [0.3e-3, -1e-3, 2e-3]])
    b = np.array([1e-4, -2e-4, 3e-4])
    exact = quad.nodes @ A.T + b
    deck = ["*NODE, NSET=Nall"]
    deck += [", ".join([str(i + 1), *map(number, x)]) for i, x in enumerate(quad.nodes)]
    # the deck writer's element lines: taken from the export's deck of the same grid
    lines = inp_text(data, "C3D20R").splitlines()
    start = lines.index("*ELEMENT, TYPE=C3D20R, ELSET=Eall")
    deck += lines[start : start + 1 + 2 * len(quad.cells)]
    m = get_material("MP2")
    deck += ["*MATERIAL, NAME=M", "*ELASTIC", f"{number(m.E)}, {number(m.nu)}"]
    deck += ["*SOLID SECTION, ELSET=Eall, MATERIAL=M", "*STEP", "*STATIC", "*BOUNDARY"]
    deck += [
        f"{i + 1}, {k + 1}, {k + 1}, {number(exact[i, k])}"
        for i in np.flatnonzero(boundary)
        for k in range(3)
    ]
    deck += ["*NODE FILE", "U", "*NODE PRINT, NSET=Nall", "U", "*END STEP", ""]
    ccx(tmp_path, "\n".join(deck))
    # every node in the .dat (as printed: 7 digits), the corners in the .frd (6 digits)
    text = (tmp_path / "job.dat").read_text().splitlines()
    at = next(k for k, line in enumerate(text) if line.strip().startswith("displacements"))
    rows = [r.split() for r in text[at + 1 :] if r.strip()]
    u = np.zeros_like(exact)
    for r in rows:
        u[int(r[0]) - 1] = [float(v) for v in r[1:4]]
    scale = np.abs(exact).max()
    assert np.abs(u[free] - exact[free]).max() < 1e-6 * scale, u[free] - exact[free]
    points, cells, _, _, values, field = read_frd(tmp_path / "job.frd")
    assert field == "DISP" and len(points) == len(data.nodes)
    assert np.allclose(points, quad.nodes[: len(data.nodes)], rtol=0, atol=1e-5)
    assert np.array_equal(cells, data.cells)  # the corners, in the export's order
    assert np.abs(values[-1] - exact[: len(points)]).max() < 1e-5 * scale
    # the .dat reader takes the corners too, from the deck beside it
    _, dat_cells, _, _, dat_values, _ = read_dat(tmp_path / "job.dat")
    assert np.array_equal(dat_cells, data.cells)
    assert np.abs(dat_values[-1] - exact[: len(points)]).max() < 1e-6 * scale


@needs_ccx
@pytest.mark.serial
@pytest.mark.parametrize(
    "material, within",
    [("MP3", 0.02), ("MP2", 0.15)],  # at n = 2: 1.1 % and 11 % measured (MP2 locks a little)
)
def test_static_rod_tip_against_the_truth(tmp_path, material, within):
    """The rod's static tip under gravity on the 4 x 2 x 2 grid against the truth's Q2 (MP3)
    or Taylor-Hood Q2-Q1 (MP2, nu = 0.495) on 8 x 4 x 4: C3D20R within `within`, and closer
    than C3D8 and C3D8I on the same grid."""
    case = {"MP3": "rod", "MP2": "rod-MP2"}[material]
    truth, _ = case_truth(case, 4, MPI.COMM_SELF)
    exact = truth.tip(truth.static(1.0))[1]
    data = rod(material, 2, 1, "static")
    off = {}
    for element in ("C3D8", "C3D8I", "C3D20R"):
        ccx(tmp_path / element, inp_text(data, element))
        off[element] = abs(tip_of(tmp_path / element / "job.frd")[-1, 1] / exact - 1)
    assert off["C3D20R"] < within, off
    assert off["C3D20R"] < off["C3D8I"] < off["C3D8"], off


@needs_ccx
@pytest.mark.serial
def test_dynamic_rod_tip_against_the_truth(tmp_path):
    """The rod (MP3) over 30 steps of h, CalculiX's trapezoidal rule: C3D20R on 4 x 2 x 2
    follows the truth's Q2 tip history (8 x 4 x 4, consistent mass) within 2 % of its largest
    deflection, five times closer than C3D8; the variant runs through the simulator module
    (its dofs: the midside nodes' included)."""
    steps = 30
    truth, bench = case_truth("rod", 4, MPI.COMM_SELF)
    exact = truth.run(H, steps, keep=0).tip[1:, 1]
    data = rod("MP3", 2, steps, "dynamic")
    assert "implicit-C3D20R" in calculix.variants(data)
    off = {}
    for element in ("C3D8", "C3D20R"):
        (tmp_path / element).mkdir()
        done = calculix.run(data, f"implicit-{element}", tmp_path / element)
        assert done.status == "ok", done.reason
        tip = tip_of(done.series)[:, 1]
        assert len(tip) == steps
        off[element] = np.abs(tip - exact).max() / np.abs(exact).max()
        if element == "C3D20R":
            assert done.dofs == 3 * len(quadratic_hexahedra(data).nodes) == 3 * 141
    assert off["C3D20R"] < 0.02 and off["C3D20R"] < off["C3D8"] / 5, off
