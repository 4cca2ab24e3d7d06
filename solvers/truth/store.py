"""Where the truth lives (SPEC 10, issue 25 item 2): a case's hierarchy computed once, its own
error estimated, its finest level sampled for grading (samples.TruthSamples) and cached
outside git, keyed by the fingerprint of every input it was computed from.

- sample(truth, run): a truth run's displacement at the vertices of its mesh and at the
  Gauss-Legendre points (3 per direction) of its cells, with the cells (VTK order), the
  boundary facets and the quadrature weights, on rank 0 in a numbering that does not depend
  on the number of ranks (vertices by their input index, cells by their original index).
- truth_samples(case, quick): the TruthSamples of a SPEC 10 case, from the cache
  ($TISSUEBENCH_CACHE/truth/, default ~/.cache/tissuebench/truth/) or computed there.

The hierarchy (SPEC 10: three refined levels, the truth's step and its half on the finest):
rod n = 2, 4, 8 (16 x 8 x 8 hexahedra on the finest), block N = 20, 40, 80 (the linear ones
graded toward the needle's ends, cases.graded_block; MP1 steps h/4, MP2 h/16), each to the
benchmark's end time T = 10 s with its h = 1/30 s. Quick (CI and tests, never the truth):
rod n = 1, 2, 4 and block N = 10, 20, 40, 30 steps of h = 1/30 s (T = 1 s). The cylinder's
cases (SPEC 13) on its graded meridian, n = 10, 20, 40 (quick 4, 8, 16; cases.MERIDIAN_LEVELS):
their samples are the meridian's (2D, r and z), marked by inputs()["axisymmetric"]
(is_axisymmetric), and revolve.revolve() makes the 3D ones that grading needs; their own error
and size are of the revolved body (m^3).

Units: SI (m, s); E_i in m^3 (rod) and m^2 (block).
"""

from __future__ import annotations

import ast
import contextlib
import hashlib
import json
import math
import os
import re
import stat
import sys
import time
import zipfile
from pathlib import Path
from typing import Callable, cast

from mpi4py import MPI

import basix
import dolfinx.mesh
import numpy as np
from dolfinx import fem
from dolfinx.io.utils import cell_perm_vtk

from tissuebench.core import interrupt
from tissuebench.core.errors import UserError
from tissuebench.core.fingerprint import fingerprint
from tissuebench.core.speed import scaled
from tissuebench.meshes.benchmark import Benchmark
from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth.cases import CASES, MERIDIAN_LEVELS, STEP_DIVISOR, case_truth
from tissuebench.solvers.truth.estimate import estimate_error, interior_difference
from tissuebench.solvers.truth.floor import FLOOR_CASES, FLOOR_RTOL, FloorTruth
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.solvers.truth.solver import MIXED_NU, VOLUMETRIC, Truth, TruthRun
from tissuebench.solvers.truth.split import Levels, split_share, splittable
from tissuebench.solvers.truth.split import compute_split as _compute_split

SAMPLING = 2  # the version of sample() and compute(): part of the inputs (the cache key)
QUADRATURE_POINTS = 3  # Gauss-Legendre points per direction (metrics/crossmesh.py's rule)
QUICK_STEPS = 30  # quick: 30 steps of h = 1/30 s, T = 1 s
# SPEC 10: the truth's own E_i max at most this fraction of its E_i against rest (u' = 0, the
# maximum over steps): about 1.2e-5 m^3 on the linear rod, 4-5e-5 m^2 on the linear blocks
TARGET_FRACTION = 0.002
# s per step of h on each level (one rank): a level's wall time over its 300 steps, measured by
# `tissuebench truth all` from an empty cache on this 2-core machine, two cases at a time
MEASURED_STEP_SECONDS: dict[str, tuple] = {
    "rod-nh-s1": (0.0037, 0.026, 0.35),
    "rod-nhb-s3": (0.005, 0.033, 1.25),  # n = 8: Newton slows where J collapses (truth.md)
}
# wall time (s) of a full computation here, one rank, measured by `tissuebench truth all` from
# an empty cache (the hierarchy, the time order on the coarsest level, the half step and the
# sampling), two cases at a time on the machine's two cores: 1,146 s for all six. The linear
# cases' since their step matrices are factorised as L D L^T (solver.py's CHOLESKY): the CPU
# seconds of `tissuebench truth rod rod-MP2 block-MP1-w0.2 block-MP2-w0.2 --jobs 2` from an empty
# cache (50, 153, 64 and 207 s) over the probe's slowdown then (0.74-0.81: 0.77)
EXPECTED_SECONDS = {
    "rod": 65.0,
    "rod-nh-s1": 319.0,
    "rod-nhb-s3": 869.0,
    # SPEC 10's sweep below the fold, graded levels: as rod-nhb-s3 until measured here
    **{f"rod-nhb-s{s:g}": 869.0 for s in (2.0, 1.75, 1.5, 1.25)},
    # on uniform levels: rod-nhb-s1.75-uniform's n = 2, 4, 8 took 1.1, 8.9 and 103 s at h, two
    # truths at once (its half step, 662 s, ran beside three helpers' work: load 4 to 6): about
    # 330 s quiet, with the half step at twice the n = 8 level
    **{f"rod-nhb-s{s:g}-uniform": 330.0 for s in (2.0, 1.75)},
    "rod-MP2": 199.0,
    "block-MP1-w0.2": 83.0,
    "block-MP2-w0.2": 269.0,
    # the contact cases (with the 10 k check at the half step): their CPU seconds, computed two
    # or three at a time under a load of 4 to 8 (contact-MP1 624 s of CPU in 2,288 s of wall;
    # contact-MP1-nhb in proportion to its wall time, 2,602 s; contact-MP2 at s = 1 as measured
    # quiet before, with its 10 k run at h)
    "contact-MP1": 624.0,
    "contact-MP1-nhb": 710.0,
    "contact-MP2": 2709.0,
    "contact-MP2-s0.5": 950.0,
    # SPEC 13's cylinder on its meridian (n = 10, 20, 40, with the 10 k check at the half step):
    # cylinder-MP1-s0.5's CPU seconds, 809 s in 1,751 s of wall under a load of 4 to 8, over the
    # probe's 0.042 s then (0.04 here); cylinder-MP1 at s = 1 from its stages' wall times (19,
    # 185 and 561 s for the levels, 317 s the half step, about 1,900 s its 10 k run, Newton
    # slowing at the deep push: it was killed from outside at 90 % of that run) at the same
    # wall-to-CPU ratio, 2.2. MP2 and the neo-Hookean one as MP1 at the same s until measured
    # (their quick truths took 0.95 and 1.19 times cylinder-MP1's CPU time); s = 0.25 as 0.5.
    # Measured again on 2026-11-29, two at a time beside a leaderboard run: cylinder-MP1-s0.5
    # 797 s of CPU (1,477 s of wall), cylinder-MP2-s0.5 628 s (1,241 s)
    "cylinder-MP1": 1330.0,
    **{f"cylinder-{m}": 1330.0 for m in ("MP2", "MP1-nhb")},
    **{f"cylinder-{m}-s{s:g}": 764.0 for m in ("MP1", "MP2", "MP1-nhb") for s in (0.5, 0.25)},
    "cylinder-MP1-s0.5": 797.0,
    "cylinder-MP2-s0.5": 628.0,
}
PENALTY_CHECK = 10.0  # SPEC 12: the finest level of a contact case again with this times k
# the code a truth comes from: its fingerprint changes when any of these files does
SOURCES = (
    "solvers/truth/solver.py",
    "solvers/truth/cases.py",
    "solvers/truth/estimate.py",
    "solvers/materials.py",
    "meshes/benchmark.py",
    "meshes/rod.py",
    "meshes/block.py",
    "meshes/contact.py",
    "solvers/contact.py",
)
PACKAGE = Path(__file__).resolve().parents[2]  # the tissuebench package's folder
# SPEC 13: the code a meridian truth (cases.MERIDIAN_LEVELS) comes from besides SOURCES, in its
# key alone (inputs()["axisymmetric"]): its forms and mesh, the cylinder and its capsule
AXISYMMETRIC_SOURCES = (
    "solvers/truth/axisymmetric.py",
    "meshes/cylinder.py",
    "meshes/tools/tool.py",
    "meshes/tools/capsule.py",
    "meshes/tools/half_stadium.py",
)


