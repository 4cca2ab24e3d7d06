"""A user's simulator for the README's "grade your own simulator" recipe (tests/test_recipe.py).

It knows nothing of tissuebench: it reads only the exported JSON (schema tissuebench.benchmark,
version 2) and uses numpy and scipy. From the JSON's `geometry` it meshes the box on its own
grid of simplices (each grid cell split into d! Kuhn simplices: 6 tetrahedra in 3D, 2
triangles in 2D; spacing 1/CELLS_PER_METRE m, so not the export's nodes), finds each
constrained region's nodes by evaluating its predicate ("x = 0", "x = 1 and |y - 0.5| <= 0.1"),
prescribes the constraint's u, v, a there, and integrates linear P1 elasticity (plane strain or
stress in 2D) with consistent mass, Rayleigh damping C = alpha M + beta K_0, body force rho g,
and the JSON's algorithm: Newmark with its beta and gamma from u = v = 0 and a_0 from the
equation of motion. It writes the displacement at every t_i as XDMF with the data inline (XML),
field "displacement".

    python recipe_solver.py rod.json --out mine.xdmf [--cells-per-metre 16]

Checked by hand against tissuebench's own P1 (not a test: the meshes differ): the block with
w = 0.2 m and MP1 at nu = 0.3 on 20 x 20 squares, graded against our Q1 implicit, E_i max
1.134e-3 m^2 here and 1.133e-3 m^2 for `tissuebench run block --cell triangle` (alternating
diagonals); at MP1's nu = 0.47 this mesh's one-way diagonals lock (E_i max 2.6e-3 against
7.2e-4). The rod with 8 x 4 x 4 cells (225 nodes): E_i max 6.6e-4 m^3 against our implicit.

Units: SI as the JSON's `units` block says (m, s, kg, Pa).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
EQUAL = re.compile(rf"^([xyz])\s*(=|<=|>=)\s*({NUMBER})$")
BAND = re.compile(rf"^\|\s*([xyz])\s*-\s*({NUMBER})\s*\|\s*<=\s*({NUMBER})$")


def region_mask(predicate: str, points: np.ndarray, tolerance: float) -> np.ndarray:
    """The points (n, d) where predicate holds within tolerance (m): terms joined by "and",
    each "c = v", "c <= v", "c >= v" or "|c - v| <= r", c one of x, y, z."""
    inside = np.ones(len(points), dtype=bool)
    for term in predicate.split(" and "):
        term = term.strip()
        if m := EQUAL.match(term):
            c = points[:, "xyz".index(m[1])]
            value = float(m[3])
            test = {
                "=": np.abs(c - value) <= tolerance,
                "<=": c <= value + tolerance,
                ">=": c >= value - tolerance,
            }[m[2]]
        elif m := BAND.match(term):
            c = points[:, "xyz".index(m[1])]
            test = np.abs(c - float(m[2])) <= float(m[3]) + tolerance
        else:
            raise SystemExit(f"cannot read the region predicate term {term!r}")
        inside &= test
    return inside


def kuhn_mesh(extents: list, per_metre: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, d) and simplices (c, d + 1) of a grid on the box, each cell split into the
    d! simplices of the Kuhn triangulation (conforming across cells), positively oriented."""
    lows = np.array([e[0] for e in extents], dtype=float)
    highs = np.array([e[1] for e in extents], dtype=float)
    d = len(extents)
    counts = [max(1, round((hi - lo) * per_metre)) for lo, hi in zip(lows, highs, strict=True)]
    axes = [np.linspace(lo, hi, n + 1) for lo, hi, n in zip(lows, highs, counts, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    points = grid.reshape(-1, d)
    shape = [n + 1 for n in counts]
    index = np.arange(points.shape[0]).reshape(shape)
    cells = []
    for corner in itertools.product(*(range(n) for n in counts)):
        for order in itertools.permutations(range(d)):
            vertex = list(corner)
            simplex = [index[tuple(vertex)]]
            for axis in order:
                vertex[axis] += 1
                simplex.append(index[tuple(vertex)])
            cells.append(simplex)
    cells = np.array(cells, dtype=np.int64)
    jac = points[cells[:, 1:]] - points[cells[:, :1]]  # (c, d, d): edge vectors as rows
    negative = np.linalg.det(jac) < 0
    cells[negative, 0], cells[negative, 1] = cells[negative, 1], cells[negative, 0].copy()
    return points, cells


def assemble(points, cells, lam, mu, rho, gravity):
    """Linear P1 stiffness K (Pa m^(d-2) units of N/m), consistent mass M (kg) and the body
    force vector f (N), dofs node-major (node k, component i -> k d + i)."""
    n, d = points.shape
    rows, cols, kvals, mvals = [], [], [], []
    f = np.zeros(n * d)
    for cell in cells:
        x = points[cell]
        jac = (x[1:] - x[0]).T  # d x d
        volume = abs(np.linalg.det(jac)) / math.factorial(d)
        inverse = np.linalg.inv(jac)
        grads = np.vstack([-inverse.sum(axis=0), inverse])  # (d + 1, d): grad phi_a
        dofs = (cell[:, None] * d + np.arange(d)).ravel()
        k = np.zeros((d + 1, d, d + 1, d))
        for a in range(d + 1):
            for b in range(d + 1):
                ga, gb = grads[a], grads[b]
                k[a, :, b, :] = volume * (
                    lam * np.outer(ga, gb) + mu * (np.outer(gb, ga) + np.eye(d) * (ga @ gb))
                )
        m = rho * volume / ((d + 1) * (d + 2)) * (np.ones((d + 1, d + 1)) + np.eye(d + 1))
        m = np.kron(m, np.eye(d))
        rows.append(np.repeat(dofs, len(dofs)))
        cols.append(np.tile(dofs, len(dofs)))
        kvals.append(k.reshape(len(dofs), len(dofs)).ravel())
        mvals.append(m.ravel())
        for a in range(d + 1):
            f[cell[a] * d : cell[a] * d + d] += rho * np.asarray(gravity) * volume / (d + 1)
    r, c = np.concatenate(rows), np.concatenate(cols)
    size = (n * d, n * d)
    K = sp.csr_matrix((np.concatenate(kvals), (r, c)), shape=size)
    M = sp.csr_matrix((np.concatenate(mvals), (r, c)), shape=size)
    return K, M, f


def write_xdmf(path: Path, points, cells, times, displacements) -> None:
    """An XDMF series with every array inline (Format XML): mesh (simplices, or quadrilaterals
    in 2D), then one grid per t_i."""
    n, d = points.shape
    pad = np.zeros((n, 3 - d))
    xyz = np.hstack([points, pad])
    corners = cells.shape[1]
    topology = {3: "Triangle", 4: "Tetrahedron" if d == 3 else "Quadrilateral"}[corners]

    def block(array, fmt):
        return "\n".join(" ".join(fmt % v for v in row) for row in array)

    lines = [
        '<?xml version="1.0"?>',
        '<Xdmf Version="3.0">',
        "  <Domain>",
        '    <Grid Name="mesh" GridType="Uniform">',
        f'      <Topology TopologyType="{topology}" NumberOfElements="{len(cells)}">',
        f'        <DataItem Dimensions="{len(cells)} {corners}" NumberType="Int" Format="XML">',
        block(cells, "%d"),
        "        </DataItem>",
        "      </Topology>",
        '      <Geometry GeometryType="XYZ">',
        f'        <DataItem Dimensions="{n} 3" NumberType="Float" Precision="8" Format="XML">',
        block(xyz, "%.17g"),
        "        </DataItem>",
        "      </Geometry>",
        "    </Grid>",
        '    <Grid Name="series" GridType="Collection" CollectionType="Temporal">',
    ]
    for t, u in zip(times, displacements, strict=True):
        lines += [
            '      <Grid GridType="Uniform">',
            f'        <Time Value="{t!r}" />',
            '        <Attribute Name="displacement" AttributeType="Vector" Center="Node">',
            f'          <DataItem Dimensions="{n} 3" NumberType="Float" Precision="8" '
            'Format="XML">',
            block(np.hstack([u.reshape(n, d), pad]), "%.17g"),
            "          </DataItem>",
            "        </Attribute>",
            "      </Grid>",
        ]
    lines += ["    </Grid>", "  </Domain>", "</Xdmf>", ""]
    path.write_text("\n".join(lines))


def solve(doc: dict, per_metre: float) -> tuple[np.ndarray, np.ndarray, list, list]:
    """(points, cells, times, displacements): the benchmark of the JSON doc on our own mesh."""
    if doc.get("schema") != "tissuebench.benchmark" or doc.get("version") != 2:
        raise SystemExit("not a tissuebench.benchmark JSON of version 2")
    if doc["model"] != "linear":
        raise SystemExit(f"this solver is linear only, the export's model is {doc['model']}")
    geometry, material, algorithm = doc["geometry"], doc["material"], doc["algorithm"]
    d = int(doc["dimension"])
    points, cells = kuhn_mesh(geometry["extents"], per_metre)
    E, nu, rho = material["E"], material["nu"], material["rho"]
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    if d == 2 and doc["plane"] == "stress":
        lam = 2 * mu * lam / (lam + 2 * mu)
    K, M, f = assemble(points, cells, lam, mu, rho, doc["body_force"]["gravity"])
    C = material["alpha"] * M + material["beta"] * K

    # constrained dofs: every component of every node on the region; the last set wins
    owner = np.full(len(points), -1)
    constraints = doc["constraints"]
    for k, c in enumerate(constraints):
        mask = region_mask(c["region"], points, geometry["tolerance"])
        if not mask.any():
            raise SystemExit(f"no node of our mesh lies on {c['set']}: {c['region']}")
        owner[mask] = k
    fixed_nodes = np.flatnonzero(owner >= 0)
    con = (fixed_nodes[:, None] * d + np.arange(d)).ravel()
    free = np.setdiff1d(np.arange(len(points) * d), con)
    motion = {name: np.array([c[name] for c in constraints]) for name in "uva"}  # (k, t, d)

    def prescribed(name: str, i: int) -> np.ndarray:
        return motion[name][owner[fixed_nodes], i].ravel()

    times = doc["time"]["t"]
    h = doc["time"]["h"]
    n_dofs = len(points) * d
    u, v, a = np.zeros(n_dofs), np.zeros(n_dofs), np.zeros(n_dofs)
    u[con], v[con], a[con] = prescribed("u", 0), prescribed("v", 0), prescribed("a", 0)
    Mff, Mfc = M[free][:, free], M[free][:, con]
    rhs0 = f[free] - Mfc @ a[con] - (C @ v)[free] - (K @ u)[free]
    a[free] = spla.spsolve(Mff.tocsc(), rhs0)
    displacements = [u.copy()]
    if doc["procedure"] == "static":
        Kff = spla.splu(K[free][:, free].tocsc())
        for i in range(1, len(times)):
            u[con] = prescribed("u", i)
            u[free] = Kff.solve(f[free] - K[free][:, con] @ u[con])
            displacements.append(u.copy())
        return points, cells, times, displacements
    beta, gamma = algorithm["newmark_beta"], algorithm["newmark_gamma"]
    A = (M + gamma * h * C + beta * h * h * K).tocsr()
    solver = spla.splu(A[free][:, free].tocsc())
    Cfc, Kfc = C[free][:, con], K[free][:, con]
    Cff, Kff = C[free][:, free], K[free][:, free]
    for i in range(1, len(times)):
        u_star = u + h * v + h * h * (0.5 - beta) * a
        v_star = v + h * (1 - gamma) * a
        a_c, v_c, u_c = prescribed("a", i), prescribed("v", i), prescribed("u", i)
        rhs = f[free] - Mfc @ a_c - Cff @ v_star[free] - Cfc @ v_c - Kff @ u_star[free] - Kfc @ u_c
        a_new = np.empty(n_dofs)
        a_new[free] = solver.solve(rhs)
        a_new[con] = a_c
        u = u_star + beta * h * h * a_new
        v = v_star + gamma * h * a_new
        u[con], v[con] = u_c, v_c
        a = a_new
        displacements.append(u.copy())
    return points, cells, times, displacements


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("benchmark", type=Path, help="the exported JSON (version 2)")
    parser.add_argument("--out", type=Path, required=True, help="the XDMF series to write")
    parser.add_argument("--cells-per-metre", type=float, default=16.0)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    doc = json.loads(args.benchmark.read_text())
    points, cells, times, displacements = solve(doc, args.cells_per_metre)
    wall = time.perf_counter() - start
    write_xdmf(args.out, points, cells, times, displacements)
    print(
        f"{len(points)} nodes, {len(cells)} simplices, {len(times) - 1} steps in {wall:.2f} s: "
        f"wrote {args.out}"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
