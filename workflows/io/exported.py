"""The exported benchmark (`Exported`) as a file: JSON for any code (write_json, read_json)
and the mesh alone as .vtu or .msh (write_mesh). The CalculiX deck is io/calculix_deck.py's;
posing a benchmark for export, workflows/compare/posing.py.

JSON schema "tissuebench.benchmark", version 2
----------------------------------------------
SI units throughout (m, s, kg, Pa), and the file says so. The benchmark itself is defined in
meshes/BENCHMARKS.md; this file states it as data, so that a simulator can be set up from the
JSON alone. One object:

- `schema`: "tissuebench.benchmark"; `version`: 2 (a reader refuses other versions, saying
  to export again); `description`: one line naming the benchmark and meshes/BENCHMARKS.md.
- `benchmark`: "block", "rod" or "contact"; `mesh_size`: N or n; `options`: the benchmark's
  own options ({"needle_width": w (m), "load_scale": s} for the block, {"load_scale": s} for
  the rod, {"kappa": kappa, "load_scale": s} for contact);
  `dimension`: 2 or 3; `plane`: "strain" or "stress" in 2D, null in 3D.
- `units`: {quantity: unit} for every number in the file, by its path ("nodes": "m",
  "constraints.a": "m/s^2", "body_force.gravity": "m/s^2", "material.beta": "s", ...) and for
  the metrics a grade reports ("metrics.E_i": "m^3" in 3D, "m^2" in 2D; E_n and E_s "1").
- `geometry`: {"domain": "box", "axes": ["x", "y"(, "z")], "extents": [[min, max] per axis]
  (m), "regions": {set name: predicate}, "tolerance": m}: the undeformed body and, for every
  node set, the region it covers as a predicate on the coordinates ("x = 0",
  "x = 1 and |y - 0.5| <= 0.1"; terms joined by "and", each "c = v", "c <= v", "c >= v" or
  "|c - v| <= r", holding within the tolerance), so that any mesh of the box can find its
  constrained nodes. A body that is no box states its own domain beside the same keys (the
  cylinder: {"domain": "cylinder", "radius", "height", "extents": its bounding box, ...}).
  null for a benchmark whose geometry is not written here.
- `nodes`: [[x, y(, z)], ...], m; node i is row i (0-based; the deck numbers it i + 1).
- `cells`: {"type": "quadrilateral" | "hexahedron", "order": "vtk", "connectivity":
  [[n0, n1, ...], ...]}: first-order cells, corners in VTK order (a quadrilateral
  counter-clockwise; a hexahedron's face 0-1-2-3 then 4-5-6-7 above it), positive measure.
- `node_sets`: {name: [node, ...]}: every constrained set (the block: "needle", "left",
  "bottom", "top"; the rod: "clamped"), sorted node indices: the nodes of `nodes` on the
  set's region.
- `constraints`: [{"set": name, "region": predicate, "fixed": bool, "u": [[...] per t_i],
  "v": ..., "a": ...}, ...] in the solver's order; `constraint_semantics` says in words what
  they mean: every component of every node of the set follows the prescribed displacement u
  (m), velocity v (m/s) and acceleration a (m/s^2) at each t_i (arrays of shape (steps + 1,
  dimension), exact at the t_i); "fixed": true when all three are zero at every t_i (a
  clamp), false when the set moves (false never means free). A node in several sets follows
  the last of them (the fixed edges of the block share corners, with equal motion).
- `time`: {"h": s, "end_time": s, "steps": N, "t": [t_0 = 0, ..., t_N]} with t_i = i h.
- `body_force`: {"gravity": [g_x, ...] m/s^2, "meaning": words}: an acceleration, from
  t = 0 on, constant; the force per volume is rho g (N/m^3).
- `material`: {"name", "E" (Pa), "nu", "rho" (kg/m^3), "alpha" (1/s), "beta" (s)};
  `damping`: {"C": "alpha M + beta K_0", "K_0": words, ...}: Rayleigh damping with K_0 the
  linear stiffness at rest, for every model (the nonlinear ones too).
- `model`: "linear", "svk", "neo-hookean", "neo-hookean-barrier" or "corotational";
  `model_law`: that model's law in words (MODEL_LAWS: its stress or strain energy in the
  material's Lamé constants; for the neo-Hookean pair, which one CalculiX's NEO HOOKE is);
  `procedure`: "dynamic" or "static". The large cases (the rod MP3 at load scale 3, the
  block at 2) use "neo-hookean-barrier": the (J - 1)^2 law costs at most kappa/2 per unit
  volume to crush a volume to nothing, so under large loads its continuum problem need not
  have a solution (SPEC 8).
- `algorithm`: our reference's integrator, which `reference` ran: for "dynamic" {"name":
  "implicit", "scheme", "newmark_beta": 0.25, "newmark_gamma": 0.5, "update", "equation",
  "mass": "consistent", "damping", "initial_acceleration", "nonlinear_solve"}; for "static"
  {"name": "quasi-static", "equation", "mass": "none", ...}.
- `initial_state`: "zero": u = v = 0 at t = 0 on the free nodes.
- `probe`: null, or {"point": [x, y, z] (m), "meaning": words}: the rod's tip, a point (not a
  node) where the displacement is interpolated and reported; not a metric.
- `metrics`: {"E_n", "E_s", "E_i": definition and unit}: what `tissuebench compare` grades.
- `truth`: {"case": name, "compare": the command, "what", "own_error"} when a converged
  reference of this case exists (rod, rod-nh-s1, rod-nhb-s3, rod-MP2, block-MP1-w0.2,
  block-MP2-w0.2, at the benchmark's h and T), else {"case": null, "why": words}.
- `reference`: null, or {"file": the XDMF beside the JSON, "field": "displacement",
  "run": its run label, "status": "ok" | "diverged", "steps": last step kept,
  "wall_time_s": s}: our run's displacement at every t_i on these nodes; with contact also
  "contact": {"force": [[F_x, F_y] per t_i kept] (N/m), "interpenetration": [m per t_i]}.
- `contact` (only for a benchmark with a rigid tool in contact, SPEC 12; absent otherwise, so
  the other benchmarks' files are unchanged): the tool and the law, from its entry's `tool`
  (meshes/contact.py): "shape" ({"kind": "half-stadium", "words", "radius": R (m), the signed
  distance and outward normal in words}), "motion" ({"centre": "c(t) = c0 + s g(t)", "c0"
  (m), "load_scale", g's "v_x" (m/s) and "t_stop" (s), "c": [c(t_i)] (m) at every t_i}),
  "law" ({"words", "friction": "none", "surface": predicate ("x = 1"), "surface_nodes": the
  export's nodes on it, "gap", "conditions", "methods": any contact method may be used}),
  "penalty" (ours: {"k_formula": "k = kappa E / h_e", "kappa", "h_e" (m), "k" (Pa/m),
  "quadrature"}), "graded" (the displacement's E_n, E_s, E_i; the needle force F(t) in N/m,
  the force the tissue exerts on the needle; the interpenetration in m, the largest -g_n over
  the deformed surface) and "units" (paths within `contact`, also in `units` as "contact.*").

`read_json` returns the same `Exported` that was written (nodes, cells, sets, motions, ...).

Changes (CHANGES; a reader of another version is refused in one line that names them)
-------------------------------------------------------------------------------------
- Version 2 (from version 1): `probe` was [x, y, z] and is {"point": [x, y, z], "meaning":
  words} (read `probe["point"]`); `units` was {"length": "m", "time": "s", "mass": "kg",
  "stress": "Pa"} and is the unit of every number by its path; `body_force` gained
  "meaning" and each constraint its "region". Added: `description`, `geometry`,
  `constraint_semantics`, `damping`, `model_law`, `algorithm`, `metrics`, `truth`. Every
  other field keeps its name, shape and meaning.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from tissuebench.core.errors import UserError
from tissuebench.metrics.series import InputError
from tissuebench.solvers.materials import Material

SCHEMA = "tissuebench.benchmark"
# what each version changed from the one before, in one line (the docstring's Changes)
CHANGES = {
    2: 'probe [x, y, z] became {"point": [x, y, z], "meaning": ...} (read probe["point"]), '
    "units became the unit of every number by its path, and geometry, constraint_semantics, "
    "damping, model_law, algorithm, metrics and truth were added",
}
SCHEMA_VERSION = 2
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
    geometry: dict | None = None  # see the module docstring; posing.geometry builds it
    truth: dict | None = None  # {"case": name, ...} or {"case": None, "why": ...}
    contact: dict | None = None  # the rigid tool in contact (SPEC 12), posing.contact_object

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
                    np.array_equal(a, b)
                    for a, b in zip(self.motions[name], self.motions[later], strict=True)
                ):
                    nodes = np.setdiff1d(nodes, self.node_sets[later])
            effective[name] = nodes
        return effective


# --- building ---------------------------------------------------------------------------------


CONSTRAINT_SEMANTICS = {
    "prescribed": "every component of every node of the set is prescribed (a Dirichlet "
    "condition on all components): at t_i its displacement, velocity and acceleration are "
    "u[i], v[i] and a[i] exactly; the other nodes are free and solve the equation of motion "
    "with these values moved to the right-hand side",
    "fixed": "true when u, v and a are zero at every t_i (a clamp); false when the set moves "
    "as u, v and a say. Either way every component is prescribed: false never means free",
    "u": "prescribed displacement (m) at each t_i: (steps + 1) rows of dimension components",
    "v": "prescribed velocity (m/s) at each t_i, the right derivative of u where u has a kink "
    "(the block's needle stops at t = 2 s: v = 0 from t_60 on)",
    "a": "prescribed acceleration (m/s^2) at each t_i",
    "overlap": "a node in several sets follows the last of them in this list (the block's "
    "fixed edges share corners, with equal motion)",
    "free": "a node in no set is free: u = v = 0 at t = 0, then the equation of motion",
}

DAMPING = {
    "C": "alpha M + beta K_0",
    "K_0": "the linear stiffness at rest (at u = 0), for every model: a nonlinear model damps "
    "with beta K_0 v too, not with its tangent, so that models differ by elasticity alone",
    "M": "the scheme's mass matrix (the reference's: consistent)",
    "continuum": "per unit volume alpha rho v . w + beta sigma_lin(v) : eps(w), sigma_lin the "
    "linear elastic law",
    "mass_damping_only": "dropping beta (C = alpha M, as many explicit codes do) is a "
    "departure from this benchmark, graded as such: meshes/BENCHMARKS.md gives its measured "
    "cost",
}


# the law of each model (SPEC 8), as `model_law` states it; mu, lambda the material's Lame
# constants (Pa) of E and nu (plane stress: lambda* = 2 mu lambda / (lambda + 2 mu))
HYPERELASTIC = (
    "P = dpsi/dF, F = I + grad u, J = det F, I1 = tr(F^T F), kappa = lambda + 2 mu / 3 (Pa); "
    "in 2D plane strain, F33 = 1"
)
MODEL_LAWS = {
    "linear": "small strain: sigma = 2 mu eps + lambda tr(eps) I, eps = (grad u + grad u^T) / 2 "
    "(f_int = K u); mu, lambda the Lame constants of E and nu (Pa)",
    "svk": "St Venant-Kirchhoff: P = F S, S = lambda tr(E) I + 2 mu E, E = (F^T F - I) / 2; "
    "2D plane strain",
    "neo-hookean": "psi = (mu/2)(J^(-2/3) I1 - 3) + (kappa/2)(J - 1)^2 (J/m^3); "
    + HYPERELASTIC
    + ". CalculiX's and Abaqus's NEO HOOKE with C10 = mu/2, D1 = 2/kappa",
    "neo-hookean-barrier": "psi = (mu/2)(J^(-2/3) I1 - 3) + (kappa/4)(J^2 - 1 - 2 ln J) "
    "(J/m^3), Simo and Taylor's volumetric energy; "
    + HYPERELASTIC
    + ". Equal to neo-hookean to second order in J - 1, but its energy grows without bound "
    "as J -> 0, so no finite load crushes a volume to nothing (neo-hookean's costs at most "
    "kappa/2 per unit volume): the law of the large cases. Not CalculiX's NEO HOOKE, which is "
    "the (kappa/2)(J - 1)^2 law: a simulator with that law differs from this one at large "
    "compression, and the difference is part of its error",
    "corotational": "per cell, R = the rotation of the polar decomposition of F at the cell "
    "centre; f_int,e = R K_e (R^T x_e - X_e), x_e = X_e + u_e, K_e the linear element "
    "stiffness; tangent R K_e R^T",
}


def model_law(model: str) -> str:
    """The law of an elastic model in words (MODEL_LAWS; an unknown model: its name only)."""
    return MODEL_LAWS.get(model, f"the {model} model (SPEC 8)")


def units(dim: int) -> dict[str, str]:
    """{JSON path: unit} of every number the file holds, and of the metrics a grade reports
    (E_i: m^3 in 3D, m^2 in 2D; "1": dimensionless)."""
    return {
        "length": "m",
        "time": "s",
        "mass": "kg",
        "stress": "Pa",
        "nodes": "m",
        "geometry.extents": "m",
        "geometry.tolerance": "m",
        "options.needle_width": "m",
        "options.load_scale": "1",
        "constraints.u": "m",
        "constraints.v": "m/s",
        "constraints.a": "m/s^2",
        "time.h": "s",
        "time.end_time": "s",
        "time.t": "s",
        "body_force.gravity": "m/s^2",
        "body_force.density": "N/m^3 (rho g)",
        "material.E": "Pa",
        "material.nu": "1",
        "material.rho": "kg/m^3",
        "material.alpha": "1/s",
        "material.beta": "s",
        "probe.point": "m",
        "reference.wall_time_s": "s",
        "metrics.E_n": "1",
        "metrics.E_s": "1",
        "metrics.E_i": f"m^{dim}",
    }


def metrics(dim: int) -> dict[str, str]:
    """What `tissuebench compare` grades, each with its unit (in words)."""
    body = "area" if dim == 2 else "volume"
    return {
        "E_n": "relative displacement error ||u' - u|| / ||u||, Euclidean norms of all nodal "
        "displacement components at the reference's nodes (u' evaluated there); "
        "dimensionless; NaN where u = 0 (step 0)",
        "E_s": f"surface error |Omega_t xor Omega'_t| / |Omega_t|, the {body} of the "
        "symmetric difference of the two deformed bodies over the reference's; dimensionless",
        "E_i": f"interior error |Omega_0|^(-1/{dim}) integral over Omega_0 of ||u'(X) - u(X)|| "
        f"dX, by Gauss quadrature on the reference's cells; m^{dim}",
        "summaries": "the maximum and the time-mean of each curve over steps 1..N",
    }


def algorithm(procedure: str) -> dict:
    """Our reference's integrator for a procedure ("dynamic": implicit, "static":
    quasi-static), its Newmark parameters in the usual notation (beta = SPEC's beta_N / 2)
    taken from the solvers' registry."""
    from tissuebench.solvers import ALGORITHMS

    if procedure == "static":
        return {
            "name": "quasi-static",
            "equation": "f_int(u_i) = f_i at every t_i (K u_i = f_i for the linear model): no "
            "inertia, no damping, no history; v and a reported as zero",
            "mass": ALGORITHMS["quasi-static"].mass,
            "nonlinear_solve": "Newton (PETSc SNES, line search) to a relative residual of "
            "1e-10, from the previous step's solution, the load step halved up to 6 times "
            "when Newton fails",
        }
    entry = ALGORITHMS["implicit"]
    assert entry.beta_N is not None  # a Newmark scheme's
    return {
        "name": "implicit",
        "scheme": "Newmark's trapezoidal rule (average acceleration), unconditionally stable",
        "newmark_beta": entry.beta_N / 2,
        "newmark_gamma": entry.gamma,
        "update": "u_{i+1} = u_i + h v_i + h^2 ((1/2 - beta) a_i + beta a_{i+1}); "
        "v_{i+1} = v_i + h ((1 - gamma) a_i + gamma a_{i+1})",
        "equation": "M a_{i+1} + C v_{i+1} + f_int(u_{i+1}) = f_{i+1} at every t_{i+1} = "
        "(i + 1) h (f_int = K u for the linear model)",
        "mass": entry.mass,
        "damping": DAMPING["C"] + ", K_0 the linear stiffness at rest",
        "initial_acceleration": "a_0 on the free nodes solves the equation of motion at t = 0 "
        "with u = v = 0 there and the prescribed u, v, a on the constrained nodes",
        "nonlinear_solve": "Newton (PETSc SNES, line search) to a relative residual of 1e-10 "
        "per step",
    }


def to_json(data: Exported) -> dict:
    """The JSON object of the schema in the module docstring."""
    d = data.dim
    regions = (data.geometry or {}).get("regions", {})
    probe = None
    if data.probe is not None:
        probe = {
            "point": list(data.probe),
            "meaning": "the rod's tip, the middle of the top edge of the free end: a point, "
            "not a node; its displacement is the finite-element displacement interpolated "
            "there (tip.csv of a run); reported, not graded",
        }
    doc = {
        "schema": SCHEMA,
        "version": SCHEMA_VERSION,
        "description": f"the tissuebench benchmark {data.benchmark!r} as data; defined in "
        "meshes/BENCHMARKS.md of the tissuebench project",
        "benchmark": data.benchmark,
        "mesh_size": data.mesh_size,
        "options": dict(sorted(data.options.items())),
        "dimension": d,
        "plane": data.plane,
        "units": units(d),
        "geometry": data.geometry,
        "nodes": data.nodes.tolist(),
        "cells": {"type": data.cell_type, "order": "vtk", "connectivity": data.cells.tolist()},
        "node_sets": {name: nodes.tolist() for name, nodes in data.node_sets.items()},
        "constraints": [
            {
                "set": name,
                "region": regions.get(name),
                "fixed": bool(all(np.all(np.abs(x) <= ZERO) for x in motion)),
                "u": motion[0].tolist(),
                "v": motion[1].tolist(),
                "a": motion[2].tolist(),
            }
            for name, motion in data.motions.items()
        ],
        "constraint_semantics": CONSTRAINT_SEMANTICS,
        "time": {
            "h": data.h,
            "end_time": data.end_time,
            "steps": data.steps,
            "t": data.times.tolist(),
        },
        "body_force": {
            "gravity": data.gravity.tolist(),
            "meaning": "an acceleration (m/s^2), on from t = 0 and constant; the force per "
            "volume is rho g (N/m^3), the load vector the integral of rho g . w",
        },
        "material": asdict(data.material),
        "damping": DAMPING,
        "model": data.model,
        "model_law": model_law(data.model),
        "procedure": data.procedure,
        "algorithm": algorithm(data.procedure),
        "initial_state": "zero",
        "probe": probe,
        "metrics": metrics(d),
        "truth": data.truth,
        "reference": data.reference,
    }
    if data.contact is not None:  # only then: the other benchmarks' files stay as they were
        doc["units"].update({f"contact.{k}": v for k, v in data.contact.get("units", {}).items()})
        doc["units"].update(
            {"reference.contact.force": "N/m", "reference.contact.interpenetration": "m"}
        )
        doc["contact"] = data.contact
    return doc


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
    version = doc.get("version")
    if version != SCHEMA_VERSION:
        changed = [
            f"version {k}: {CHANGES[k]}"
            for k in sorted(CHANGES)
            if isinstance(version, int) and not isinstance(version, bool) and version < k
        ]
        said = f" ({'; '.join(changed)})" if changed else ""
        given = " ".join(repr(version).split())[:40]
        raise InputError(
            f"{path}: {SCHEMA} version {given}; this tissuebench reads "
            f"version {SCHEMA_VERSION} only{said}: export the benchmark again with "
            "`tissuebench export`"
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
            probe=tuple(doc["probe"]["point"]) if doc.get("probe") is not None else None,
            reference=doc.get("reference"),
            geometry=doc["geometry"],
            truth=doc["truth"],
            contact=doc.get("contact"),
        )
    except UserError as exc:
        raise InputError(f"{path}: {exc}") from None
    except (KeyError, TypeError, ValueError) as exc:
        said = " ".join(str(exc).split())
        raise InputError(
            f"{path}: not a valid {SCHEMA} JSON ({type(exc).__name__}: {said})"
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