def check_case(case: str) -> None:
    """Raise UserError (one line) unless `case` is a SPEC 10 truth case."""
    if case not in CASES:
        raise UserError(
            f"no truth for {case!r}: the truth cases are {', '.join(CASES)} (a point needle, "
            "w = 0, has no converged reference)"
        )


def levels_of(case: str, quick: bool = False) -> tuple[int, ...]:
    """The mesh sizes of a case's hierarchy (its benchmark's entry's truth levels)."""
    from tissuebench.meshes import get_entry

    if case in MERIDIAN_LEVELS:  # SPEC 13: the meridian's grids, not the 3D benchmark's
        return MERIDIAN_LEVELS[case][1 if quick else 0]
    entry = get_entry(CASES[case][0])
    return entry.quick_truth_levels if quick else entry.truth_levels


def expected_seconds(case: str, quick: bool = False, now: bool = True) -> float:
    """About how long the first computation of a case takes here, s (one rank): its time
    measured on the quiet machine of EXPECTED_SECONDS scaled by this machine's speed and load
    now (core/speed.py; not `now`: as measured, for a report that must not change with the
    load); a case not measured (a benchmark registered from elsewhere) takes ten times its
    quick estimate."""
    from tissuebench.meshes import get_entry

    factor = 5.0 if CASES[case][2] in VOLUMETRIC else 1.0  # neo-Hookean: about x 5
    quick_seconds = get_entry(CASES[case][0]).quick_truth_seconds * factor
    seconds = quick_seconds if quick else EXPECTED_SECONDS.get(case, 10 * quick_seconds)
    return scaled(seconds) if now else seconds


def _versions() -> dict:
    from importlib.metadata import version

    import petsc4py
    from petsc4py import PETSc

    return {
        "tissuebench": version("tissuebench"),
        "dolfinx": dolfinx.__version__,
        "basix": basix.__version__,
        "petsc4py": petsc4py.__version__,
        "petsc": ".".join(str(v) for v in PETSc.Sys.getVersion()),
        "numpy": np.__version__,
    }


class _Numerics(ast.NodeTransformer):
    """A module's syntax tree without what cannot change a number: imports, docstrings and
    type annotations (line numbers and comments are not in it)."""

    def visit_Import(self, node: ast.Import | ast.ImportFrom) -> None:  # noqa: N802 (ast's names)
        return None

    visit_ImportFrom = visit_Import

    def visit_Expr(self, node: ast.Expr) -> ast.AST | None:  # noqa: N802
        if isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            return None
        return self.generic_visit(node)

    def visit_arg(self, node: ast.arg) -> ast.arg:
        node.annotation = None
        return node

    def visit_FunctionDef(self, node: ast.FunctionDef) -> ast.AST:  # noqa: N802
        node.returns = None
        return self.generic_visit(node)

    def visit_AnnAssign(self, node: ast.AnnAssign) -> ast.AST:  # noqa: N802
        node.annotation = ast.Constant(None)
        return self.generic_visit(node)


# a source's code (_tree) by (its path, modification time in ns, size in bytes): parsed once
# per process while the file stays as it is (a case's inputs are asked for several times)
_TREES: dict[tuple[str, int, int], str] = {}


def _tree(path: Path) -> str:
    """The dump of a source's syntax tree without its docstrings and type hints (_Numerics)."""
    stat = path.stat()
    key = (str(path), stat.st_mtime_ns, stat.st_size)
    if key not in _TREES:
        _TREES[key] = ast.dump(_Numerics().visit(ast.parse(path.read_text())))
    return _TREES[key]


def code_hash(sources: tuple[str, ...] | None = None) -> str:
    """The SHA-256 of the truth's sources (`sources`, default SOURCES), in order: of their
    code, not of their text, so that moving an import, a docstring, a type hint or the layout
    keeps the cache."""
    digest = hashlib.sha256()
    for name in SOURCES if sources is None else sources:
        digest.update(name.encode())
        digest.update(_tree(PACKAGE / name).encode())
    return digest.hexdigest()


def inputs(case: str, quick: bool = False) -> dict:
    """Every input a case's truth is computed from (JSON-ready): the case's parameters and
    material, its levels, h and steps, the element and time rule, the sampling, the software's
    versions and the sources' hash. Its fingerprint is the cache key."""
    from tissuebench.meshes import get_entry

    check_case(case)
    benchmark, material, model, scale, width = CASES[case]
    mat = get_material(material)
    entry = get_entry(benchmark)
    steps = QUICK_STEPS if quick else round(entry.end_time / entry.dt)
    if model in VOLUMETRIC:
        form = "Taylor-Hood Q2-Q1-Q1 (u, p, p_d)"
    elif mat.nu >= MIXED_NU:
        form = "Taylor-Hood Q2-Q1 (u, p)"
    else:
        form = "Q2 (u)"
    # SPEC 12's check of a contact truth's penalty (penalty_check), which changed from the
    # step h to the half step: in the key of the contact cases alone, whose truths it is part of
    checks = {"penalty_check": {"times": PENALTY_CHECK, "step": "h / 2k"}} if entry.tool else {}
    if case in FLOOR_CASES:  # its Newton may stop at the round-off floor (floor.py): its key alone
        floor = code_hash(("solvers/truth/floor.py",))
        checks["newton_floor"] = {"rtol": FLOOR_RTOL, "code": floor}
    if case in MERIDIAN_LEVELS:  # SPEC 13: computed on the meridian; graders revolve it
        form = f"axisymmetric {form} on the meridian (r, z), dV = 2 pi r dr dz"
        checks["axisymmetric"] = {
            "axis": "z",
            "meridian": "(r, z) in [0, R_B] x [0, H]",
            "code": code_hash(AXISYMMETRIC_SOURCES),
        }
    return {
        **checks,
        "case": case,
        "benchmark": benchmark,
        "material": {k: getattr(mat, k) for k in ("name", "E", "nu", "rho", "alpha", "beta")},
        "model": model,
        "load_scale": scale,
        "needle_width": width,
        "levels": list(levels_of(case, quick)),
        "h": entry.dt,
        "step_divisor": STEP_DIVISOR.get(case, 1),
        "h_half": True,
        "steps": steps,
        "end_time": steps * entry.dt,
        "element": form,
        "time": "trapezoidal rule, consistent mass",
        "quadrature_points": QUADRATURE_POINTS,
        "sampling": SAMPLING,
        "quick": quick,
        "versions": _versions(),
        "code": code_hash(),
    }


