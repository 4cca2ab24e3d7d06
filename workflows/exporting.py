"""A benchmark posed for another simulator: its mesh, node sets, prescribed motion, body force,
material and time stepping, written as JSON (for any code), as a CalculiX deck (.inp, ready
for `ccx`) or as the mesh alone (.vtu, .msh); beside the JSON and the deck, our reference's
displacement history (XDMF), so that the other simulator's output can be graded with
`tissuebench compare` at once. `tissuebench export` (workflows/export.py) is the command.

JSON schema "tissuebench.benchmark", version 1
----------------------------------------------
SI units throughout (m, s, kg, Pa). One object:

- `schema`: "tissuebench.benchmark"; `version`: 1 (a reader refuses other versions).
- `benchmark`: "block" or "rod" (SPEC sections 4 and 5); `mesh_size`: N or n; `options`: the
  benchmark's own options ({"needle_width": w, "load_scale": s} for the block,
  {"load_scale": s} for the rod); `dimension`: 2 or 3; `plane`: "strain" or "stress" in 2D,
  null in 3D.
- `nodes`: [[x, y(, z)], ...], m; node i is row i (0-based; the deck numbers it i + 1).
- `cells`: {"type": "quadrilateral" | "hexahedron", "order": "vtk", "connectivity":
  [[n0, n1, ...], ...]}: first-order cells, corners in VTK order (a quadrilateral
  counter-clockwise; a hexahedron's face 0-1-2-3 then 4-5-6-7 above it), positive measure.
- `node_sets`: {name: [node, ...]}: every constrained set (the block: "needle", "left",
  "bottom", "top"; the rod: "clamped"), sorted node indices.
- `constraints`: [{"set": name, "fixed": bool, "u": [[...] per t_i], "v": ..., "a": ...}, ...]
  in the solver's order: every component of every node of the set follows the prescribed
  displacement u (m), velocity v (m/s) and acceleration a (m/s^2) at each t_i (arrays of
  shape (steps + 1, dimension), exact at the t_i; "fixed": all zero). A node in several sets
  follows the last of them (the fixed edges of the block share corners, with equal motion).
- `time`: {"h": s, "end_time": s, "steps": N, "t": [t_0 = 0, ..., t_N]} with t_i = i h.
- `body_force`: {"gravity": [g_x, ...] m/s^2, from t = 0 on, constant; the force density is
  rho g}.
- `material`: {"name", "E" (Pa), "nu", "rho" (kg/m^3), "alpha" (1/s), "beta" (s)}: Rayleigh
  damping C = alpha M + beta K_0 (SPEC sections 1, 2, 8).
- `model`: "linear", "svk", "neo-hookean" or "corotational" (SPEC section 8); `procedure`:
  "dynamic" (the reference is `implicit`, trapezoidal Newmark) or "static" (quasi-static:
  K u_i = f_i at every t_i).
- `initial_state`: "zero": u = v = 0 at t = 0 on the free nodes (SPEC section 3).
- `probe`: the rod's tip (m) or null.
- `reference`: null, or {"file": the XDMF beside the JSON, "field": "displacement",
  "run": its run label, "status": "ok" | "diverged", "steps": last step kept,
  "wall_time_s": s}: our run's displacement at every t_i on these nodes.

`read_json` returns the same `Exported` that was written (nodes, cells, sets, motions, ...).

The CalculiX deck
-----------------
*NODE and *ELEMENT (C3D8, C3D8I, C3D8R in 3D; CPE4, CPE4R in plane strain, CPS4, CPS4R in
plane stress, thickness 1 m), one *NSET per set, *MATERIAL with *ELASTIC (linear; with
NLGEOM it is St Venant-Kirchhoff: `svk`) or *HYPERELASTIC, NEO HOOKE with C10 = mu/2,
D1 = 2/kappa (`neo-hookean`, NLGEOM), *DENSITY, *DAMPING ALPHA, BETA (Rayleigh, whole model);
`corotational` has no CalculiX counterpart and is refused. Dynamic: one *STEP of fixed
increments h up to T, *DYNAMIC, DIRECT, ALPHA=0 (the trapezoidal rule); static: one
*STATIC step of length h per t_i (a linear static step is solved once, at its end). The
constrained nodes by *BOUNDARY (a moving component with an *AMPLITUDE in total time through
the kinks of its sampled motion, exact at every t_i) and *INITIAL CONDITIONS, TYPE=VELOCITY
for the needle's initial speed; gravity by *DLOAD GRAV with a constant amplitude from t = 0;
U at every increment to the .frd (*NODE FILE) and the .dat (*NODE PRINT). CalculiX writes no
result at t = 0: `compare` takes such a series to start from the zero initial state.

Measured against CalculiX 2.20 (tests/test_export.py): the rod, C3D8, linear, dynamic: E_n
below 1e-5 after the first 5 steps (CalculiX's initial acceleration solves
(M + (h/10)^2 K / 4) a_0 = f, not M a_0 = f: up to 4e-5 before); static: 2e-7. Known
departures, said in the deck as comments: with NLGEOM CalculiX damps with the current
stiffness, not beta K_0 (the rod: 0.8 % at t = 2 s; without damping 1e-6); a prescribed
motion in *DYNAMIC is followed otherwise than the SPEC (the block in CPE4: E_n up to 0.3 in
the first steps, E_i time-mean 7e-4; a one-layer C3D8 slab of it with u_z = 0 departs alike,
E_i time-mean 1.7e-4, with or without the initial velocity; the static block: 1e-7).
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import asdict, dataclass
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.series import InputError, cell_measures
from tissuebench.solvers.materials import Material
from tissuebench.workflows.errors import UserError

SCHEMA = "tissuebench.benchmark"
SCHEMA_VERSION = 1
FORMATS = ("json", "inp", "vtu", "msh")
# procedure -> our reference algorithm (the CalculiX step: dynamic_keyword, STATIC_KEYWORD)
PROCEDURES = {"dynamic": "implicit", "static": "quasi-static"}
STATIC_KEYWORD = "*STATIC, DIRECT"
# CalculiX element -> (dimension, plane: None in 3D)
ELEMENTS = {
    "C3D8": (3, None),
    "C3D8I": (3, None),
    "C3D8R": (3, None),
    "CPE4": (2, "strain"),
    "CPE4R": (2, "strain"),
    "CPS4": (2, "stress"),
    "CPS4R": (2, "stress"),
}
REFERENCE_FIELD = "displacement"
ZERO = 1e-300  # a motion whose every value is at most this (m, m/s) is no motion


class ExportError(UserError):
    """An export that cannot be written as asked: one line, exit status 2."""


@dataclass
class Exported:
    """A benchmark as exported: what the JSON holds (see the module docstring), in arrays.

    `nodes` (N, d) m; `cells` (C, 4 or 8) VTK order; `node_sets` {name: sorted node indices};
    `motions` {set name: (u, v, a)}, each (steps + 1, d), in the solver's constraint order;
    `gravity` (d,) m/s^2."""

    benchmark: str
    mesh_size: int
    options: dict
    plane: str | None
    material: Material
    model: str
    procedure: str
    h: float
    steps: int
    nodes: np.ndarray
    cell_type: str
    cells: np.ndarray
    node_sets: dict
    motions: dict
    gravity: np.ndarray
    probe: tuple | None = None
    reference: dict | None = None

    @property
    def dim(self) -> int:
        return self.nodes.shape[1]

    @property
    def end_time(self) -> float:
        return self.steps * self.h

    @property
    def times(self) -> np.ndarray:
        """t_i = i h, i = 0..steps (s), each computed as the product (SPEC section 3)."""
        return np.arange(self.steps + 1) * self.h

    def effective_sets(self) -> dict[str, np.ndarray]:
        """The constrained sets without the nodes that a later set of another motion takes
        (a node follows the last constraint that names it, as in the solver); sets of equal
        motion, such as the block's fixed edges, keep their shared corners."""
        names = list(self.motions)
        effective = {}
        for k, name in enumerate(names):
            nodes = self.node_sets[name]
            for later in names[k + 1 :]:
                if not all(
                    np.array_equal(a, b) for a, b in zip(self.motions[name], self.motions[later])
                ):
                    nodes = np.setdiff1d(nodes, self.node_sets[later])
            effective[name] = nodes
        return effective


