"""The metrics of SPEC section 6 on one vector Q1 function space, for one pair of
displacement fields or for whole histories, and METRICS, the one table of them: every
consumer (run and compare CSVs, summaries, report, figures, convergence) iterates it, so a
metric is added by one line there.

Displacements are numpy arrays of the owned dofs of V, unrolled with block size d (the first
`V.dofmap.index_map.size_local * d` entries of a Function's x.array). Every method is
collective and returns the same numbers on every rank.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from mpi4py import MPI

import numpy as np
from dolfinx import fem

from tissuebench.metrics.boundary import Boundary
from tissuebench.metrics.interior import InteriorMetric
from tissuebench.metrics.relative import relative_error
from tissuebench.metrics.surface import domain, surface_error


@dataclass(frozen=True)
class Metric:
    """One metric: its symbol (tables), its label (figures; Unicode subscripts, since
    matplotlib's mathtext is slow to load), and its value for a pair of owned displacement
    arrays, `value(metrics, u_ref, u_cand)` (metrics: a Metrics below, or
    metrics/crossmesh.py's CrossMetrics, which has the same comm, surface and interior). A
    variant (E_i's nodal form) names the metric whose figure panel it shares, and is left out
    of convergence studies."""

    symbol: str
    label: str
    value: Callable[[Any, np.ndarray, np.ndarray], float]
    variant_of: str | None = None


METRICS: dict[str, Metric] = {
    "relative_error": Metric(
        "E_n",
        "relative error E\u2099",
        lambda m, u_ref, u_cand: relative_error(u_ref, u_cand, m.comm),
    ),
    "surface_error": Metric(
        "E_s", "surface error E\u209b", lambda m, u_ref, u_cand: m.surface(u_ref, u_cand)
    ),
    "interior_error": Metric(
        "E_i",
        "interior error E\u1d62",
        lambda m, u_ref, u_cand: m.interior.quadrature(u_ref, u_cand),
    ),
    "interior_error_nodal": Metric(
        "E_i nodal",
        "interior error, nodal form",
        lambda m, u_ref, u_cand: m.interior.nodal(u_ref, u_cand),
        variant_of="interior_error",
    ),
}
NAMES = tuple(METRICS)  # the SPEC's four, in order (METRICS itself holds any added later)
SURFACE = "surface_error"  # E_s: measured apart from the others in histories (its booleans)


def panels() -> list[list[str]]:
    """The metrics grouped for figures: each metric that is no variant, followed by its variants."""
    return [
        [name, *(v for v, m in METRICS.items() if m.variant_of == name)]
        for name, metric in METRICS.items()
        if metric.variant_of is None
    ]


class Metrics:
    """E_n, E_s, E_i and E_i's nodal variant on V (vector Q1 on quadrilaterals or hexahedra, or
    P1 on triangles or tetrahedra; a candidate on another mesh: metrics/crossmesh.py).

    Built once per V: the interior forms and nodal weights (`interior`), |Ω_0| (`volume`),
    d (`dim`), and the boundary known on every rank (`boundary`, with `domain` its Polygon or
    Solid).
    """

    def __init__(self, V: fem.FunctionSpace, points: int = 3):
        self.comm: MPI.Comm = V.mesh.comm
        self.dim = V.mesh.geometry.dim
        self.size = V.dofmap.index_map.size_local * self.dim
        self.interior: InteriorMetric = InteriorMetric(V, points)
        self.volume = self.interior.volume
        self.boundary = Boundary(V)
        self.domain = domain(self.boundary.X, self.boundary.facets)

    def _check(self, u):
        u = np.asarray(u, dtype=np.float64)
        if u.shape != (self.size,):
            raise ValueError(f"expected the {self.size} owned dof values of V, got shape {u.shape}")
        return u

    def _surfaces(self, d_ref: np.ndarray, d_cands: list[np.ndarray]) -> list[float]:
        """E_s of each candidate against the reference from their gathered boundary
        displacements (m), on this rank alone: the reference's deformed domain built once."""
        x_ref, ref, out = self.boundary.X + d_ref, None, []
        for d in d_cands:
            x_cand = self.boundary.X + d
            if ref is None and np.isfinite(x_ref).all() and np.isfinite(x_cand).all():
                ref = self.domain.region(x_ref)
            out.append(surface_error(self.domain, x_ref, x_cand, ref_region=ref))
        return out

    def surface(self, u_ref: np.ndarray, u_cand: np.ndarray) -> float:
        """E_s, computed on rank 0 from the gathered deformed boundaries and broadcast."""
        d_ref, d_cand = self.boundary.gather(u_ref), self.boundary.gather(u_cand)
        value = None
        if self.comm.rank == 0:
            assert d_ref is not None and d_cand is not None  # gathered to rank 0
            value = self._surfaces(d_ref, [d_cand])[0]
        return self.comm.bcast(value, root=0)

    def evaluate(
        self, u_ref: np.ndarray, u_cand: np.ndarray, skip: tuple[str, ...] = ()
    ) -> dict[str, float]:
        """The metrics of candidate u_cand against reference u_ref, a dict keyed as METRICS
        (NaN, not computed, for the names in `skip`)."""
        u_ref, u_cand = self._check(u_ref), self._check(u_cand)
        return {
            name: np.nan if name in skip else float(metric.value(self, u_ref, u_cand))
            for name, metric in METRICS.items()
        }

    def history(
        self,
        ref: list[np.ndarray],
        cand: list[np.ndarray],
        on_step: Callable[[], object] | None = None,
    ) -> dict[str, np.ndarray]:
        """One value per reference step for each metric (numpy arrays keyed as METRICS); NaN
        for the steps a shorter candidate (a diverged run) does not have. `on_step()` is called
        twice a step as it is measured (a progress bar's; see histories)."""
        return self.histories(ref, {"": cand}, on_step)[""]

    def histories(
        self,
        ref: list[np.ndarray],
        cands: dict[str, list[np.ndarray]],
        on_step: Callable[[], object] | None = None,
    ) -> dict[str, dict[str, np.ndarray]]:
        """history() of each candidate, keyed as `cands`. E_s, the booleans that take nearly
        all the time, is shared out between the ranks: step i's deformed boundaries are gathered
        to rank i mod size, and each rank then measures its steps alone (the reference's
        domain of a step built once for all its candidates), with no message until the values
        are shared at the end. `on_step()` (a progress bar's, on rank 0) is called twice for
        each candidate's step: as its E_n and E_i are measured, and as its E_s is (comm.size
        times for each that rank 0 measures: the other ranks measure as many meanwhile)."""
        curves = {label: {name: np.full(len(ref), np.nan) for name in METRICS} for label in cands}
        mine: dict[int, tuple[np.ndarray, dict[str, np.ndarray]]] = {}
        for i in range(len(ref)):
            owner = i % self.comm.size
            u_ref = self._check(ref[i])
            d_ref = self.boundary.gather(u_ref, root=owner)
            d_cands = {}
            for label, cand in cands.items():
                if i >= len(cand):
                    continue
                u_cand = self._check(cand[i])
                for name, value in self.evaluate(u_ref, u_cand, skip=(SURFACE,)).items():
                    curves[label][name][i] = value
                d_cands[label] = self.boundary.gather(u_cand, root=owner)
                if on_step is not None:
                    on_step()
            if self.comm.rank == owner:  # gathered here: none is None
                assert d_ref is not None
                mine[i] = (d_ref, {label: d for label, d in d_cands.items() if d is not None})
        measured = {}
        for i, (d_ref, d_cands) in mine.items():
            values = self._surfaces(d_ref, list(d_cands.values()))
            measured.update({(i, label): v for label, v in zip(d_cands, values, strict=True)})
            if on_step is not None:
                for _ in range(len(d_cands) * self.comm.size):
                    on_step()
        for part in self.comm.allgather(measured):
            for (i, label), value in part.items():
                curves[label][SURFACE][i] = value
        return curves