def fingerprint_of(case: str, quick: bool = False) -> str:
    """The fingerprint of the case's inputs (core/fingerprint.py, as every run's)."""
    return fingerprint(inputs(case, quick))


def cache_dir() -> Path:
    """$TISSUEBENCH_CACHE/truth, default ~/.cache/tissuebench/truth."""
    root = os.environ.get("TISSUEBENCH_CACHE") or Path.home() / ".cache" / "tissuebench"
    return Path(root) / "truth"


def failure_path(case: str, quick: bool = False) -> Path:
    """The record of a case's last computation that failed (record_failure), beside its
    cache file: CASE[-quick]-FINGERPRINT.failed.json."""
    return cache_path(case, quick).with_suffix(".failed.json")


def record_failure(
    case: str, quick: bool, n: int, truth: Truth, info: dict, err: Exception, comm: MPI.Comm
) -> None:
    """Keep, as evidence, where a case's computation failed (a Newton solve that does not
    converge: SPEC 10's sweep below the fold records it): the level n, the time of the step
    that failed (s), the error, the smallest J of the last converged state and where (a
    neo-Hookean truth), and the levels computed before it with their smallest J. Collective;
    rank 0 writes. Cleared by the next computation that succeeds (_compute_and_store)."""
    jacobian = truth._jacobian() if truth._jacobian is not None else None  # collective
    t = float(truth.t.value)
    if comm.rank != 0:
        return
    record = {
        "case": case,
        "fingerprint": fingerprint_of(case, quick),
        "level": n,
        "t": t,
        "error": " ".join(str(err).split())[:300],
        "smallest_J": None if jacobian is None else float(jacobian[0]),
        "smallest_J_at": None if jacobian is None else np.asarray(jacobian[1]).tolist(),
        "levels_done": list(info["levels"]),
        "levels_done_smallest_J": [float(min(v)) for v in info.get("min_jacobian", [])],
        "wall": list(info["wall"]),
        "when": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
    }
    try:
        path = failure_path(case, quick)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(record, indent=1) + "\n")
    except OSError:
        pass  # evidence only: the error itself is raised either way


# a failure record's fields (record_failure) and what each must be, as its readers use them
FAILURE_FIELDS: dict[str, Callable[[object], bool]] = {
    "level": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "t": lambda v: _number(v),
    "error": lambda v: isinstance(v, str),
    "when": lambda v: isinstance(v, str),
    "smallest_J": lambda v: v is None or _number(v),
    "levels_done": lambda v: isinstance(v, list) and all(isinstance(x, int) for x in v),
    "levels_done_smallest_J": lambda v: isinstance(v, list) and all(_number(x) for x in v),
    "wall": lambda v: isinstance(v, list) and all(_number(x) for x in v),
}


def load_failure(case: str, quick: bool = False) -> dict | None:
    """The failure record of a case for today's inputs (record_failure), or None; a record
    that is not one (edited, cut short: not an object, a field missing or of another type) is
    said in one line on stderr and ignored."""
    path = failure_path(case, quick)
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(record, dict) or record.get("fingerprint") != fingerprint_of(case, quick):
        if not isinstance(record, dict):
            _stderr(f"truth {case}: {path} is no failure record (not an object); ignored")
        return None
    bad = [k for k, ok in FAILURE_FIELDS.items() if k not in record or not ok(record[k])]
    if bad:
        _stderr(f"truth {case}: {path} is no failure record ({', '.join(bad)}); ignored")
        return None
    return record


def cache_path(case: str, quick: bool = False) -> Path:
    """The cache file of a case's truth: CASE[-quick]-FINGERPRINT.npz."""
    key = fingerprint_of(case, quick)
    return cache_dir() / f"{case}{'-quick' if quick else ''}-{key[:20]}.npz"


# --- sampling -----------------------------------------------------------------------------------


def _facet_cycles(mesh: dolfinx.mesh.Mesh) -> np.ndarray:
    """The owned exterior facets as local geometry nodes, ordered around each facet and
    oriented as metrics.cells.boundary_facets orients them (outward: the domain on the left
    of an edge in 2D; a face's right-handed normal out of its cell in 3D)."""
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    facets = dolfinx.mesh.exterior_facet_indices(mesh.topology)
    nodes = dolfinx.mesh.entities_to_geometry(mesh, tdim - 1, facets)
    if nodes.shape[1] == 4:  # a quadrilateral face's vertices are in tensor order
        nodes = nodes[:, [0, 1, 3, 2]]
    f2c = mesh.topology.connectivity(tdim - 1, tdim)
    x = mesh.geometry.x[:, :gdim]
    owner = np.array([f2c.links(f)[0] for f in facets], dtype=np.int64)
    gdofs = mesh.geometry.dofmaps[0]
    inside = x[gdofs[owner]].mean(axis=1) if len(owner) else np.zeros((0, gdim))
    p = x[nodes]
    if gdim == 2:
        edge, to_inside = p[:, 1] - p[:, 0], inside - p[:, 0]
        keep = edge[:, 0] * to_inside[:, 1] - edge[:, 1] * to_inside[:, 0] > 0
    else:
        normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
        keep = np.einsum("ij,ij->i", normal, p.mean(axis=1) - inside) > 0
    return np.where(keep[:, None], nodes, nodes[:, ::-1])


def canonical_cycles(facets: np.ndarray) -> np.ndarray:
    """Each facet's cycle of vertices rotated to start at its smallest index (its direction
    kept), and the rows sorted: one order for the same set of oriented facets."""
    facets = np.asarray(facets)
    if len(facets) == 0:
        return facets
    first = np.argmin(facets, axis=1)
    m = facets.shape[1]
    rotated = np.take_along_axis(facets, (first[:, None] + np.arange(m)) % m, axis=1)
    return rotated[np.lexsort(rotated.T[::-1])]


