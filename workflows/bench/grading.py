"""Timing `tissuebench compare` on the reference's mesh against a candidate on its own mesh
(SPEC section 9): `python -m tissuebench.workflows.bench.grading [--n 12] [--steps 300]`.

The reference is the rod of benchmark B at mesh size n (2n x n x n hexahedra, SPEC 5); both
series are synthesised from smooth analytic fields (a bending rod whose amplitude oscillates
and decays; the candidate's amplitude is 3 % larger and a little late, plus a non-affine
ripple), written as XDMF and graded by `metrics.compare.grade`, reading included:

- same mesh: the candidate on the reference's nodes and cells (section 6, node for node);
- tetrahedra: the reference's hexahedra each split into six tetrahedra on the same nodes;
- rod n-1: the hexahedral rod one size coarser.

A second table times the point location alone, for the reference's nodes and the quadrature
points of E_i: metrics.cells.Locator (numpy grid of cell boxes, vectorised pull-back) against
DOLFINx (geometry.determine_point_ownership, and fem.create_interpolation_data with
Function.interpolate_nonmatching for the nodes). Collective: run it under mpiexec to time the
ranks together. Times are wall-clock seconds, the best of `--repeat` runs, with one BLAS
thread per rank unless OMP_NUM_THREADS and the like say otherwise.
"""

from __future__ import annotations

import os

# One BLAS/OpenMP thread per rank, as every timing of tissuebench (bench_measure.THREAD_VARS),
# unless set otherwise: set before numpy loads its BLAS.
for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import argparse  # noqa: E402
import shutil  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import TypeVar, cast  # noqa: E402

from mpi4py import MPI  # noqa: E402

import basix  # noqa: E402
import numpy as np  # noqa: E402
from dolfinx import fem, geometry  # noqa: E402

from tissuebench.meshes import get_benchmark, get_entry  # noqa: E402
from tissuebench.metrics.cells import Locator  # noqa: E402
from tissuebench.metrics.crossmesh import PointValues  # noqa: E402
from tissuebench.workflows.compare.grading import grade  # noqa: E402
from tissuebench.workflows.io.xdmf import gather_mesh, write_series  # noqa: E402

ROD = "rod"  # the benchmark whose meshes this bench grades
SIZE = get_entry(ROD).box  # m: the rod's length, height and depth


def rod_mesh(n: int, comm: MPI.Comm):
    """The rod's mesh at size n on comm (its TaggedMesh)."""
    return get_benchmark(ROD, mesh_size=n, comm=comm).tagged


