"""A user's simulator for the contact benchmark (tests/test_recipe_contact.py): the needle as a
rigid tool in frictionless contact, posed from the exported JSON alone.

Like recipe_solver.py it knows nothing of tissuebench: it reads only the JSON (schema
tissuebench.benchmark, version 2, with its `contact` object) and uses numpy and scipy. It meshes
the box of `geometry` on its own grid of bilinear quadrilaterals (Q1, 2 x 2 Gauss points;
spacing the JSON's h_e unless --cells-per-metre says otherwise), clamps every node on the
regions of the fixed sets by evaluating their predicates, and finds the contact surface's
edges by its predicate ("x = 1"). The needle is the half-stadium of `contact.shape`, its centre
c(t) = c0 + s g(t) computed from `contact.motion`'s parameters (g(t) = (v_x min(t, t_stop), 0)).
The law is imposed by a penalty of its own assembly: the energy (k/2) int <-g_n>^2 over the
surface's edges, 3 Gauss points per edge, k = kappa E / h_e with the JSON's kappa and its own
smallest surface edge h_e, Newton with the penalty's exact tangent (k n n^T, and -k <-g_n>
(I - n n^T) / r where the closest point is on the disc). Linear plane-strain (or stress)
elasticity, quasi-static: at every t_i of the JSON it solves K u + f_c(u) = 0 from the last
step's u.

The needle force per unit thickness (N/m) that the tissue exerts on it is the sum over the
surface's nodes of its own contact forces, F = -int p n ds; the interpenetration (m) is the
largest -g_n over the deformed surface edges, each sampled at 9 points.

    python recipe_contact.py contact.json --out mine.xdmf --forces mine.csv

Writes the displacement at every t_i as XDMF (data inline, field "displacement") and, with
--forces, a CSV of t (s), F_x, F_y (N/m) and the interpenetration (m) at every t_i.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

sys.path.insert(0, str(Path(__file__).parent))
from recipe_solver import region_mask, write_xdmf  # noqa: E402 (beside this file)

GAUSS_2 = np.array([-1.0, 1.0]) / np.sqrt(3.0)  # 2-point Gauss on [-1, 1], weights 1
GAUSS_3 = (np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)]), np.array([5.0, 8.0, 5.0]) / 9.0)
SAMPLES = 9  # points per deformed surface edge for the interpenetration


def quad_grid(extents: list, per_metre: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 2) and counter-clockwise quadrilaterals (c, 4) of a grid on the 2D box."""
    (x0, x1), (y0, y1) = extents
    nx, ny = max(1, round((x1 - x0) * per_metre)), max(1, round((y1 - y0) * per_metre))
    x, y = np.linspace(x0, x1, nx + 1), np.linspace(y0, y1, ny + 1)
    points = np.array([(a, b) for b in y for a in x])
    index = np.arange(len(points)).reshape(ny + 1, nx + 1)
    cells = np.array(
        [
            (index[j, i], index[j, i + 1], index[j + 1, i + 1], index[j + 1, i])
            for j in range(ny)
            for i in range(nx)
        ]
    )
    return points, cells


def q1_stiffness(points: np.ndarray, cells: np.ndarray, lam: float, mu: float) -> sp.csr_matrix:
    """The Q1 stiffness (N/m per unit thickness), 2 x 2 Gauss, dofs node-major (k -> 2k, 2k+1)."""
    ref = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=float)
    D = np.array([[lam + 2 * mu, lam, 0], [lam, lam + 2 * mu, 0], [0, 0, mu]])
    rows, cols, vals = [], [], []
    for cell in cells:
        x = points[cell]
        k = np.zeros((8, 8))
        for xi in GAUSS_2:
            for eta in GAUSS_2:
                dN = 0.25 * np.array(
                    [ref[:, 0] * (1 + ref[:, 1] * eta), ref[:, 1] * (1 + ref[:, 0] * xi)]
                )  # (2, 4): d/dxi, d/deta
                jac = dN @ x  # (2, 2)
                grads = np.linalg.solve(jac, dN)  # (2, 4): d/dx, d/dy
                B = np.zeros((3, 8))
                B[0, 0::2], B[1, 1::2] = grads[0], grads[1]
                B[2, 0::2], B[2, 1::2] = grads[1], grads[0]
                k += B.T @ D @ B * np.linalg.det(jac)
        dofs = (cell[:, None] * 2 + np.arange(2)).ravel()
        rows.append(np.repeat(dofs, 8))
        cols.append(np.tile(dofs, 8))
        vals.append(k.ravel())
    n = 2 * len(points)
    return sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
    )