def sample(
    truth: Truth | None,
    run: TruthRun,
    case: str = "",
    own_error: dict | None = None,
    inputs: dict | None = None,
    hierarchy: dict | None = None,
) -> TruthSamples | None:
    """The truth run's samples for grading (samples.TruthSamples): on rank 0, None elsewhere.
    Collective.

    vertices: the geometry nodes of the (first-order) mesh, ordered by their input index;
    cells: ordered by their original index, their vertices in VTK order; boundary: the
    exterior facets, ordered around each facet and oriented outward, rows sorted by their
    vertices; points and weights: Gauss-Legendre, QUADRATURE_POINTS per direction on each
    cell (w |det J|, m^gdim), cell by cell; u_vertices and u_points: the truth's Q2
    displacement there (m) at every kept step of `run`. These do not depend on the number of
    ranks."""
    V = run.V if run.V is not None else truth.V
    mesh = V.mesh
    comm = mesh.comm
    tdim, gdim = mesh.topology.dim, mesh.geometry.dim
    cell_type = mesh.topology.cell_name()
    if cell_type not in ("quadrilateral", "hexahedron") or mesh.geometry.cmaps[0].degree != 1:
        raise ValueError(f"sample() takes first-order quadrilaterals or hexahedra, not {cell_type}")
    if V.element.needs_dof_transformations:
        raise ValueError("sample() takes Lagrange spaces without dof transformations")
    n_cells = mesh.topology.index_map(tdim).size_local
    gdofs = mesh.geometry.dofmaps[0]
    nv = gdofs.shape[1]
    ids = np.asarray(mesh.geometry.input_global_indices, dtype=np.int64)
    n_nodes = mesh.geometry.index_map().size_local
    # the Q2 dof at each geometry node: the cell's vertex dofs (first order: node k = vertex k)
    vertex_dofs = [V.dofmap.dof_layout.entity_dofs(0, k)[0] for k in range(nv)]
    node_dof = np.empty(len(mesh.geometry.x), dtype=np.int64)
    node_dof[gdofs.ravel()] = V.dofmap.list[:, vertex_dofs].ravel()
    node_dof = node_dof[:n_nodes]

    perm = np.asarray(cell_perm_vtk(mesh.topology.cell_type, nv))  # VTK node k = DOLFINx perm[k]
    cells = ids[gdofs[:n_cells][:, perm]]
    original = np.asarray(mesh.topology.original_cell_index[:n_cells], dtype=np.int64)
    boundary = ids[_facet_cycles(mesh)]

    basix_cell = basix.CellType[cell_type]
    # basix annotates its arrays as ArrayLike
    xi, w = cast(
        tuple[np.ndarray, ...], basix.make_quadrature(basix_cell, 2 * QUADRATURE_POINTS - 1)
    )
    q1 = cast(
        np.ndarray, basix.create_element(basix.ElementFamily.P, basix_cell, 1).tabulate(1, xi)
    )[..., 0]
    X = mesh.geometry.x[gdofs[:n_cells], :gdim]  # (cells, nodes, gdim)
    points = np.einsum("qk,cki->cqi", q1[0], X)
    J = np.einsum("jqk,cki->cqij", q1[1:], X)
    weights = w * np.abs(np.linalg.det(J))  # (cells, q)
    phi = cast(np.ndarray, V.element.basix_element.tabulate(0, xi))[0, :, :, 0]  # (q, Q2 nodes)
    dofs = V.dofmap.list[:n_cells]

    fn = fem.Function(V)
    assert run.u is not None  # a run that kept its steps
    steps = len(run.u)
    u_vertices = np.empty((steps, n_nodes, gdim))
    u_points = np.empty((steps, n_cells, len(w), gdim))
    for k in range(steps):
        fn.x.array[: len(run.u[k])] = run.u[k]
        fn.x.scatter_forward()
        U = fn.x.array.reshape(-1, gdim)
        u_vertices[k] = U[node_dof]
        u_points[k] = np.einsum("qk,ckd->cqd", phi, U[dofs])

    mine = {
        "ids": ids[:n_nodes],
        "x": mesh.geometry.x[:n_nodes, :gdim],
        "original": original,
        "cells": cells,
        "boundary": boundary,
        "points": points,
        "weights": weights,
        "u_vertices": u_vertices,
        "u_points": u_points,
    }
    parts = comm.gather(mine, root=0)
    if comm.rank != 0:
        return None

    def joined(name, axis=0):
        return np.concatenate([part[name] for part in parts], axis=axis)

    node_ids = joined("ids")
    by_id = np.argsort(node_ids, kind="stable")
    sorted_ids = node_ids[by_id]

    def position(global_ids):
        return np.searchsorted(sorted_ids, global_ids)

    cell_order = np.argsort(joined("original"), kind="stable")
    facets = canonical_cycles(position(joined("boundary")))
    return TruthSamples(
        case=case,
        cell_type=cell_type,
        times=np.asarray(run.times, dtype=float),
        vertices=joined("x")[by_id],
        cells=position(joined("cells"))[cell_order],
        boundary=facets,
        points=joined("points")[cell_order].reshape(-1, gdim),
        weights=joined("weights")[cell_order].reshape(-1),
        u_vertices=joined("u_vertices", axis=1)[:, by_id],
        u_points=joined("u_points", axis=1)[:, cell_order].reshape(steps, -1, gdim),
        own_error=dict(own_error or {}),
        inputs=dict(inputs or {}),
        hierarchy=dict(hierarchy or {}),
    )


# --- computing a case ---------------------------------------------------------------------------


def _progress(comm: MPI.Comm, total: int, desc: str):
    """(on_step, close) of a tqdm bar on rank 0; on_step also lets a signal stop every rank
    together (interrupt.checkpoint)."""
    from tqdm import tqdm

    quiet = comm.rank != 0 or os.environ.get("TISSUEBENCH_PROGRESS_BARS") == "0"  # a worker
    bar = tqdm(total=total, desc=desc, unit="step", leave=False, disable=quiet, mininterval=0.5)

    def on_step(i: int) -> None:
        bar.update(1)
        interrupt.checkpoint(comm)

    return on_step, bar.close


def level_truth(case: str, n: int, comm: MPI.Comm) -> tuple[Truth, Benchmark]:
    """case_truth, as a FloorTruth for the cases in FLOOR_CASES (floor.py)."""
    truth, bench = case_truth(case, n, comm)
    return (FloorTruth(truth.problem), bench) if case in FLOOR_CASES else (truth, bench)


def floor_record(truth: Truth, level: str, info: dict) -> None:
    """Add to info["newton_floor"] the steps a FloorTruth took at the round-off floor, as
    [level, t in s, residual / its first value]."""
    if isinstance(truth, FloorTruth):
        record = info.setdefault("newton_floor", [])
        record.extend([level, t, ratio] for t, ratio in truth.floor_steps)
        truth.floor_steps.clear()


def _timed_run(truth: Truth, h: float, steps: int, keep: int, desc: str, comm) -> TruthRun:
    on_step, close = _progress(comm, steps, desc)
    try:
        return truth.run(h, steps, keep=keep, on_step=on_step)
    finally:
        close()


def time_differences(
    truth: Truth, run: TruthRun, h: float, k: int, steps: int, comm: MPI.Comm, info: dict
) -> list[float]:
    """[E_i max(step, step/2), E_i max(step/2, step/4)] (m^3 rod, m^2 block) of one level, the
    truth's step h / k, compared at the steps of h; `run` is that level at the step. Collective."""
    half = _timed_run(truth, h / (2 * k), 2 * k * steps, 2 * k, "half step", comm)
    quarter = _timed_run(truth, h / (4 * k), 4 * k * steps, 4 * k, "quarter step", comm)
    floor_record(truth, "time order", info)
    return [float(interior_difference(a, b).max()) for a, b in ((run, half), (half, quarter))]


