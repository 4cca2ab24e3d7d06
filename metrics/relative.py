"""The relative displacement error E_n = ‖u′ − u‖ / ‖u‖ (SPEC 6.1), Euclidean norms over all
nodal components, reduced over the ranks of `comm`; NaN where ‖u‖ = 0."""

from __future__ import annotations

from mpi4py import MPI

import numpy as np


def norm(u: np.ndarray, comm: MPI.Comm) -> float:
    """Euclidean norm of a distributed vector (each rank holds its owned entries)."""
    u = np.asarray(u, dtype=np.float64)
    return np.sqrt(comm.allreduce(float(u @ u), op=MPI.SUM))


def relative_error(u_ref: np.ndarray, u_cand: np.ndarray, comm: MPI.Comm = MPI.COMM_SELF) -> float:
    """E_n of candidate u_cand against reference u_ref (owned dof values on each rank)."""
    reference = norm(u_ref, comm)
    difference = norm(np.asarray(u_cand) - np.asarray(u_ref), comm)
    return difference / reference if reference > 0 else np.nan