def surface_edges(cells: np.ndarray, on_surface: np.ndarray) -> np.ndarray:
    """The cells' edges (m, 2) whose two ends lie on the surface (node mask)."""
    edges = {
        tuple(sorted((int(c[i]), int(c[(i + 1) % 4]))))
        for c in cells
        for i in range(4)
        if on_surface[c[i]] and on_surface[c[(i + 1) % 4]]
    }
    return np.array(sorted(edges))


def gap_and_normal(x: np.ndarray, c: np.ndarray, radius: float):
    """(g, n, r, on_disc) at the points x (n, 2): the signed distance (m, negative inside) to
    the half-stadium of `radius` centred at c, its outward normal at the closest point, the
    distance r from c and whether the closest point is on the disc (not a flank)."""
    dx, dy = x[:, 0] - c[0], x[:, 1] - c[1]
    r = np.hypot(dx, dy)
    on_disc = dx < 0
    g = np.where(on_disc, r, np.abs(dy)) - radius
    safe = np.maximum(r, 1e-300)
    n = np.stack([np.where(on_disc, dx / safe, 0.0), np.where(on_disc, dy / safe, np.sign(dy))], 1)
    return g, n, safe, on_disc


def contact_terms(u, points, edges, c, radius, k):
    """The penalty's force vector f_c = d/du (k/2) int <-g_n>^2 ds (N/m per unit thickness, the
    force the needle's energy adds to the tissue's equations) and its tangent, 3 Gauss points
    per surface edge."""
    n_dofs = 2 * len(points)
    f = np.zeros(n_dofs)
    rows, cols, vals = [], [], []
    xs, ws = GAUSS_3
    for a, b in edges:
        length = np.linalg.norm(points[b] - points[a])
        phi = np.stack([(1 - xs) / 2, (1 + xs) / 2], 1)  # (3, 2)
        X = phi @ points[[a, b]]
        x = X + phi @ u.reshape(-1, 2)[[a, b]]
        g, n, r, on_disc = gap_and_normal(x, c, radius)
        dofs = np.array([2 * a, 2 * a + 1, 2 * b, 2 * b + 1])
        for q in range(len(xs)):
            if g[q] >= 0:
                continue
            weight = ws[q] * length / 2
            p = -k * g[q]  # Pa: the pressure on the tissue, along n
            N = np.kron(phi[q][:, None], np.eye(2))  # (4, 2): dofs x components
            f[dofs] += weight * N @ (-p * n[q])
            tangent = k * np.outer(n[q], n[q])
            if on_disc[q]:
                tangent -= p * (np.eye(2) - np.outer(n[q], n[q])) / r[q]
            rows.append(np.repeat(dofs, 4))
            cols.append(np.tile(dofs, 4))
            vals.append((weight * N @ tangent @ N.T).ravel())
    if rows:
        T = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n_dofs, n_dofs),
        )
    else:
        T = sp.csr_matrix((n_dofs, n_dofs))
    return f, T


def interpenetration(u, points, edges, c, radius) -> float:
    """The largest -g_n (m) over the deformed surface edges, SAMPLES points each; 0 if none."""
    s = np.linspace(0.0, 1.0, SAMPLES)[:, None]
    x = points + u.reshape(-1, 2)
    worst = 0.0
    for a, b in edges:
        g, _, _, _ = gap_and_normal((1 - s) * x[a] + s * x[b], c, radius)
        worst = max(worst, float(-g.min()))
    return worst