def time_order(d1: float, d2: float, rule: float = 2.0) -> float:
    """The observed order in time, log2(d1 / d2), of the differences between a step and its half
    (d1) and the half and its quarter (d2), at most the rule's order (the trapezoidal rule's 2:
    above it is round-off or luck); NaN where the differences do not fall. The time error of a
    step is then its difference to its half times 2^q / (2^q - 1). Measured: the linear blocks
    are first order (0.92-1.13 from h to h/16): the needle stops at t = 2 s, a kink in the
    prescribed motion."""
    if d1 == 0 and d2 == 0:
        return rule  # nothing changes with the step (a static problem)
    if not (0 < d2 < d1):
        return float("nan")
    return min(float(np.log2(d1 / d2)), rule)


def penalty_check(
    case: str,
    n: int,
    half: TruthRun,
    k: int,
    steps: int,
    info: dict,
    comm: MPI.Comm,
    say: Callable[[str], None],
) -> None:
    """SPEC 12's limit of the penalty: the finest level n again with PENALTY_CHECK times the
    truth's penalty, at the half step h / 2k, against `half`, that level's own run at the half
    step with the truth's penalty; into info: "penalty_difference" (E_i max between the two at
    every step of h), "penalty_force_all" (its needle force at every half step, N/m),
    "penalty_step" and "penalty_wall" (s); or "penalty_failed" (why its Newton stopped: the
    check is said unmade, the case is kept). At the step h itself Newton cycles between active
    sets with 10 k (contact-MP1 from t = 0.87 s, contact-MP1-nhb from t = 0.3 s, measured: the
    first guess u + h v lies too far from the stiff penalty's active set); at h / 2 it runs
    through. Collective."""
    stiff_truth, bench = case_truth(case, n, comm, penalty=PENALTY_CHECK)
    info["penalty_step"] = bench.dt / (2 * k)
    try:
        stiff = _timed_run(
            stiff_truth, bench.dt / (2 * k), 2 * k * steps, 2 * k, f"{case} n={n} 10 k", comm
        )
    except RuntimeError as err:  # evidence, not a lost case: the check is said unmade
        info["penalty_failed"] = str(err)
        say(f"{case} n={n} with {PENALTY_CHECK:g} k: {err}; the penalty's limit is unchecked")
        return
    info["penalty_wall"] = comm.allreduce(stiff.wall, op=MPI.MAX)
    info["penalty_difference"] = interior_difference(half, stiff).tolist()
    info["penalty_force_all"] = np.asarray(stiff.force).tolist()
    say(f"{case} n={n} with {PENALTY_CHECK:g} k at the half step: {info['penalty_wall']:.1f} s")


def own_error(info: dict, time_ei: np.ndarray, gdim: int) -> dict:
    """A hierarchy's own error (estimate.estimate_error: m^3 in 3D, m^2 in 2D) from its level
    differences and `time_ei`, the finest level's E_i at each step between the step and its
    half; info["time_order"] is set from info["time_order_differences"] on the way."""
    info["time_order"] = order = time_order(*info["time_order_differences"])
    est = estimate_error(
        [max(d) for d in info["level_differences"]], float(time_ei.max()), time_order=order
    )
    return {
        "interior_error_max": est.total,
        "order": est.order,
        "space": est.space,
        "time": est.time,
        "units": "m^3" if gdim == 3 else "m^2",
        "how": "E_i max between the last two levels / (2^p - 1) plus E_i max(step, step/2) "
        "2^q / (2^q - 1), q the time order observed on the coarsest level",
    }


def compute(
    case: str,
    quick: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] | None = None,
) -> TruthSamples | None:
    """Compute a case's hierarchy (levels_of(case, quick) with the truth's step h / k on each,
    k = STEP_DIVISOR of the case or 1, and h / 2k on the finest), estimate its own error
    (estimate.estimate_error) and sample the finest level at the steps of h. On
    rank 0 the TruthSamples, None elsewhere. Collective. `log` is told each level's cost."""
    check_case(case)
    start = time.perf_counter()
    estimate = expected_seconds(case, quick)

    def say(line: str) -> None:  # each stage's line with the whole case's time so far and left
        spent = time.perf_counter() - start
        left = estimate - spent
        tail = f"about {words(left)} left" if left > 0 else f"past its estimate, {words(estimate)}"
        if log is not None:
            log(f"{line} ({spent:.0f} s in all, {tail})")

    given = inputs(case, quick)
    steps, k = given["steps"], given["step_divisor"]  # steps of h; the truth's step is h / k
    info: dict = {"levels": [], "dofs": [], "wall": [], "steps": steps, "level_differences": []}
    tips, statics = [], []
    previous = None
    for n in levels_of(case, quick):
        truth, bench = level_truth(case, n, comm)
        try:
            run = _timed_run(truth, bench.dt / k, k * steps, k, f"{case} n={n}", comm)
        except RuntimeError as err:  # Newton failed: where and how, kept as evidence
            record_failure(case, quick, n, truth, info, err, comm)
            raise
        floor_record(truth, str(n), info)
        wall = comm.allreduce(run.wall, op=MPI.MAX)
        info["levels"].append(n)
        info["dofs"].append(run.dofs)
        info["wall"].append(wall)
        info["h"], info["step"] = bench.dt, bench.dt / k
        if run.tip is not None:
            tips.append(np.asarray(run.tip)[::k].tolist())
            try:  # the static tip is reported beside the truth, never worth losing it for
                static = np.asarray(truth.tip(truth.static(steps * bench.dt)))
            except RuntimeError as err:
                say(f"{case} n={n}: {err}; its static tip is not reported")
                static = np.full(3, np.nan)
            statics.append(static.tolist())
        if run.min_jacobian is not None:  # neo-Hookean: SPEC 8's J > 0, and how close
            info.setdefault("min_jacobian", []).append(run.min_jacobian.values.tolist())
            info.setdefault("min_jacobian_at", []).append(
                [run.min_jacobian.at_time, *run.min_jacobian.at_point.tolist()]
            )
        if run.force is not None:  # SPEC 12: the needle's force at the steps of h, N/m
            info.setdefault("force_levels", []).append(np.asarray(run.force)[::k].tolist())
        if previous is not None:
            info["level_differences"].append(interior_difference(previous, run).tolist())
            previous.u = None  # the coarser level's history is no longer needed
        say(f"{case} n={n}: {run.dofs:,} dofs, {k * steps} steps, {wall:.1f} s")
        if previous is None:  # the coarsest level: the time order, from three steps
            info["time_order_differences"] = time_differences(
                truth, run, bench.dt, k, steps, comm, info
            )
            say(f"{case} n={n}: time order from its step, half and quarter")
        previous = run
    half = _timed_run(truth, bench.dt / (2 * k), 2 * k * steps, 2 * k, f"{case} n={n} half", comm)
    floor_record(truth, f"{n} half", info)
    info["half_wall"] = comm.allreduce(half.wall, op=MPI.MAX)
    if half.tip is not None:  # at every half of h
        info["half_tip"] = np.asarray(half.tip)[::k].tolist()
    if half.min_jacobian is not None:
        info["half_min_jacobian"] = half.min_jacobian.values.tolist()
    if half.force is not None:  # at every half step: sampled at the steps of h, the force's
        # step-to-step alternation under a stiff penalty would alias (contact/study.py)
        info["half_force_all"] = np.asarray(half.force).tolist()
    say(f"{case} n={n} half step: {2 * k * steps} steps, {info['half_wall']:.1f} s")
    time_ei = interior_difference(run, half)
    info["time_difference"] = time_ei.tolist()
    if truth.problem.contact is not None:  # SPEC 12: the penalty toward its limit, 10 k
        penalty_check(case, n, half, k, steps, info, comm, say)
    half = None
    if tips:
        info["tip"], info["static_tip"] = tips, statics
    own = own_error(info, time_ei, 3 if run.axisymmetric else bench.mesh.geometry.dim)
    samples = sample(truth, run, case, own, given, info)
    wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    if samples is not None:
        samples.hierarchy["total_wall"] = wall
    return samples


