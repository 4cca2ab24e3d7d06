"""SPEC 13's grading of a 3D candidate against a truth computed on a meridian: the meridian's
samples (store.sample() of an axisymmetric truth, 2D: coordinates (r, z)) revolved about the z
axis on `angles` azimuths theta_j = offset + 2 pi j / angles, into the 3D samples that
metrics/truth.py grades with (samples.TruthSamples).

- vertices: the meridian's vertices (r, z) at every angle, (r cos theta, r sin theta, z); the
  vertices on the axis (r = 0) once. m.
- u at a point: (u_r cos theta, u_r sin theta, u_z), m (u_r = 0 on the axis).
- points and weights: the meridian's quadrature points on every angle, with the weights
  w_q r_q (2 pi / angles) (m^3): Gauss in (r, z) times the trapezoidal rule in theta, which is
  exact for every trigonometric polynomial of degree below `angles` in theta (the volume, and
  int u_x^2 with u_x = u_r cos theta, exactly; |u| of an axisymmetric field is independent of
  theta, so E_i of the truth is exact in theta too).
- cells: hexahedra, each meridian quadrilateral swept between consecutive angles (a straight
  chord between them: first-order cells, as the candidates'), in VTK order with a positive
  Jacobian; a cell touching the axis keeps its repeated vertices (a wedge). Cell (c, j) holds
  the points of meridian cell c at angle theta_j: cell by cell, as TruthSamples says.
- boundary: the meridian's boundary edges off the axis swept between consecutive angles:
  quadrilaterals oriented outward (a facet touching the axis keeps its repeated vertex, which
  metrics/surface.py's Solid accepts: the face's triangle through it has no area).

The revolved samples carry the meridian's inputs, own error (already of the revolved body,
m^3) and hierarchy, with hierarchy["revolved"] = {"angles", "offset"}.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from tissuebench.solvers.truth.samples import TruthSamples

ANGLES = 32  # SPEC 13: at least 32 azimuths


class Revolved:
    """A revolved displacement history, (steps + 1, n, 3) m, computed from the meridian's
    (steps + 1, n_meridian, 2) when its steps are asked for (an index, a slice or a tuple
    starting with one), not held: a fine truth's revolved quadrature-point values would take
    gigabytes (3.3 GB for a 40-cell meridian on 32 angles). Indexing returns numpy arrays;
    np.asarray() gives the whole history."""

    def __init__(self, meridian: np.ndarray, turn, n: int):
        self.meridian = meridian
        self.turn = turn  # (k, n_meridian, 2) -> (k, n, 3)
        self.shape = (len(meridian), n, 3)
        self.ndim = 3
        self.dtype = np.dtype(np.float64)

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key):
        first, rest = (key[0], key[1:]) if isinstance(key, tuple) else (key, ())
        if isinstance(first, (int, np.integer)):
            out = self.turn(np.asarray(self.meridian[first : first + 1 or None]))[0]
            return out[rest] if rest else out
        out = self.turn(np.asarray(self.meridian[first]))
        return out[(slice(None), *rest)] if rest else out

    def __iter__(self):
        for i in range(len(self)):
            yield self[i]

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        out = self.turn(np.asarray(self.meridian))
        return out if dtype is None else out.astype(dtype)


def _axis(r: np.ndarray, scale: float) -> np.ndarray:
    """Which meridian vertices lie on the axis r = 0 (within round-off of the extent)."""
    return np.abs(r) <= 1e-12 * scale


def revolve(samples: TruthSamples, angles: int = ANGLES, offset: float = 0.0) -> TruthSamples:
    """The 3D TruthSamples of a meridian truth (2D samples in (r, z), m) revolved on `angles`
    azimuths theta_j = offset + 2 pi j / angles (rad); see the module docstring."""
    if samples.gdim != 2 or samples.cell_type != "quadrilateral":
        raise ValueError("revolve() takes a meridian's samples: 2D, quadrilaterals")
    if angles < 3:
        raise ValueError(f"revolve() needs at least 3 angles, got {angles}")
    R = np.asarray(samples.vertices, dtype=np.float64)
    r = R[:, 0]
    if r.min() < -1e-12 * np.abs(R).max():
        raise ValueError("a meridian's vertices have r >= 0")
    theta = offset + 2 * np.pi * np.arange(angles) / angles
    cos, sin = np.cos(theta), np.sin(theta)
    on_axis = _axis(r, float(np.abs(R).max()))
    n_v = len(R)
    axis_ids = np.flatnonzero(on_axis)
    off_ids = np.flatnonzero(~on_axis)
    n_axis, n_off = len(axis_ids), len(off_ids)
    # index[i, j]: the 3D vertex of meridian vertex i at angle j
    index = np.empty((n_v, angles), dtype=np.int64)
    index[axis_ids] = np.arange(n_axis)[:, None]
    index[off_ids] = n_axis + np.arange(angles)[None, :] * n_off + np.arange(n_off)[:, None]

    def spread(values_rz: np.ndarray, ids: np.ndarray) -> np.ndarray:
        """(..., len(ids), 2) values (r, z) at every angle: (..., angles * len(ids), 3), angle
        by angle."""
        a = values_rz[..., ids, :]
        radial = a[..., None, :, 0]  # (..., 1, n)
        out = np.stack(
            [
                radial * cos[:, None],
                radial * sin[:, None],
                np.broadcast_to(a[..., None, :, 1], radial.shape[:-2] + (angles, len(ids))),
            ],
            axis=-1,
        )
        return out.reshape(*a.shape[:-2], angles * len(ids), 3)

    def axis_values(values_rz: np.ndarray) -> np.ndarray:
        a = values_rz[..., axis_ids, :]
        out = np.zeros(a.shape[:-1] + (3,))
        out[..., 0] = a[..., 0] * cos[0]  # r = 0, u_r = 0 there: kept as they are
        out[..., 2] = a[..., 1]
        return out

    vertices = np.concatenate([axis_values(R), spread(R, off_ids)], axis=0)
    u_vertices = Revolved(
        samples.u_vertices,
        lambda u: np.concatenate([axis_values(u), spread(u, off_ids)], axis=1),
        len(vertices),
    )

    # the cells: (c, j) -> c * angles + j; each quad (v0, v1, v2, v3) anticlockwise in (r, z)
    cells2 = np.asarray(samples.cells, dtype=np.int64)
    n_c = len(cells2)
    R_c = R[cells2]
    area = (R_c[:, 2, 0] - R_c[:, 0, 0]) * (R_c[:, 3, 1] - R_c[:, 1, 1]) - (
        R_c[:, 2, 1] - R_c[:, 0, 1]
    ) * (R_c[:, 3, 0] - R_c[:, 1, 0])
    # anticlockwise in (r, z) and theta third is a left-handed frame: the faces run clockwise
    quads = np.where((area > 0)[:, None], cells2[:, ::-1], cells2)
    j = np.arange(angles)
    following = (j + 1) % angles
    swept = np.concatenate([index[quads][:, :, j], index[quads][:, :, following]], axis=1)
    cells = swept.transpose(0, 2, 1).reshape(n_c * angles, 8)  # (c, j) -> c * angles + j

    # the points: cell (c, j) holds meridian cell c's q points at angle j
    P = np.asarray(samples.points, dtype=np.float64)
    q = len(P) // n_c
    Pc = P.reshape(n_c, q, 2)

    def at_angles(values: np.ndarray) -> np.ndarray:
        """(..., n_c, q, 2) meridian values at points: (..., n_c * angles * q, 3)."""
        radial = values[..., :, None, :, 0]  # (..., n_c, 1, q)
        out = np.stack(
            [
                radial * cos[:, None],
                radial * sin[:, None],
                np.broadcast_to(values[..., :, None, :, 1], radial.shape[:-2] + (angles, q)),
            ],
            axis=-1,
        )
        return out.reshape(*values.shape[:-3], n_c * angles * q, 3)

    points = at_angles(Pc)
    w = np.asarray(samples.weights, dtype=np.float64).reshape(n_c, 1, q) * Pc[:, None, :, 0]
    weights = np.broadcast_to(w * (2 * np.pi / angles), (n_c, angles, q)).reshape(-1)
    u_points = Revolved(
        samples.u_points, lambda u: at_angles(u.reshape(len(u), n_c, q, 2)), len(points)
    )

    # the boundary: the meridian's edges (a, b), domain on their left, off the axis
    edges = np.asarray(samples.boundary, dtype=np.int64)
    edges = edges[~(on_axis[edges[:, 0]] & on_axis[edges[:, 1]])]
    a, b = edges[:, 0], edges[:, 1]
    faces = np.stack(
        [index[a][:, j], index[b][:, j], index[b][:, following], index[a][:, following]], axis=-1
    ).reshape(-1, 4)
    # outward: the meridian's outward normal (dz, -dr) revolved to the face's middle angle
    d = R[b] - R[a]
    middle = np.repeat(theta[None, :] + np.pi / angles, len(edges), axis=0).reshape(-1)
    n_r = np.repeat(d[:, 1], angles)
    n_z = np.repeat(-d[:, 0], angles)
    outward = np.column_stack([n_r * np.cos(middle), n_r * np.sin(middle), n_z])
    p = vertices[faces]
    normal = np.cross(p[:, 2] - p[:, 0], p[:, 3] - p[:, 1])
    flip = np.einsum("ij,ij->i", normal, outward) < 0
    faces = np.where(flip[:, None], faces[:, ::-1], faces)
    first = np.argmin(faces, axis=1)
    faces = np.take_along_axis(faces, (first[:, None] + np.arange(4)) % 4, axis=1)
    faces = faces[np.lexsort(faces.T[::-1])]

    return TruthSamples(
        case=samples.case,
        cell_type="hexahedron",
        times=np.asarray(samples.times, dtype=float),
        vertices=vertices,
        cells=cells,
        boundary=faces,
        points=points,
        weights=weights,
        u_vertices=cast(np.ndarray, u_vertices),  # Revolved: indexed as an array would be
        u_points=cast(np.ndarray, u_points),
        own_error=dict(samples.own_error),
        inputs=dict(samples.inputs),
        hierarchy={**samples.hierarchy, "revolved": {"angles": angles, "offset": offset}},
    )
