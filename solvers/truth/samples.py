"""The truth as it is stored and graded against: its displacement history sampled where the
metrics need it (SPEC 10, "Grading against the truth"), as plain arrays on one process.

- at the vertices of the truth's mesh: E_n (the candidate evaluated there) and E_s (the
  truth's deformed boundary through its vertices);
- at the quadrature points of the truth's cells, with their weights: E_i by quadrature on
  the truth's cells, with the truth's own (second-order) interpolation u_h(X).

Everything in SI units: coordinates and displacements in m, weights in m^2 (2D) or m^3 (3D),
times in s. A TruthSamples is saved as one .npz (numpy arrays and a JSON text for the rest).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np


@dataclass
class TruthSamples:
    """A truth's displacement history, sampled for grading (see the module docstring).

    case: the SPEC 10 case name ("rod", "block-MP1-w0.2", ...).
    cell_type: the truth mesh's cells, "quadrilateral" or "hexahedron" (first-order geometry).
    times: (steps + 1,) t_i = i h, s.
    vertices: (n_v, gdim) undeformed coordinates of the truth mesh's vertices, m.
    cells: (n_c, 4 | 8) vertex indices of each cell, in metrics/cells.py's (VTK) order.
    boundary: (n_f, 2 | 4) vertex indices of each boundary facet (edges in 2D, quadrilaterals
        in 3D), ordered around the facet.
    points: (n_q, gdim) quadrature points on the undeformed truth cells, m, cell by cell:
        points[c q : (c + 1) q] lie in cells[c], q = n_q / n_c (Gauss-Legendre, 3 per
        direction: q = 9 in 2D, 27 in 3D).
    weights: (n_q,) their quadrature weights, m^gdim; they sum to |Omega_0|.
    u_vertices: (steps + 1, n_v, gdim) the truth's displacement at the vertices, m.
    u_points: (steps + 1, n_q, gdim) the truth's displacement at the quadrature points, m.
    own_error: the truth's estimated own error (SPEC 10): at least "interior_error_max"
        (m^(gdim)), and how it was estimated ("order", "space", "time", "levels", ...).
    inputs: every input it was computed from (its fingerprint is taken of these).
    hierarchy: how it was computed, level by level (solvers/truth/store.py): "levels" (mesh
        sizes), "dofs", "wall" (s), "steps", "h" (s), "half_wall" (s, the finest at h/2),
        "level_differences" (E_i per kept step between consecutive levels),
        "time_difference" (E_i per step, h against h/2 on the finest), and for a case with
        a probe "tip" (per level, (steps + 1, gdim) m) and "static_tip" (per level, m).
    """

    case: str
    cell_type: str
    times: np.ndarray
    vertices: np.ndarray
    cells: np.ndarray
    boundary: np.ndarray
    points: np.ndarray
    weights: np.ndarray
    u_vertices: np.ndarray
    u_points: np.ndarray
    own_error: dict = field(default_factory=dict)
    inputs: dict = field(default_factory=dict)
    hierarchy: dict = field(default_factory=dict)

    @property
    def gdim(self) -> int:
        return int(self.vertices.shape[1])

    @property
    def steps(self) -> int:
        return len(self.times) - 1

    def save(self, path: Path | str) -> None:
        """Write to path (.npz), via a temporary file renamed into place."""
        path = Path(path)
        arrays = {
            f.name: getattr(self, f.name)
            for f in fields(self)
            if isinstance(getattr(self, f.name), np.ndarray)
        }
        meta = {"case": self.case, "cell_type": self.cell_type, "own_error": self.own_error}
        meta["inputs"] = self.inputs
        meta["hierarchy"] = self.hierarchy
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.npz")  # one per writing process
        try:
            np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
            tmp.replace(path)
        finally:
            tmp.unlink(missing_ok=True)

    @classmethod
    def load(cls, path: Path | str) -> TruthSamples:
        """Read what save() wrote."""
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            arrays = {k: data[k] for k in data.files if k != "meta"}
        return cls(**meta, **arrays)