# --- building ---------------------------------------------------------------------------------


def oriented(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """Cells (VTK order) with a positive area or volume: a quadrilateral taken clockwise, or a
    hexahedron whose bottom face is, is reversed (CalculiX refuses negative Jacobians)."""
    cells = np.array(cells, dtype=np.int64)
    negative = cell_measures(points, cells) < 0
    flip = [0, 3, 2, 1] if cells.shape[1] == 4 else [0, 3, 2, 1, 4, 7, 6, 5]
    cells[negative] = cells[negative][:, flip]
    return cells


def constrained_sets(bench, V) -> dict[str, np.ndarray]:
    """On rank 0: {constraint name: sorted global node indices of V} (None elsewhere)."""
    from dolfinx import fem

    mesh, imap = V.mesh, V.dofmap.index_map
    tdim = mesh.topology.dim
    local = {}
    for c in bench.constraints:
        mesh.topology.create_connectivity(c.dim, tdim)
        nodes = fem.locate_dofs_topological(V, c.dim, c.entities)
        nodes = nodes[nodes < imap.size_local]
        local[c.name] = imap.local_to_global(nodes.astype(np.int32)).astype(np.int64)
    parts = mesh.comm.gather(local, root=0)
    if mesh.comm.rank != 0:
        return None
    return {
        c.name: np.unique(np.concatenate([p[c.name] for p in parts])) for c in bench.constraints
    }


def sample_motion(motion, times: np.ndarray, dim: int) -> tuple[np.ndarray, ...]:
    """(u, v, a), each (len(times), dim), of a constraint's motion(t) at every time."""
    values = np.zeros((3, len(times), dim))
    for i, t in enumerate(times):
        for j, x in enumerate(motion(float(t))):
            values[j, i] = np.asarray(x, dtype=np.float64)[:dim]
    return values[0], values[1], values[2]


def build(
    benchmark: str,
    mesh_size: int,
    options: dict,
    material: Material,
    model: str,
    h: float,
    steps: int,
    plane: str,
    procedure: str,
    comm: MPI.Comm = MPI.COMM_WORLD,
):
    """Build the benchmark's mesh over comm and collect what an export holds. Collective;
    returns (Exported on rank 0 and None elsewhere, the Benchmark, its vector Q1 space)."""
    from dolfinx import fem

    from tissuebench.meshes import get_benchmark
    from tissuebench.workflows.xdmf import gather_mesh

    bench = get_benchmark(benchmark, mesh_size=mesh_size, comm=comm, **options)
    dim = bench.gdim
    V = fem.functionspace(bench.mesh, ("Lagrange", 1, (dim,)))
    mesh_data, _ = gather_mesh(V)
    sets = constrained_sets(bench, V)
    if comm.rank != 0:
        return None, bench, V
    points, cells, cell_type = mesh_data
    points = np.ascontiguousarray(points[:, :dim])
    times = np.arange(steps + 1) * h
    data = Exported(
        benchmark=benchmark,
        mesh_size=mesh_size,
        options={**bench.options},
        plane=plane if dim == 2 else None,
        material=material,
        model=model,
        procedure=procedure,
        h=h,
        steps=steps,
        nodes=points,
        cell_type=cell_type,
        cells=oriented(points, cells),
        node_sets=sets,
        motions={c.name: sample_motion(c.motion, times, dim) for c in bench.constraints},
        gravity=np.asarray(bench.gravity, dtype=np.float64)[:dim],
        probe=tuple(bench.probe) if bench.probe is not None else None,
    )
    return data, bench, V


def run_reference(
    data: Exported | None,
    bench,
    material: Material,
    path: Path,
    solver: str = "direct",
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> dict:
    """Run our reference for the export (`implicit`, or `quasi-static` for the static
    procedure, with the export's model) as `tissuebench run` runs it, and write its
    displacement history to path (.xdmf, with its .h5). Collective; returns what the JSON's
    `reference` records."""
    from tissuebench.solvers import get_integrator
    from tissuebench.solvers.models import run_label
    from tissuebench.solvers.simulate import simulate
    from tissuebench.solvers.system import System
    from tissuebench.workflows.output import collective
    from tissuebench.workflows.xdmf import gather_series, write_series

    model, procedure, h, steps, plane = comm.bcast(
        (data.model, data.procedure, data.h, data.steps, data.plane or "strain")
        if comm.rank == 0
        else None,
        root=0,
    )
    algorithm = PROCEDURES[procedure]
    label = run_label(algorithm, model)
    system = System(bench, material, plane=plane)
    integrator = get_integrator(algorithm, system, h, solver=solver, model=model)
    try:
        run = simulate(integrator, steps, bench.extent, label)
    finally:
        integrator.destroy()
    series = gather_series(system.V, {REFERENCE_FIELD: run.u})
    collective(comm, lambda: write_series(path, series, np.arange(run.steps + 1) * h), path)
    info = {
        "file": path.name,
        "field": REFERENCE_FIELD,
        "run": label,
        "status": run.status,
        "steps": run.steps,
        "wall_time_s": run.wall_time_s,
    }
    if run.status != "ok":
        info["diverged_step"], info["reason"] = run.diverged_step, run.reason
    if comm.rank == 0:
        state = (
            "ok" if run.status == "ok" else f"DIVERGED at step {run.diverged_step}: {run.reason}"
        )
        log(f"reference {label}: {state}, {run.steps} steps in {run.wall_time_s:.2f} s")
    return info


# --- JSON -------------------------------------------------------------------------------------


def to_json(data: Exported) -> dict:
    """The JSON object of the schema in the module docstring."""
    return {
        "schema": SCHEMA,
        "version": SCHEMA_VERSION,
        "benchmark": data.benchmark,
        "mesh_size": data.mesh_size,
        "options": dict(sorted(data.options.items())),
        "dimension": data.dim,
        "plane": data.plane,
        "units": {"length": "m", "time": "s", "mass": "kg", "stress": "Pa"},
        "nodes": data.nodes.tolist(),
        "cells": {"type": data.cell_type, "order": "vtk", "connectivity": data.cells.tolist()},
        "node_sets": {name: nodes.tolist() for name, nodes in data.node_sets.items()},
        "constraints": [
            {
                "set": name,
                "fixed": bool(all(np.all(np.abs(x) <= ZERO) for x in motion)),
                "u": motion[0].tolist(),
                "v": motion[1].tolist(),
                "a": motion[2].tolist(),
            }
            for name, motion in data.motions.items()
        ],
        "time": {
            "h": data.h,
            "end_time": data.end_time,
            "steps": data.steps,
            "t": data.times.tolist(),
        },
        "body_force": {"gravity": data.gravity.tolist()},
        "material": asdict(data.material),
        "model": data.model,
        "procedure": data.procedure,
        "initial_state": "zero",
        "probe": list(data.probe) if data.probe is not None else None,
        "reference": data.reference,
    }


def dumps(value, indent: str = "") -> str:
    """JSON text with every list of numbers (a node, a cell, a motion at one time) on one line
    and everything else indented."""
    inner = indent + " "
    if isinstance(value, dict) and value:
        items = [f"{inner}{json.dumps(k)}: {dumps(v, inner)}" for k, v in value.items()]
        return "{\n" + ",\n".join(items) + f"\n{indent}}}"
    if isinstance(value, list) and value and any(isinstance(v, (list, dict)) for v in value):
        return "[\n" + ",\n".join(inner + dumps(v, inner) for v in value) + f"\n{indent}]"
    return json.dumps(value, allow_nan=False)


def write_json(data: Exported, path: Path) -> None:
    Path(path).write_text(dumps(to_json(data)) + "\n")


def read_json(path: str | Path) -> Exported:
    """The Exported that write_json wrote to path. InputError (one line) for a file that is
    not such a JSON, of another version, or inconsistent."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, ValueError, RecursionError) as exc:
        raise InputError(
            f"{path}: not a readable JSON file ({' '.join(str(exc).split())})"
        ) from None
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        raise InputError(f'{path}: not a {SCHEMA} JSON (no "schema": "{SCHEMA}")')
    if doc.get("version") != SCHEMA_VERSION:
        raise InputError(
            f"{path}: {SCHEMA} version {doc.get('version')!r}; this tissuebench reads version "
            f"{SCHEMA_VERSION}"
        )
    try:
        dim = int(doc["dimension"])
        nodes = np.array(doc["nodes"], dtype=np.float64).reshape(-1, dim)
        cells = np.array(doc["cells"]["connectivity"], dtype=np.int64)
        steps = int(doc["time"]["steps"])
        motions = {
            c["set"]: tuple(np.array(c[k], dtype=np.float64).reshape(steps + 1, dim) for k in "uva")
            for c in doc["constraints"]
        }
        data = Exported(
            benchmark=doc["benchmark"],
            mesh_size=int(doc["mesh_size"]),
            options=dict(doc["options"]),
            plane=doc["plane"],
            material=Material(**doc["material"]),
            model=doc["model"],
            procedure=doc["procedure"],
            h=float(doc["time"]["h"]),
            steps=steps,
            nodes=nodes,
            cell_type=doc["cells"]["type"],
            cells=cells,
            node_sets={k: np.array(v, dtype=np.int64) for k, v in doc["node_sets"].items()},
            motions=motions,
            gravity=np.array(doc["body_force"]["gravity"], dtype=np.float64),
            probe=tuple(doc["probe"]) if doc.get("probe") is not None else None,
            reference=doc.get("reference"),
        )
    except UserError as exc:
        raise InputError(f"{path}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        raise InputError(
            f"{path}: not a valid {SCHEMA} JSON ({type(exc).__name__}: {' '.join(str(exc).split())})"
        ) from None
    per_cell = {"quadrilateral": 4, "hexahedron": 8}.get(data.cell_type)
    if per_cell is None or cells.ndim != 2 or cells.shape[1] != per_cell:
        raise InputError(
            f"{path}: cells must be quadrilaterals or hexahedra, got {data.cell_type!r}"
        )
    if cells.size and (cells.min() < 0 or cells.max() >= len(nodes)):
        raise InputError(f"{path}: a cell names a node outside 0..{len(nodes) - 1}")
    if set(data.motions) - set(data.node_sets):
        raise InputError(f"{path}: a constraint names a set that node_sets lacks")
    return data


# --- CalculiX ---------------------------------------------------------------------------------

MAX_FIELD = 20  # characters CalculiX reads of a number (f20.0)


def number(x: float) -> str:
    """A float as CalculiX reads it in full: the shortest repr when it fits 20 characters,
    else 14 significant digits."""
    text = repr(float(x))
    if len(text) <= MAX_FIELD:
        return text
    return f"{x:.13e}" if len(f"{x:.13e}") <= MAX_FIELD else f"{x:.11e}"


def ccx_name(name: str) -> str:
    """A set or material name as CalculiX takes it: letters, digits and _, at most 80."""
    return (re.sub(r"[^A-Za-z0-9_]", "_", name) or "X")[:80]


def kinks(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The indices of the samples that a piecewise linear function through them needs: the
    first, the last, and every one where the slope changes (beyond round-off). Linear
    interpolation between the kept samples gives every sample back."""
    n = len(times)
    if n <= 2:
        return np.arange(n)
    scale = max(float(np.abs(values).max()), ZERO)
    slopes = np.diff(values) / np.diff(times)
    change = np.abs(np.diff(slopes)) * np.diff(times)[1:] > 1e-12 * scale
    return np.flatnonzero(np.r_[True, change, True])


def check_element(element: str, dim: int, plane: str | None) -> None:
    if element not in ELEMENTS:
        raise ExportError(f"unknown element {element!r}: use one of {', '.join(ELEMENTS)}")
    edim, eplane = ELEMENTS[element]
    if edim != dim:
        raise ExportError(
            f"element {element} is {edim}D and the benchmark is {dim}D: use "
            f"{', '.join(e for e, (d, _) in ELEMENTS.items() if d == dim)}"
        )
    if dim == 2 and eplane != (plane or "strain"):
        raise ExportError(
            f"element {element} is plane {eplane} and the export is plane {plane or 'strain'}: use "
            f"{', '.join(e for e, (d, p) in ELEMENTS.items() if d == 2 and p == (plane or 'strain'))}"
        )


def default_element(dim: int, plane: str | None) -> str:
    return "C3D8" if dim == 3 else ("CPE4" if (plane or "strain") == "strain" else "CPS4")


def check_inp_model(model: str) -> None:
    if model == "corotational":
        raise ExportError(
            "the corotational model has no CalculiX material: export it as json, or use "
            "linear, svk (*ELASTIC with NLGEOM) or neo-hookean (*HYPERELASTIC, NEO HOOKE)"
        )


def lines_of(values: list[str], per_line: int) -> list[str]:
    return [", ".join(values[k : k + per_line]) for k in range(0, len(values), per_line)]


def dynamic_keyword(alpha: float = 0.0) -> str:
    """CalculiX's *DYNAMIC line with fixed increments h: implicit HHT-alpha, alpha in
    [-1/3, 0] (alpha = 0 is the trapezoidal rule, the SPEC's `implicit`; CalculiX's own
    default is -0.05, which damps high frequencies)."""
    if not -1 / 3 <= alpha <= 0:
        raise ExportError(f"CalculiX's HHT alpha must lie in [-1/3, 0], got {alpha!r}")
    return f"*DYNAMIC, DIRECT, ALPHA={number(alpha)}"


def inp_text(data: Exported, element: str | None = None, alpha: float = 0.0) -> str:
    """The CalculiX deck of the export (see the module docstring); `alpha` is the HHT
    parameter of the dynamic procedure (dynamic_keyword)."""
    element = element or default_element(data.dim, data.plane)
    check_element(element, data.dim, data.plane)
    check_inp_model(data.model)
    m = data.material
    nlgeom = data.model != "linear"
    times, end = data.times, data.end_time
    out = [
        f"** tissuebench export: benchmark {data.benchmark} (SPEC sections 4-5, 8), mesh size "
        f"{data.mesh_size}, options {json.dumps(dict(sorted(data.options.items())))}",
        f"** material {m.name}, model {data.model}, {data.procedure}: h = {data.h!r} s, "
        f"T = {end!r} s, {data.steps} steps; SI units (m, s, kg, N, Pa)",
        "** node i + 1 is node i of the JSON export; the zero initial state is at t = 0",
        "*HEADING",
        f"tissuebench {data.benchmark} {m.name} {data.model} {data.procedure}",
        "*NODE, NSET=Nall",
    ]
    for i, x in enumerate(data.nodes):
        out.append(", ".join([str(i + 1), *(number(c) for c in x)]))
    out.append(f"*ELEMENT, TYPE={element}, ELSET=Eall")
    for c, nodes in enumerate(data.cells):
        out.append(", ".join([str(c + 1), *(str(int(n) + 1) for n in nodes)]))
    names = {name: ccx_name(name) for name in data.node_sets}
    for name, nodes in data.node_sets.items():
        out.append(f"*NSET, NSET={names[name]}")
        out += lines_of([str(int(n) + 1) for n in nodes], 16)
    effective = data.effective_sets()
    bc_sets = {}
    for name, nodes in effective.items():
        if len(nodes) == len(data.node_sets[name]):
            bc_sets[name] = names[name]
        elif len(nodes):
            bc_sets[name] = f"{names[name]}_BC"[:80]
            out.append(f"*NSET, NSET={bc_sets[name]}")
            out += lines_of([str(int(n) + 1) for n in nodes], 16)

    material = ccx_name(m.name)
    out.append(f"** material {m.name!r}: E = {m.E!r} Pa, nu = {m.nu!r}, rho = {m.rho!r} kg/m^3")
    out.append(f"*MATERIAL, NAME={material}")
    if data.model == "neo-hookean":
        kappa = m.lmbda + 2 * m.mu / 3
        out.append(f"** NEO HOOKE: C10 = mu/2 = {m.mu / 2!r} Pa, D1 = 2/kappa = {2 / kappa!r} 1/Pa")
        out += ["*HYPERELASTIC, NEO HOOKE", f"{number(m.mu / 2)}, {number(2 / kappa)}"]
    else:
        out += ["*ELASTIC", f"{number(m.E)}, {number(m.nu)}"]
    out += ["*DENSITY", number(m.rho)]
    if data.procedure == "dynamic":
        if nlgeom and m.beta > 0:
            out.append(
                "** NLGEOM: CalculiX's stiffness damping follows the current stiffness, the "
                "SPEC's is beta K_0 (section 8): measured 0.8 % apart on the rod at t = 2 s"
            )
        out.append(f"*DAMPING, ALPHA={number(m.alpha)}, BETA={number(m.beta)}")
    out.append(f"*SOLID SECTION, ELSET=Eall, MATERIAL={material}")
    if data.dim == 2:
        out.append("1.")  # thickness, m

    amplitudes, boundaries, velocities = [], [], []
    for name, (u, v, _) in data.motions.items():
        if name not in bc_sets:
            continue
        scales = np.abs(u).max(axis=0)
        if np.all(scales <= ZERO):
            boundaries.append(("", f"{bc_sets[name]}, 1, {data.dim}"))
            continue
        for k in range(data.dim):
            scale = float(scales[k])
            if scale <= ZERO:
                boundaries.append(("", f"{bc_sets[name]}, {k + 1}, {k + 1}"))
                continue
            amp = f"A_{bc_sets[name]}_{k + 1}"[:80]
            keep = kinks(times, u[:, k])
            pairs = [f"{number(times[i])}, {number(u[i, k] / scale)}" for i in keep]
            amplitudes += [f"*AMPLITUDE, NAME={amp}, TIME=TOTAL TIME", *lines_of(pairs, 4)]
            boundaries.append((amp, f"{bc_sets[name]}, {k + 1}, {k + 1}, {number(scale)}"))
            if abs(v[0, k]) > ZERO:
                velocities.append(f"{bc_sets[name]}, {k + 1}, {number(v[0, k])}")
    gravity = float(np.linalg.norm(data.gravity))
    if gravity > 0:
        amplitudes += ["*AMPLITUDE, NAME=A_ON, TIME=TOTAL TIME", f"0., 1., {number(end)}, 1."]
    out += amplitudes
    if data.procedure == "dynamic" and len(amplitudes):
        out.append(
            "** CalculiX 2.20 follows a prescribed motion in *DYNAMIC otherwise than the SPEC "
            "(measured: the block at E_n up to 0.3 in CPE4 and in a C3D8 slab; static: 1e-7)"
        )
    if velocities and data.procedure == "dynamic":
        out += ["** the prescribed velocity at t = 0 (SPEC: the right derivative)"]
        out += ["*INITIAL CONDITIONS, TYPE=VELOCITY", *velocities]

    flags = ", NLGEOM" if nlgeom else ""
    output = ["*NODE FILE, FREQUENCY=1", "U", "*NODE PRINT, NSET=Nall, FREQUENCY=1", "U"]
    if data.procedure == "dynamic":  # one step of fixed increments h
        out += [f"*STEP{flags}, INC={data.steps + 10}", dynamic_keyword(alpha)]
        out.append(f"{number(data.h)}, {number(end)}")
    else:
        # one *STATIC step per t_i: a linear static step is solved once, at its end, whatever
        # its increments; the loads and boundaries carry over from step to step
        out += ["** quasi-static: one *STATIC step of length h per t_i (amplitudes in total time)"]
        out += [f"*STEP{flags}", STATIC_KEYWORD, f"{number(data.h)}, {number(data.h)}"]
    fixed = [line for amp, line in boundaries if not amp]
    if fixed:
        out += ["*BOUNDARY", *fixed]
    for amp, line in boundaries:
        if amp:
            out += [f"*BOUNDARY, AMPLITUDE={amp}", line]
    if gravity > 0:
        direction = [number(g / gravity) for g in data.gravity] + ["0."] * (3 - data.dim)
        out += ["*DLOAD, AMPLITUDE=A_ON", f"Eall, GRAV, {number(gravity)}, {', '.join(direction)}"]
    out += [*output, "*END STEP"]
    if data.procedure == "static":
        for _ in range(data.steps - 1):
            out += [f"*STEP{flags}", STATIC_KEYWORD, f"{number(data.h)}, {number(data.h)}"]
            out += [*output, "*END STEP"]
    out.append("")
    return "\n".join(out)


def write_inp(
    data: Exported,
    path: Path,
    element: str | None = None,
    alpha: float = 0.0,
) -> None:
    Path(path).write_text(inp_text(data, element, alpha))


# --- mesh files -------------------------------------------------------------------------------


def write_mesh(data: Exported, path: Path, fmt: str) -> None:
    """The mesh alone: .vtu (with a 0/1 point field per node set) or gmsh .msh (version 2.2,
    ASCII, which gmsh reads; meshio's 4.1 lacks the entities gmsh needs), through meshio."""
    import meshio

    points = np.c_[data.nodes, np.zeros((len(data.nodes), 3 - data.dim))]
    cell = "quad" if data.cell_type == "quadrilateral" else "hexahedron"
    if fmt == "vtu":
        indicator = {}
        for name, nodes in data.node_sets.items():
            values = np.zeros(len(points))
            values[nodes] = 1.0
            indicator[name] = values
        meshio.write(
            str(path),
            meshio.Mesh(points, [(cell, data.cells)], point_data=indicator),
            file_format="vtu",
        )
    elif fmt == "msh":
        ones = np.ones(len(data.cells), dtype=np.int32)
        mesh = meshio.Mesh(
            points,
            [(cell, data.cells)],
            cell_data={"gmsh:physical": [ones], "gmsh:geometrical": [ones]},
        )
        meshio.write(str(path), mesh, file_format="gmsh22", binary=False)
    else:
        raise ExportError(f"unknown mesh format {fmt!r}")


# --- files ------------------------------------------------------------------------------------


def reference_path(out: Path) -> Path:
    """Where the reference's history goes beside an export: OUT-stem.reference.xdmf (+ .h5)."""
    return out.with_name(f"{out.stem}.reference.xdmf")


def export(
    benchmark: str,
    fmt: str,
    out: Path,
    *,
    mesh_size: int,
    options: dict,
    material: Material,
    model: str,
    h: float,
    steps: int,
    plane: str = "strain",
    procedure: str = "dynamic",
    element: str | None = None,
    reference: bool = True,
    solver: str = "direct",
    force: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    log=print,
) -> list[Path]:
    """Write the export of format fmt to out and, for json and inp unless reference is False,
    our reference's history beside it (reference_path). Every check comes before the heavy
    work; every file is written under a temporary name and renamed into place. Collective;
    returns the files written."""
    from tissuebench.meshes import get_entry
    from tissuebench.workflows.output import PREFIX, check_file_target, collective, write_owned

    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r}: use one of {', '.join(FORMATS)}")
    if procedure not in PROCEDURES:
        raise ExportError(f"unknown procedure {procedure!r}: use {' or '.join(PROCEDURES)}")
    dim = get_entry(benchmark).gdim
    if fmt == "inp":
        element = element or default_element(dim, plane)
        check_element(element, dim, plane)
        check_inp_model(model)
    elif element is not None:
        raise ExportError(f"--element applies to --format inp only, not to {fmt}")
    with_reference = reference and fmt in ("json", "inp")
    ref_path = reference_path(out)
    also = [ref_path, ref_path.with_suffix(".h5")] if with_reference else []
    collective(comm, lambda: check_file_target(out, fmt, force, also))

    data, bench, _ = build(
        benchmark, mesh_size, options, material, model, h, steps, plane, procedure, comm
    )
    written = [out]
    if with_reference:
        staging = out.with_name(f"{PREFIX}export-{out.name}-{os.getpid()}")
        collective(comm, lambda: staging.mkdir(parents=True, exist_ok=True), staging)
        try:
            info = run_reference(data, bench, material, staging / ref_path.name, solver, comm, log)

            def place():
                for path in also[::-1]:  # the .h5 first: the .xdmf names it
                    write_owned(path, lambda tmp, name=path.name: os.replace(staging / name, tmp))

            collective(comm, place, ref_path)
        finally:
            if comm.rank == 0:
                for path in also:
                    (staging / path.name).unlink(missing_ok=True)
                if staging.is_dir():
                    staging.rmdir()
        if comm.rank == 0:
            data.reference = info
        written += also

    def write():
        if fmt == "json":
            write_owned(out, lambda p: write_json(data, p))
        elif fmt == "inp":
            write_owned(out, lambda p: write_inp(data, p, element))
        else:
            write_owned(out, lambda p: write_mesh(data, p, fmt))

    collective(comm, write, out)
    return written


def step_note(h: float, end_time: float, steps: int) -> str | None:
    """The line saying that h does not divide the end time, or None."""
    if math.isclose(steps * h, end_time, rel_tol=1e-9):
        return None
    return (
        f"end time {end_time:g} s is not a multiple of h = {h:g} s; exporting {steps} steps to "
        f"t = {steps * h:.6g} s"
    )
