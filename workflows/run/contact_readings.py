"""A contact run's readings (SPEC 12) for its summary: the largest needle force and the largest
interpenetration over its steps."""

from __future__ import annotations

import numpy as np


def contact_readings(rows: np.ndarray) -> dict[str, float | None]:
    """{"needle_force_max": the largest |F| (N/m), "interpenetration_max": the largest
    interpenetration (m)} over the steps of rows (steps, 3: F_x, F_y in N/m, interpenetration
    in m); None for a run without steps, and NaN steps ignored."""
    rows = np.asarray(rows, dtype=float).reshape(-1, 3)
    force = np.hypot(rows[:, 0], rows[:, 1])
    force, depth = force[np.isfinite(force)], rows[np.isfinite(rows[:, 2]), 2]
    return {
        "needle_force_max": float(force.max()) if force.size else None,
        "interpenetration_max": float(depth.max()) if depth.size else None,
    }