# --- the cache ----------------------------------------------------------------------------------

TEMPORARY = re.compile(r"\..+\.npz\.(?P<pid>\d+)\.tmp\.npz")  # TruthSamples.save's temporary


# s: what a case split into runs (split.py) still does in one process after them: the
# differences between levels and steps, the estimate and the sampling of the finest level
# (measured by `tissuebench bench --only paths`: about 11 s on the rod and on the blocks)
SPLIT_FIXED_SECONDS = 10.0


def compute_split(
    case: str, quick: bool, jobs: int, log: Callable[[str], None] | None = None
) -> TruthSamples | None:
    """compute()'s TruthSamples of a splittable case on one rank, its runs `jobs` at a time in
    worker processes (solvers/truth/split.py), bit for bit."""
    parts = Levels(inputs, level_truth, levels_of, own_error, sample)
    return _compute_split(case, quick, jobs, parts, log)


def expected_wall(case: str, quick: bool = False, jobs: int = 1) -> float:
    """About how long the first computation of a case takes here, s, its runs `jobs` at a time
    where it is splittable (split.py: the longest runs first, then SPLIT_FIXED_SECONDS in one
    process), else on one core."""
    seconds = expected_seconds(case, quick)
    if jobs > 1 and splittable(case, quick):
        fixed = min(scaled(SPLIT_FIXED_SECONDS), seconds)
        share = split_share(levels_of(case, quick), CASES[case][0], jobs)
        return (seconds - fixed) * share + fixed
    return seconds


def words(seconds: float) -> str:
    """A time in words: "3 min" from 90 s on, else "40 s"."""
    return f"{seconds / 60:.0f} min" if seconds >= 90 else f"{seconds:.0f} s"


def expected_words(case: str, quick: bool = False, jobs: int = 1) -> str:
    """How long the first computation of a case takes here, in words ("about 3 min"), its runs
    `jobs` at a time where it is splittable."""
    return f"about {words(expected_wall(case, quick, jobs))}"


def _check_npz(path: Path) -> None:
    """Raise ValueError naming the member when an .npz's arrays cannot be what their headers
    say (a header claiming more entries than the file holds, objects): before any array is
    allocated, so that a corrupt header never asks for terabytes."""
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            with archive.open(info) as f:
                version = np.lib.format.read_magic(f)
                if version == (1, 0):
                    shape, _, dtype = np.lib.format.read_array_header_1_0(f)
                elif version == (2, 0):
                    shape, _, dtype = np.lib.format.read_array_header_2_0(f)
                else:
                    raise ValueError(f"{info.filename}: npy format version {version}")
                if dtype.hasobject:
                    raise ValueError(f"{info.filename}: holds Python objects")
                need = math.prod(shape) * dtype.itemsize
                have = info.file_size - f.tell()
                if need != have:
                    raise ValueError(
                        f"{info.filename}: its header claims {math.prod(shape):,} entries "
                        f"({need:,} bytes), the file holds {have:,} bytes"
                    )


def _check_shapes(s: TruthSamples) -> None:
    """Raise ValueError unless the arrays of a TruthSamples fit one another."""
    steps, (nv, gdim), nq = len(s.times), s.vertices.shape, len(s.points)
    expected = {
        "times": (steps,),
        "points": (nq, gdim),
        "weights": (nq,),
        "u_vertices": (steps, nv, gdim),
        "u_points": (steps, nq, gdim),
    }
    for name, shape in expected.items():
        if getattr(s, name).shape != shape:
            raise ValueError(f"{name} has shape {getattr(s, name).shape}, not {shape}")
    if s.cells.size and (s.cells.min() < 0 or s.cells.max() >= nv):
        raise ValueError("cells name vertices it does not have")


def _read(case: str, quick: bool) -> tuple[TruthSamples | None, str | None]:
    """(the cached truth of a case for today's inputs or None, why its file cannot be read or
    None). Never raises but for a signal: anything a file can do (cut short, a corrupt header,
    bad JSON, a MemoryError) is a reason. Rank 0 (reads files only)."""
    path = cache_path(case, quick)
    if not path.is_file():
        return None, None
    try:
        _check_npz(path)
        samples = TruthSamples.load(path)
        _check_shapes(samples)
        judge(samples)
    except interrupt.Interrupted:
        raise
    except Exception as exc:  # any reason: the file is not a truth we can use
        why = " ".join(str(exc).split())[:160]
        return None, f"its cache file {path} cannot be read ({type(exc).__name__}: {why})"
    today = json.dumps(inputs(case, quick), sort_keys=True)
    if json.dumps(samples.inputs, sort_keys=True) != today:
        return None, None  # another truth under the same key prefix: not today's
    return samples, None


def size_of(samples: TruthSamples) -> float:
    """The truth's E_i against rest (u' = 0), its maximum over steps: |Omega_0|^(-1/d) times
    the largest ∫ |u| dX (m^3 rod, m^2 block; m^3 for a meridian's truth, of the revolved
    body: dX = 2 pi r dr dz, d = 3)."""
    w = np.asarray(samples.weights, dtype=np.float64)
    if is_axisymmetric(samples):
        w = w * 2 * np.pi * np.asarray(samples.points[:, 0], dtype=np.float64)
        return float(w.sum()) ** (-1.0 / 3) * max(
            float(w @ np.linalg.norm(np.asarray(u, dtype=np.float64), axis=1))
            for u in samples.u_points
        )
    scale = float(w.sum()) ** (-1.0 / samples.gdim)
    return scale * max(
        float(w @ np.linalg.norm(np.asarray(u, dtype=np.float64), axis=1)) for u in samples.u_points
    )


def is_axisymmetric(samples: TruthSamples) -> bool:
    """Whether these are a meridian truth's samples (SPEC 13: its inputs say it was computed
    on a meridian (r, z), and they are 2D): revolve.revolve() makes the 3D ones that grading
    needs (which keep the inputs, and are 3D)."""
    return "axisymmetric" in samples.inputs and samples.gdim == 2


def penalty_part(h: dict) -> float | None:
    """A contact truth's distance to its penalty's limit (m^2; SPEC 12), from the finest
    level's run at the half step with k and with 10 k (penalty_check): their E_i max
    difference d over 0.9, the error of k if it falls as 1/k (e(k) - e(10 k) = 0.9 e(k)).
    SPEC 12 asks d to be under a tenth of the truth's own error; where it is not, it is
    counted in that error as a third part beside space and time (judge). None where the check
    was not made at the half step (or not made at all)."""
    if "penalty_step" not in h or "penalty_difference" not in h:
        return None
    return float(max(h["penalty_difference"])) / 0.9


