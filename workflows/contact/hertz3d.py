"""The Hertz check of SPEC 13, as a record and a figure: the capsule pushed statically into the
cylinder's top face, solved on the meridian (solvers/truth/hertz3d.py) on three nested graded
levels and two penalties, the finest against Hertz's sphere and Sneddon's exact rigid sphere on a
half-space; and the same push on bodies 2 and 4 times as large, which measures how much the
finite body moves the force away from the half-space's.

The record (results/contact/hertz3d.json) holds the material, R, the depth and the body, the
finest level's P (N), a (m) and p0 (Pa), the laws' values (Hertz's P, a, p0; Sneddon's a, P,
centre pressure and second-moment radius), the relative differences, the SPEC's tolerances and
whether each holds, the convergence under refinement (observed order, estimated error) and in
the penalty, the body-size study, every level's numbers and the timings (s).
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth import axisymmetric as axi
from tissuebench.solvers.truth.hertz3d import (
    DEPTH,
    RADIUS,
    Push,
    effective_modulus,
    hertz_force,
    hertz_pressure,
    hertz_radius,
    push,
    sneddon,
    sneddon_pressure,
    sneddon_second_moment,
)

MATERIAL = "MP1"  # SPEC 13: MP1, linear, static
LEVELS = (32, 64, 128)  # n of the three nested meridian grids (cells a direction)
QUICK = (16, 32, 64)  # the quick mode's levels
BODIES = (2.0, 4.0)  # the body-size study: the cylinder scaled by these, at the middle level
# SPEC 13: P within 1.5 % of Hertz and 0.5 % of Sneddon, a within 2 %, p0 within 2 %
TOLERANCE = {"P_hertz": 0.015, "a": 0.02, "p0": 0.02, "P_sneddon": 0.005}


def compute(
    levels: tuple[int, ...] = LEVELS,
    bodies: tuple[float, ...] = BODIES,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> tuple[list[Push], list[tuple[float, Push]]]:
    """The pushes of every level (two penalties each, the stiffer last), and the stiffer push of
    the body-size study (scale, Push) at the middle level. Collective."""
    material = get_material(MATERIAL)
    pushes = []
    for n in levels:
        pushes += push(material.E, material.nu, n, comm=comm)
    middle = levels[len(levels) // 2]
    study = [
        (s, push(material.E, material.nu, middle, body=(s * axi.R_B, s * axi.H), comm=comm)[-1])
        for s in bodies
    ]
    return pushes, study


def observed_order(values: list[float]) -> dict:
    """The observed order p of three values on levels refined by 2, and the finest's estimated
    error E ~ |v3 - v2| / (2^p - 1) (SPEC 10); p None where the differences do not fall."""
    d1, d2 = abs(values[1] - values[0]), abs(values[2] - values[1])
    if d2 == 0 or d1 <= d2:
        return {"order": None, "finest_error": d2, "differences": [d1, d2]}
    p = float(np.log2(d1 / d2))
    return {"order": p, "finest_error": d2 / (2**p - 1), "differences": [d1, d2]}


def record(pushes: list[Push], study: list[tuple[float, Push]], seconds: float) -> dict:
    """The check's record (JSON-ready) from compute()'s results: the last push is the finest
    level with the stiffest penalty, the one held to the laws; `seconds` the wall time."""
    material = get_material(MATERIAL)
    E, nu = material.E, material.nu
    best = pushes[-1]
    P_hertz = hertz_force(E, nu, DEPTH)
    a_hertz = hertz_radius(best.P, E, nu)
    p0_hertz = hertz_pressure(best.P, best.a)
    a_sneddon, P_sneddon = sneddon(E, nu, DEPTH)
    errors = {
        "P_hertz": best.P / P_hertz - 1,
        "a": best.a / a_hertz - 1,
        "p0": p0_hertz / best.p0 - 1,
        "P_sneddon": best.P / P_sneddon - 1,
    }
    holds = {key: bool(abs(errors[key]) <= TOLERANCE[key]) for key in TOLERANCE}
    stiff = [p for p in pushes if p.kappa == best.kappa]
    soft = [p for p in pushes if p.kappa != best.kappa]
    refinement = observed_order([p.P for p in stiff]) if len(stiff) == 3 else {}
    finest = [p for p in pushes if p.n == best.n]
    # the body-size study: P(s) = P_inf + C / s, fitted through the largest two bodies
    middle = next((p for p in stiff if study and p.n == study[0][1].n), None)
    sizes = [(1.0, middle), *study] if middle is not None else []
    extrapolated = None
    if len(sizes) >= 2:
        (s1, p1), (s2, p2) = sizes[-2], sizes[-1]
        extrapolated = (s2 * p2.P - s1 * p1.P) / (s2 - s1)
    return {
        "check": "SPEC 13 Hertz: the rigid capsule pushed statically into the linear cylinder "
        "(axisymmetric truth on the meridian)",
        "material": MATERIAL,
        "E": E,
        "nu": nu,
        "E_star": effective_modulus(E, nu),
        "R": RADIUS,
        "depth": DEPTH,
        "body": {"R_B": axi.R_B, "H": axi.H},
        "P": best.P,
        "a": best.a,
        "p0": best.p0,
        "interpenetration": best.interpenetration,
        "hertz": {
            "P": P_hertz,
            "a": a_hertz,
            "p0": p0_hertz,
            "words": "P = (4/3) E* R^(1/2) d^(3/2); a = (3 P R / (4 E*))^(1/3) and "
            "p0 = 3 P / (2 pi a^2) of the truth's P and a",
        },
        "sneddon": {
            "a": a_sneddon,
            "P": P_sneddon,
            "p0": float(sneddon_pressure(np.array([0.0]), E, nu, DEPTH)[0]),
            "a_second_moment": sneddon_second_moment(E, nu, DEPTH),
            "P_below_hertz": P_sneddon / P_hertz - 1,
            "words": "d = (a/2) ln((R + a)/(R - a)), P = (E*/2)((a^2 + R^2) ln((R + a)/(R - a))"
            " - 2 a R); p0 its centre pressure, a_second_moment its pressure's second-moment "
            "radius",
        },
        "errors": errors,
        "errors_words": {
            "P_hertz": "P / Hertz's P - 1",
            "a": "a / (3 P R / (4 E*))^(1/3) - 1",
            "p0": "3 P / (2 pi a^2) / the largest pressure - 1",
            "P_sneddon": "P / Sneddon's P - 1",
        },
        "tolerance": TOLERANCE,
        "holds_each": holds,
        "holds": all(holds.values()),
        "refinement": {
            "n": [p.n for p in stiff],
            "h_near": [p.h_near for p in stiff],
            "P": [p.P for p in stiff],
            "a": [p.a for p in stiff],
            "p0": [p.p0 for p in stiff],
            **refinement,
        },
        "penalty": {
            "kappa": [p.kappa for p in finest],
            "P": [p.P for p in finest],
            "p0": [p.p0 for p in finest],
            "P_change": finest[-1].P / finest[0].P - 1 if len(finest) > 1 else None,
            "P_change_each_level": [
                s.P / p.P - 1 for s, p in zip(stiff, soft, strict=False) if s.n == p.n
            ],
        },
        "body_size": {
            "words": "the cylinder scaled by s (R_B = 0.5 s, H = s) at the middle level, the "
            "stiffer penalty; P_extrapolated = P_inf of P(s) = P_inf + C / s through the largest "
            "two: the finite body's effect on P is P / P_extrapolated - 1",
            "n": middle.n if middle is not None else None,
            "scale": [s for s, _ in sizes],
            "P": [p.P for _, p in sizes],
            "P_sneddon_error": [p.P / P_sneddon - 1 for _, p in sizes],
            "P_extrapolated": extrapolated,
            "P_extrapolated_sneddon_error": (
                extrapolated / P_sneddon - 1 if extrapolated is not None else None
            ),
            "seconds": [p.seconds for _, p in sizes],
        },
        "units": {
            "E": "Pa",
            "R": "m",
            "depth": "m",
            "P": "N",
            "p0": "Pa",
            "a": "m",
            "interpenetration": "m",
            "seconds": "s",
        },
        "discretisation": "axisymmetric Taylor-Hood Q2-Q1 on the meridian [0, 0.5] x [0, 1] m, "
        "n x n quadrilaterals graded toward (0, H) (n/2 x n/2 even cells of h_near = 0.07 / n "
        "m in the 0.035 m square there); penalty k = kappa E / h_near over the top face, "
        "dA = 2 pi r ds",
        "levels": [
            {
                "n": p.n,
                "h_near": p.h_near,
                "h_edge": p.h_edge,
                "kappa": p.kappa,
                "dofs": p.dofs,
                "P": p.P,
                "p0": p.p0,
                "a": p.a,
                "interpenetration": p.interpenetration,
                "newton_iterations": p.newton,
                "seconds": p.seconds,
            }
            for p in pushes
        ],
        "seconds": seconds,
    }


def figure(path: Path, pushes: list[Push]) -> None:
    """The finest level's contact pressure over the top face against Hertz's elliptical
    pressure for the same load and Sneddon's exact sphere at the same depth."""
    from matplotlib.figure import Figure

    material = get_material(MATERIAL)
    E, nu = material.E, material.nu
    best = pushes[-1]
    a_h = hertz_radius(best.P, E, nu)
    p0_h = hertz_pressure(best.P, a_h)
    a_s, P_s = sneddon(E, nu, DEPTH)
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.subplots()
    rho = np.linspace(0, 1.2 * a_s, 401)
    ax.plot(
        1e3 * rho,
        p0_h * np.sqrt(np.clip(1 - (rho / a_h) ** 2, 0, None)),
        "k-",
        lw=1.2,
        label=f"Hertz for the truth's P: p0 = {p0_h:.2f} Pa, a = {1e3 * a_h:.2f} mm",
    )
    ax.plot(
        1e3 * rho,
        sneddon_pressure(rho, E, nu, DEPTH),
        "C0--",
        lw=1.2,
        label=f"Sneddon's sphere at d = {1e3 * DEPTH:g} mm: P = {P_s:.5f} N, "
        f"a = {1e3 * a_s:.2f} mm",
    )
    ax.plot(
        1e3 * best.rho,
        best.p,
        "o",
        ms=2.5,
        color="C3",
        label=f"truth (Q2-Q1, n = {best.n}, kappa = {best.kappa:g}; nodal values, noisy at the "
        f"edge):\nP = {best.P:.5f} N, p0 = {best.p0:.2f} Pa, a = {1e3 * best.a:.2f} mm",
    )
    ax.set_xlabel("r of the deformed top face (mm)")
    ax.set_ylabel("contact pressure p (Pa)")
    ax.set_title(
        f"The capsule pushed {1e3 * DEPTH:g} mm into the MP1 cylinder (axisymmetric truth)\n"
        "against Hertz's sphere and Sneddon's exact sphere on a half-space"
    )
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="lower left")
    fig.savefig(path, format="png", dpi=120)
