"""The exported benchmark (`Exported`) as a file: JSON for any code (write_json, read_json)
and the mesh alone as .vtu or .msh (write_mesh). The CalculiX deck is io/calculix.py's;
posing a benchmark for export, workflows/posing.py.

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
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path


import numpy as np

from tissuebench.metrics.series import InputError
from tissuebench.solvers.materials import Material
from tissuebench.meshes.errors import UserError

SCHEMA = "tissuebench.benchmark"
SCHEMA_VERSION = 1
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


def dumps(value: object, indent: str = "") -> str:
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
