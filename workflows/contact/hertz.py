"""The Hertz check of SPEC 12, as a record and a figure: the static small push on three graded
meshes and two penalties (solvers/truth/hertz.py), the finest against Hertz's line-contact law.

The record (results/contact/hertz.json) holds the material, R and the depth, the finest
level's P (N/m), p0 (Pa) and a (m) with Hertz's p0 and a for that P and the relative
differences, the SPEC's tolerances (1 % on p0, 2 % on a), and every level's numbers so that
the convergence in the mesh and in the penalty can be read.
"""

from __future__ import annotations

from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.solvers.materials import get_material
from tissuebench.solvers.truth.hertz import DEPTH, Push, hertz, push

MATERIAL = "MP1"  # SPEC 12: MP1, linear, static
LEVELS = (2e-3, 1e-3, 5e-4)  # h_near of the three graded meshes, m
TOLERANCE = {"p0": 0.01, "a": 0.02}  # SPEC 12: Hertz within 1 % (p0) and 2 % (a)


def compute(levels: tuple[float, ...] = LEVELS, comm: MPI.Comm = MPI.COMM_WORLD) -> list[Push]:
    """The pushes of every level (two penalties each, the stiffer last). Collective."""
    material = get_material(MATERIAL)
    pushes = []
    for h_near in levels:
        pushes += push(material.E, material.nu, h_near, comm=comm)
    return pushes


def record(pushes: list[Push]) -> dict:
    """The check's record (JSON-ready) from compute()'s pushes: the last is the finest level
    with the stiffest penalty, the one held to Hertz."""
    material = get_material(MATERIAL)
    E, nu = material.E, material.nu
    best = pushes[-1]
    p0_hertz, a_hertz = hertz(best.P, E, nu, best.radius)
    return {
        "check": "SPEC 12 Hertz: the rigid needle pushed statically into the linear block",
        "material": MATERIAL,
        "E": E,
        "nu": nu,
        "R": best.radius,
        "depth": DEPTH,
        "P": best.P,
        "p0": best.p0,
        "a": best.a,
        "p0_hertz": p0_hertz,
        "a_hertz": a_hertz,
        "p0_error": best.p0 / p0_hertz - 1,
        "a_error": best.a / a_hertz - 1,
        "tolerance": TOLERANCE,
        "holds": bool(
            abs(best.p0 / p0_hertz - 1) <= TOLERANCE["p0"]
            and abs(best.a / a_hertz - 1) <= TOLERANCE["a"]
        ),
        "units": {"E": "Pa", "R": "m", "depth": "m", "P": "N/m", "p0": "Pa", "a": "m"},
        "discretisation": "Taylor-Hood P2-P1 on gmsh triangles graded to h_near on "
        "|y - 0.5| <= 0.05 m of the right edge; penalty k = kappa E / h_near",
        "levels": [
            {
                "h_near": p.h_near,
                "kappa": p.kappa,
                "dofs": p.dofs,
                "P": p.P,
                "p0": p.p0,
                "a": p.a,
                "interpenetration": p.interpenetration,
            }
            for p in pushes
        ],
    }


def figure(path: Path, pushes: list[Push]) -> None:
    """The finest level's contact pressure along the right edge against Hertz's elliptical
    pressure for the same load."""
    from matplotlib.figure import Figure

    material = get_material(MATERIAL)
    best = pushes[-1]
    p0_hertz, a_hertz = hertz(best.P, material.E, material.nu, best.radius)
    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.subplots()
    y = np.linspace(-a_hertz, a_hertz, 401)
    ax.plot(
        1e3 * y,
        p0_hertz * np.sqrt(np.clip(1 - (y / a_hertz) ** 2, 0, None)),
        "k-",
        lw=1.2,
        label=f"Hertz: p0 = {p0_hertz:.3f} Pa, a = {1e3 * a_hertz:.2f} mm",
    )
    ax.plot(
        1e3 * (best.y - 0.5),
        best.p,
        "o",
        ms=2.5,
        color="C3",
        label=f"truth (P2-P1, h = {1e3 * best.h_near:g} mm, kappa = {best.kappa:g}): "
        f"p0 = {best.p0:.3f} Pa, a = {1e3 * best.a:.2f} mm",
    )
    ax.set_xlabel("y - 0.5 along the deformed right edge (mm)")
    ax.set_ylabel("contact pressure p (Pa)")
    ax.set_title(
        f"The needle pushed {1e3 * DEPTH:g} mm into the MP1 block (P = {best.P:.4f} N/m)\n"
        "against Hertz's line contact for the same load"
    )
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="lower center")
    fig.savefig(path, format="png", dpi=120)