def solve(doc: dict, per_metre: float | None = None):
    """(points, cells, times, displacements, rows of t, F_x, F_y, interpenetration): the contact
    benchmark of the JSON doc, quasi-static, on our own Q1 grid."""
    if doc.get("schema") != "tissuebench.benchmark" or doc.get("version") != 2:
        raise SystemExit("not a tissuebench.benchmark JSON of version 2")
    contact = doc.get("contact")
    if contact is None or contact["shape"]["kind"] != "half-stadium":
        raise SystemExit("this solver poses a half-stadium tool in contact only")
    if doc["model"] != "linear" or int(doc["dimension"]) != 2:
        raise SystemExit("this solver is linear and 2D only")
    geometry, material = doc["geometry"], doc["material"]
    penalty, motion = contact["penalty"], contact["motion"]
    per_metre = per_metre or 1.0 / penalty["h_e"]
    points, cells = quad_grid(geometry["extents"], per_metre)
    E, nu = material["E"], material["nu"]
    mu = E / (2 * (1 + nu))
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    if doc["plane"] == "stress":
        lam = 2 * mu * lam / (lam + 2 * mu)
    K = q1_stiffness(points, cells, lam, mu)

    tol = geometry["tolerance"]
    clamped = np.zeros(len(points), dtype=bool)
    for c in doc["constraints"]:
        if not c["fixed"]:
            raise SystemExit(f"this solver clamps only; set {c['set']} moves")
        clamped |= region_mask(c["region"], points, tol)
    free = np.flatnonzero(~np.repeat(clamped, 2))
    edges = surface_edges(cells, region_mask(contact["law"]["surface"], points, tol))
    h_e = min(np.linalg.norm(points[b] - points[a]) for a, b in edges)
    k = penalty["kappa"] * E / h_e  # Pa/m
    radius = contact["shape"]["radius"]
    c0, s = np.array(motion["c0"]), motion["load_scale"]

    def centre(t: float) -> np.ndarray:
        return c0 + s * np.array([motion["v_x"] * min(t, motion["t_stop"]), 0.0])

    u = np.zeros(2 * len(points))
    displacements, rows = [u.copy()], [(0.0, 0.0, 0.0, 0.0)]
    scale = E * h_e  # N/m: a force per unit thickness of this problem's size
    for t in doc["time"]["t"][1:]:
        c = centre(t)
        for _ in range(50):  # Newton with the exact tangent
            f_c, T = contact_terms(u, points, edges, c, radius, k)
            residual = (K @ u + f_c)[free]
            if np.linalg.norm(residual) <= 1e-12 * scale:
                break
            A = (K + T)[free][:, free].tocsc()
            u[free] -= spla.spsolve(A, residual)
        else:
            raise SystemExit(f"Newton did not converge at t = {t} s")
        f_c, _ = contact_terms(u, points, edges, c, radius, k)
        F = f_c.reshape(-1, 2).sum(axis=0)  # -int p n ds: the force on the needle
        rows.append((t, F[0], F[1], interpenetration(u, points, edges, c, radius)))
        displacements.append(u.copy())
    return points, cells, doc["time"]["t"], displacements, rows, k


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("benchmark", type=Path, help="the exported JSON (version 2)")
    parser.add_argument("--out", type=Path, required=True, help="the XDMF series to write")
    parser.add_argument("--forces", type=Path, help="a CSV of t, F_x, F_y, interpenetration")
    parser.add_argument("--cells-per-metre", type=float, default=None)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    doc = json.loads(args.benchmark.read_text())
    points, cells, times, displacements, rows, k = solve(doc, args.cells_per_metre)
    wall = time.perf_counter() - start
    write_xdmf(args.out, points, cells, times, displacements)
    if args.forces:
        lines = ["t,force_x,force_y,interpenetration"]
        lines += [",".join(repr(float(v)) for v in row) for row in rows]
        args.forces.write_text("\n".join(lines) + "\n")
    print(
        f"{len(points)} nodes, {len(cells)} quadrilaterals, k = {k:.6g} Pa/m, "
        f"{len(times) - 1} steps in {wall:.2f} s: F = ({rows[-1][1]:.6g}, {rows[-1][2]:.6g}) "
        f"N/m at t = {rows[-1][0]:g} s; wrote {args.out}"
    )


if __name__ == "__main__":
    main(sys.argv[1:])