def judge(samples: TruthSamples) -> None:
    """Set the truth's SPEC 10 target in its own_error: "size" (size_of), "target" =
    TARGET_FRACTION x size and "meets_target" (its own E_i max at most the target), a contact
    truth's own E_i max being space + time + its penalty's part (penalty_part). Taken of the
    samples each time they are read, so a truth cached under an older target is judged by
    today's."""
    own = samples.own_error
    size = size_of(samples)
    penalty = penalty_part(samples.hierarchy)
    if penalty is not None and "space" in own and "time" in own:  # SPEC 12: counted in
        own["penalty"] = penalty
        own["interior_error_max"] = own["space"] + own["time"] + penalty
    total = own.get("interior_error_max")
    own["size"] = size
    own["target"] = TARGET_FRACTION * size
    own["meets_target"] = bool(total is not None and np.isfinite(total) and total <= own["target"])


def _stderr(line: str) -> None:
    print(f"tissuebench: {line}", file=sys.stderr, flush=True)


def load_cached(
    case: str,
    quick: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] | None = None,
) -> TruthSamples | None:
    """The cached truth of a case on rank 0 if there is a readable one for today's inputs (else
    None, said in one line where another process is computing it); None on other ranks.
    Whether one was found is the same on every rank: found(...). An unreadable file is said in
    one line to `log` (default stderr; rank 0), with the command that computes the truth
    again, and counts as not computed."""
    samples = None
    if comm.rank == 0:
        samples, problem = _read(case, quick)
        held = computing(case, quick, log) if samples is None else None
        if held is not None:  # a reader does not wait: it says why there is none yet
            (log or _stderr)(f"{being_computed(case, quick, held)}; not read until it ends")
        elif problem:
            (log or _stderr)(
                f"truth {case}{' (quick)' if quick else ''}: {problem}; it counts as not "
                f"computed: `tissuebench truth {case}{' --quick' if quick else ''}` computes it "
                f"again ({expected_words(case, quick)} on one core)"
            )
    return samples


def is_cached(case: str, quick: bool = False, comm: MPI.Comm = MPI.COMM_WORLD) -> bool:
    """Whether a readable cached truth exists for today's inputs (the same on every rank;
    nothing said of an unreadable file: whoever reads it says so)."""
    found = _read(case, quick)[0] is not None if comm.rank == 0 else None
    return bool(comm.bcast(found))


def _alive(pid: int) -> bool:
    """Whether a process of this id runs on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists, another user's
        return True
    return True


def remove_stale_temporaries(folder: Path, log: Callable[[str], None] | None = None) -> list[Path]:
    """Remove the temporary files that killed cache writes left in folder (TruthSamples.save
    writes .NAME.npz.PID.tmp.npz and renames it; a process killed before the rename leaves it):
    those whose process no longer runs here. Each is said in one line to `log`. Returns them."""
    removed = []
    for tmp in sorted(folder.glob(".*.tmp.npz")) if folder.is_dir() else []:
        m = TEMPORARY.fullmatch(tmp.name)
        if m is None or _alive(int(m["pid"])):
            continue  # not ours, or a write still under way
        try:
            size = tmp.stat().st_size
            tmp.unlink()
        except FileNotFoundError:
            continue
        except OSError as err:
            (log or _stderr)(f"truth cache: could not remove {tmp} ({err.strerror or err})")
            continue
        removed.append(tmp)
        (log or _stderr)(
            f"truth cache: removed {tmp} ({size / 1e6:.1f} MB), left by a write that was killed"
        )
    return removed


WAIT_REPORT_SECONDS = 60.0  # how often a process waiting for another's computation says so
WAIT_POLL_SECONDS = 2.0
LOCK_BOUND = 10.0  # a lock older than this many times its case's estimate is taken over
LOCK_FLOOR_SECONDS = 900.0  # ... and older than this (a quick case's estimate is seconds)
CLOCK_SLACK_SECONDS = 60.0  # a lock started later than now by more than this is invalid
PID_MAX = 1 << 22  # Linux's largest process id


def lock_path(case: str, quick: bool = False) -> Path:
    """The file that says a case's truth is being computed: {"pid", "started" (time.time()),
    "expected_s", "process_start" and "command" (the process's start in clock ticks after boot
    and its command line, from /proc: together they tell it from a later process of the same
    id), "cache" (the folder it computes into)}."""
    path = cache_path(case, quick)
    return path.with_name(f".{path.stem}.computing")


def process_identity(pid: int) -> dict:
    """{"process_start": clock ticks after boot, "command": its command line} of a process
    running here, from /proc; None for each where /proc does not say (no such process, or
    no /proc)."""
    try:
        status = Path(f"/proc/{pid}/stat").read_text()
        command = Path(f"/proc/{pid}/cmdline").read_bytes().decode("utf-8", "replace")
        start = int(status[status.rindex(")") + 2 :].split()[19])  # field 22, starttime
    except (OSError, ValueError, IndexError):
        return {"process_start": None, "command": None}
    return {"process_start": start, "command": command}


def _number(x: object) -> bool:
    """A finite int or float (not a bool) that a float holds."""
    try:
        return type(x) in (int, float) and math.isfinite(cast(float, x))
    except OverflowError:  # an int beyond any float
        return False


def lock_problem(held: object, lock: Path, case: str, quick: bool) -> str | None:
    """Why the lock `held` (its parsed JSON, found at `lock`) does not hold and is taken over,
    or None if it holds: a field missing or invalid (pid, started, expected_s, cache,
    process_start, command), written for another cache, its process gone or another one
    now (a start time or command line other than the lock's), or older than LOCK_BOUND times
    the case's estimate (and LOCK_FLOOR_SECONDS)."""
    if not isinstance(held, dict):
        return "not a lock (no JSON object)"
    pid, started, expected = held.get("pid"), held.get("started"), held.get("expected_s")
    if type(pid) is not int or not 0 < pid < PID_MAX:
        return f"an invalid pid ({pid!r:.40})"
    if not _number(started) or cast(float, started) <= 0:
        return f"an invalid start time ({started!r:.40})"
    now = time.time()
    if cast(float, started) > now + CLOCK_SLACK_SECONDS:
        return "a start time in the future"
    if not _number(expected) or cast(float, expected) <= 0:
        return f"an invalid estimate ({expected!r:.40})"
    cache = held.get("cache")
    try:
        ours = isinstance(cache, str) and Path(cache).resolve() == lock.parent.resolve()
    except (OSError, ValueError, RuntimeError):  # a NUL, a name too long, a symlink loop
        ours = False
    if not ours:
        return f"written for another cache ({cache!r:.80})"
    start, command = held.get("process_start"), held.get("command")
    if not (start is None or (type(start) is int and start >= 0)):
        return f"an invalid process start ({start!r:.40})"
    if not (command is None or isinstance(command, str)):
        return "an invalid command line"
    if not _alive(pid):
        return f"its process {pid} has gone"
    live = process_identity(pid)
    if live["command"] is not None:  # /proc says who runs under this id
        if start is None or command is None:
            return f"process {pid} is not identified (no start time or command line)"
        if live["process_start"] != start:
            return f"process {pid} is another process now (started at another time)"
        if live["command"] != command:
            shown = live["command"].replace("\0", " ").strip()
            return f"process {pid} is not the process that wrote it ({shown!r:.80})"
    age = now - cast(float, started)
    bound = max(LOCK_BOUND * expected_seconds(case, quick), LOCK_FLOOR_SECONDS)
    if age > bound:
        return f"{age / 60:.0f} min old, more than {LOCK_BOUND:g} times its estimate"
    return None


def computing(
    case: str, quick: bool = False, say: Callable[[str], None] | None = None
) -> dict | None:
    """The lock of a computation of this case under way in another process, else None. A lock
    that does not hold (lock_problem: unreadable, a field invalid, its process gone or not the
    one that wrote it, too old) is taken over: removed, with one line to `say` (default
    stderr) naming it and why."""
    lock = lock_path(case, quick)
    text: str | None = None
    try:
        if _regular(lock):  # not a folder, a link or a FIFO (which would block a reader)
            text = lock.read_text(errors="replace")
        else:
            problem = "not a file"
    except FileNotFoundError:
        return None
    except OSError as err:
        problem = f"cannot be read ({err.strerror or err})"
    if text is not None:
        try:
            held = json.loads(text)
        except (ValueError, RecursionError):
            held, problem = None, "cannot be parsed"
        else:
            if isinstance(held, dict) and held.get("pid") == os.getpid():
                return None  # this process's own
            problem = lock_problem(held, lock, case, quick)
            if problem is None:
                return held
    with contextlib.suppress(OSError):
        if text is None or lock.read_text(errors="replace") == text:  # not a new lock meanwhile
            lock.unlink(missing_ok=True)
    (say or _stderr)(f"truth {case}{' (quick)' if quick else ''}: took over {lock}: {problem}")
    return None


def _regular(path: Path) -> bool:
    """Whether path is a regular file, not through a link (FileNotFoundError if absent)."""
    return stat.S_ISREG(path.lstat().st_mode)


def _take_lock(case: str, quick: bool) -> bool:
    """Create the case's lock for this process, whole (written aside, then linked into place:
    no reader ever sees it empty); False where another process holds it (True, without a
    lock, where the cache folder cannot be written)."""
    lock = lock_path(case, quick)
    record = {
        "pid": os.getpid(),
        "started": time.time(),
        "expected_s": expected_seconds(case, quick),
        **process_identity(os.getpid()),
        "cache": str(lock.parent.resolve()),
    }
    tmp = lock.with_name(f"{lock.name}.{os.getpid()}.tmp")
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
        tmp.write_text(json.dumps(record))
        os.link(tmp, lock)
    except FileExistsError:
        with contextlib.suppress(OSError):
            if not _regular(lock):  # a folder there, which computing() cannot remove
                return True  # computed without a lock, as below
        return False
    except OSError:  # a cache that cannot be written: computed without a lock (and not kept)
        return True
    finally:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)
    return True