T = TypeVar("T")
H = 1 / 30  # s, the rod's step
# Each hexahedron (VTK order) as six tetrahedra around its diagonal 0-6.
SIX_TETRAHEDRA = np.array(
    [[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
)


def rod(n: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(points (N, 3), hexahedra in VTK order) of the rod at mesh size n, on rank 0 (else None)."""
    tagged = rod_mesh(n, MPI.COMM_SELF) if MPI.COMM_WORLD.rank == 0 else None
    if tagged is None:
        return None
    V = fem.functionspace(tagged.mesh, ("Lagrange", 1, (3,)))
    mesh_data, _ = gather_mesh(V)
    assert mesh_data is not None  # V is on COMM_SELF: this is its rank 0
    points, cells, _ = mesh_data
    return points, cells


def bending(X: np.ndarray, amplitude: float, ripple: float = 0.0) -> np.ndarray:
    """u(X) (m) of a rod clamped at x = 0 bending in -y with tip deflection `amplitude` (m):
    w(x) = s² (3 − s) / 2 with s = x / L, plane sections turning with w′, and a non-affine
    ripple of size `ripple` (m)."""
    L, H_, D = SIZE
    s = X[:, 0] / L
    w = s**2 * (3 - s) / 2
    slope = 3 * s * (2 - s) / (2 * L)
    u = np.stack(
        [
            amplitude * (X[:, 1] - H_ / 2) * slope,
            -amplitude * w,
            0.1 * amplitude * (X[:, 2] - D / 2) * w / D,
        ],
        axis=1,
    )
    u[:, 1] += ripple * np.sin(9 * X[:, 0]) * np.cos(7 * X[:, 2]) * s
    return u


def amplitude(t: np.ndarray) -> np.ndarray:
    """Tip deflection (m) over time t (s): an overshoot oscillating about 0.01 m and decaying."""
    return 0.01 * (1 - np.cos(2 * np.pi * t / 1.5) * np.exp(-0.3 * t))


def write(
    path: Path, points: np.ndarray, cells: np.ndarray, cell_type: str, times: np.ndarray, late: bool
) -> None:
    """Write the synthesised series (reference, or with `late` the candidate) to path (.xdmf)."""
    if late:
        values = [bending(points, 1.03 * a, 2e-4 * a / 0.01) for a in amplitude(times - 0.01)]
    else:
        values = [bending(points, a) for a in amplitude(times)]
    write_series(path, ((points, cells, cell_type), {"displacement": np.array(values)}), times)


def timed(function: Callable[[], T], repeat: int) -> tuple[float, T | None]:
    """(the best wall time of `repeat` calls (s), the last result), with the ranks in step."""
    best, result = np.inf, None
    for _ in range(repeat):
        MPI.COMM_WORLD.barrier()
        start = time.perf_counter()
        result = function()
        MPI.COMM_WORLD.barrier()
        best = min(best, time.perf_counter() - start)
    return best, result


def grading_table(folder: Path, n: int, steps: int, repeat: int) -> list[tuple]:
    """Rows (case, candidate nodes, cells, seconds, ratio to same mesh, max E_n, max E_i)."""
    comm = MPI.COMM_WORLD
    times = H * np.arange(steps + 1)
    cases = {}
    if comm.rank == 0:
        points, hexes = cast(tuple[np.ndarray, np.ndarray], rod(n))  # rank 0's: not None
        coarse_points, coarse_hexes = cast(tuple[np.ndarray, np.ndarray], rod(n - 1))
        tets = hexes[:, SIX_TETRAHEDRA].reshape(-1, 4)
        write(folder / "reference.xdmf", points, hexes, "hexahedron", times, late=False)
        meshes = {
            "same mesh": (points, hexes, "hexahedron"),
            "tetrahedra (hexahedra split in 6)": (points, tets, "tetrahedron"),
            f"rod n = {n - 1} (hexahedra)": (coarse_points, coarse_hexes, "hexahedron"),
        }
        for k, (name, (p, c, kind)) in enumerate(meshes.items()):
            write(folder / f"candidate{k}.xdmf", p, c, kind, times, late=True)
            cases[name] = (folder / f"candidate{k}.xdmf", len(p), f"{len(c):,} {kind}")
    cases = comm.bcast(cases, root=0)
    rows = []
    for name, (path, nodes, cells) in cases.items():
        seconds, g = timed(lambda: grade(folder / "reference.xdmf", path, comm=comm), repeat)
        assert g is not None  # repeat >= 1
        rows.append(
            (
                name,
                nodes,
                cells,
                seconds,
                np.nanmax(g.curves["relative_error"]),
                np.nanmax(g.curves["interior_error"]),
            )
        )
    same = rows[0][3]
    return [(*row[:4], row[3] / same, *row[4:]) for row in rows]


def location_table(n: int, repeat: int) -> list[tuple]:
    """Rows (method, points, seconds): locating the reference's nodes and the quadrature points
    of E_i (degree 5, 27 per hexahedron) of the rod at size n in the rod at size n - 1, whole
    on every rank (numpy) or distributed like the reference (DOLFINx interpolates between
    meshes of one communicator only)."""
    comm = MPI.COMM_WORLD
    reference = rod_mesh(n, comm).mesh
    cand = rod_mesh(n - 1, comm).mesh
    V = fem.functionspace(reference, ("Lagrange", 1, (3,)))
    W = fem.functionspace(cand, ("Lagrange", 1, (3,)))
    owned = V.dofmap.index_map.size_local
    nodes = V.tabulate_dof_coordinates()[:owned]
    cells = reference.topology.index_map(3).size_local
    # basix annotates its arrays as ArrayLike
    xi = cast(np.ndarray, basix.make_quadrature(basix.CellType.hexahedron, 5)[0])
    element = basix.create_element(basix.ElementFamily.P, basix.CellType.hexahedron, 1)
    phi = cast(np.ndarray, element.tabulate(0, xi))[0, :, :, 0]
    X = reference.geometry.x[reference.geometry.dofmaps[0][:cells]]
    quadrature = np.einsum("qk,cki->cqi", phi, X).reshape(-1, 3)
    tol = 1e-6 * max(SIZE)

    whole, _ = gather_mesh(W)  # the candidate's nodes and cells (VTK order), on rank 0
    points, hexes, _ = comm.bcast(whole, root=0)
    rows = []
    for what, x in (("nodes", nodes), ("quadrature points", quadrature)):
        seconds, _ = timed(lambda: Locator(points, hexes, "hexahedron", tol).locate(x), repeat)
        rows.append((f"numpy grid + pull-back: {what}", comm.allreduce(len(x)), seconds))
        seconds, _ = timed(lambda: geometry.determine_point_ownership(cand, x, tol), repeat)
        rows.append((f"DOLFINx determine_point_ownership: {what}", comm.allreduce(len(x)), seconds))
    all_cells = np.arange(cells, dtype=np.int32)
    seconds, data = timed(
        lambda: fem.create_interpolation_data(V, W, all_cells, padding=tol), repeat
    )
    rows.append(("DOLFINx create_interpolation_data: nodes", comm.allreduce(owned), seconds))
    u_cand, u = fem.Function(W), fem.Function(V)
    u_cand.interpolate(lambda x: bending(x.T, 0.01).T)
    assert data is not None  # repeat >= 1
    seconds, _ = timed(lambda: u.interpolate_nonmatching(u_cand, all_cells, data), repeat)
    rows.append(
        ("DOLFINx interpolate_nonmatching, per step: nodes", comm.allreduce(owned), seconds)
    )
    values = Locator(points, hexes, "hexahedron", tol)
    for what, x in (("nodes", nodes), ("quadrature points", quadrature)):
        at = PointValues(values, x)
        field = bending(points, 0.01)
        seconds, _ = timed(lambda: at(field), repeat)
        rows.append((f"numpy evaluation, per step: {what}", comm.allreduce(len(x)), seconds))
    return rows


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=12, help="the rod's mesh size (default 12)")
    parser.add_argument("--steps", type=int, default=300, help="time steps (default 300)")
    parser.add_argument("--repeat", type=int, default=3, help="runs per timing (default 3)")
    args = parser.parse_args(argv)
    comm = MPI.COMM_WORLD
    folder = Path(comm.bcast(tempfile.mkdtemp(prefix="bench_grading_") if comm.rank == 0 else None))
    try:
        rows = grading_table(folder, args.n, args.steps, args.repeat)
        location = location_table(args.n, args.repeat)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(folder, ignore_errors=True)
    if comm.rank != 0:
        return
    print(
        f"grading a {args.steps}-step rod series (n = {args.n}), {comm.size} rank(s), best of "
        f"{args.repeat}"
    )
    print("| candidate | nodes | cells | time (s) | vs same mesh | max E_n | max E_i |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, nodes, cells, seconds, ratio, e_n, e_i in rows:
        print(
            f"| {name} | {nodes:,} | {cells} | {seconds:.2f} | {ratio:.2f}x | {e_n:.4g} | "
            f"{e_i:.4g} |"
        )
    print()
    print(f"point location, rod n = {args.n} in rod n = {args.n - 1}")
    print("| method | points | time (s) |")
    print("|---|---:|---:|")
    for method, points, seconds in location:
        print(f"| {method} | {points:,} | {seconds:.3f} |")


if __name__ == "__main__":
    main()
