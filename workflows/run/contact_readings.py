"""A contact run's readings (SPEC 12) for its summary: the largest needle force and the largest
interpenetration over its steps."""

from __future__ import annotations

import numpy as np


def contact_readings(rows: np.ndarray) -> dict[str, float | None]:
    """{"needle_force_max": the largest |F| (N/m in 2D, N in 3D), "interpenetration_max": the
    largest interpenetration (m)} over the steps of rows (steps, gdim + 1: F's components, then
    the interpenetration in m); None for a run without steps, and NaN steps ignored."""
    rows = np.asarray(rows, dtype=float)
    rows = rows.reshape(-1, rows.shape[-1] if rows.ndim == 2 else 3)
    force = (
        np.hypot(rows[:, 0], rows[:, 1])
        if rows.shape[1] == 3
        else np.linalg.norm(rows[:, :-1], axis=1)
    )
    force, depth = force[np.isfinite(force)], rows[np.isfinite(rows[:, -1]), -1]
    return {
        "needle_force_max": float(force.max()) if force.size else None,
        "interpenetration_max": float(depth.max()) if depth.size else None,
    }