def _release_lock(case: str, quick: bool) -> None:
    """Remove the case's lock if it is this process's own (another may have taken it over)."""
    lock = lock_path(case, quick)
    with contextlib.suppress(OSError, ValueError, RecursionError):
        held = json.loads(lock.read_text()) if _regular(lock) else None
        if isinstance(held, dict) and held.get("pid") == os.getpid():
            lock.unlink(missing_ok=True)


def being_computed(case: str, quick: bool, held: dict) -> str:
    """'truth CASE: being computed by process N for M min (about K min left)', from its lock."""
    elapsed = time.time() - float(held["started"])
    left = float(held["expected_s"]) - elapsed
    return (
        f"truth {case}{' (quick)' if quick else ''}: being computed by process {held['pid']} "
        f"for {elapsed / 60:.0f} min "
        + (f"(about {left / 60:.0f} min left)" if left > 0 else "(past its estimate)")
    )


def wait_for(case: str, quick: bool, say: Callable[[str], None]) -> None:
    """Wait while another process computes this case, saying so now and every
    WAIT_REPORT_SECONDS (who, since when, about how long is left)."""
    last = -math.inf
    while (held := computing(case, quick, say)) is not None:
        now = time.time()
        if now - last >= WAIT_REPORT_SECONDS:
            say(f"{being_computed(case, quick, held)}; waiting for it")
            last = now
        time.sleep(WAIT_POLL_SECONDS)


def truth_samples(
    case: str,
    quick: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log: Callable[[str], None] | None = None,
    jobs: int = 1,
) -> TruthSamples | None:
    """The TruthSamples of a SPEC 10 case, from the cache or computed (and then cached): on
    rank 0, None elsewhere. Collective. `log(line)` (rank 0) hears where it comes from and,
    before a computation, how long it is expected to take; an unreadable cache file is said in
    one line (to `log`, else stderr) and computed again. UserError for a case that has no
    truth. On one rank with jobs > 1, a linear case's runs are computed `jobs` at a time
    (split.py: the same numbers)."""
    check_case(case)
    say = log if (log is not None and comm.rank == 0) else (lambda line: None)
    path = cache_path(case, quick) if comm.rank == 0 else None
    locked = False
    while True:  # another process computing this case: wait for it, then read its result
        if comm.rank == 0:
            wait_for(case, quick, log or _stderr)
        samples, problem = _read(case, quick) if comm.rank == 0 else (None, None)
        if comm.rank == 0 and samples is None:
            locked = _take_lock(case, quick)
        if comm.bcast(samples is not None or locked if comm.rank == 0 else None):
            break
    locked = comm.bcast(locked if comm.rank == 0 else None)
    if not locked:
        say(f"truth {case}{' (quick)' if quick else ''}: from the cache, {path}")
        return samples
    try:
        return _compute_and_store(case, quick, comm, log, say, path, problem, jobs)
    finally:
        if comm.rank == 0:
            _release_lock(case, quick)


def _compute_and_store(
    case, quick, comm, log, say, path, problem, jobs: int = 1
) -> TruthSamples | None:
    """truth_samples' computation, under the case's lock."""
    if problem:
        (log or _stderr)(f"truth {case}{' (quick)' if quick else ''}: {problem}; computed again")
    split = jobs > 1 and comm.size == 1 and splittable(case, quick)
    where = f"here, its runs {jobs} at a time" if split else "on one core here"
    say(
        f"truth {case}{' (quick)' if quick else ''}: not in the cache, computing it once "
        f"({expected_words(case, quick, jobs if split else 1)} {where}; later runs read {path})"
    )
    if split:
        samples = compute_split(case, quick, jobs, log=say)
    else:
        samples = compute(case, quick, comm, log=say)
    if samples is not None:
        judge(samples)

    def store():
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            remove_stale_temporaries(path.parent, log=log)
            samples.save(path)
        except OSError as err:
            say(
                f"truth {case}: could not be cached at {path} ({err.strerror or err}); "
                "it will be computed again next time"
            )

    if comm.rank == 0:
        store()
        failure_path(case, quick).unlink(missing_ok=True)  # computed now: no failure stands
    comm.barrier()
    return samples
