"""The CalculiX deck of a contact benchmark (SPEC 12): the block and a rigid needle that
CalculiX's own contact pushes against the block's right edge (io/calculix_deck.py writes the other
benchmarks' decks; workflows/simulators/calculix_contact.py runs this one).

The deck
--------
The export's block in CPE4 (plane strain, thickness 1 m; the export's node i is node i + 1),
its material as io/calculix_deck.py writes it (*ELASTIC, or *HYPERELASTIC, NEO HOOKE with NLGEOM),
the fixed edges clamped. The needle: a band of CPE4 elements between its boundary (the
half-stadium's arc in ARC_SEGMENTS straight pieces, and its two flanks out to
x = c_x + FLANK) and the same curve BAND m inside it, nodes numbered after the block's. Every
band node follows c(t) - c(0) by *BOUNDARY with an *AMPLITUDE through the kinks of the
export's sampled centre (exact at every t_i): the band moves rigidly, and minus the sum of
its nodes' reaction forces RF is the force that the block exerts on the needle (N per m of
thickness). Its material (NEEDLE_E, NEEDLE_DENSITY) strains nothing and adds no force.

*CONTACT PAIR, frictionless (no *FRICTION), NODE TO SURFACE by default: the slave the block's
faces on x = 1, the master the band's faces on the needle's boundary (their outward normals
face each other); *SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR with the slope k of the
export's own penalty (contact.penalty.k = kappa E / h_e, Pa/m: CalculiX's pressure is
k times the overclosure, our penalty's law) and CalculiX's node-to-surface sigma_inf, the
tension it allows at a clearance, k x SIGMA_INF (1e-3 m: 40 Pa in contact-MP1 at N = 20;
see SIGMA_INF for why not smaller).

The procedure: the export's. Static: one *STEP, *STATIC, DIRECT with increments h to T, each
increment solved to equilibrium (contact makes every increment nonlinear). Dynamic: one
*STEP, *DYNAMIC, DIRECT, ALPHA at increments h, *DAMPING ALPHA, BETA. U and RF at every
increment to the .frd (*NODE FILE). Measured with CalculiX 2.20 (tests/
test_external_calculix_contact.py): the static deck runs; the dynamic one stops within the
first second (calculix_contact.DYNAMIC_REFUSED).
"""

from __future__ import annotations

import json

import numpy as np

from tissuebench.workflows.io.calculix_deck import (
    ccx_name,
    check_inp_model,
    dynamic_keyword,
    kinks,
    lines_of,
    number,
)
from tissuebench.workflows.io.exported import Exported, ExportError

FLANK = 0.2  # m: the needle's flanks from its centre's x to x = c_x + FLANK (1.3 m at rest)
BAND = 0.05  # m: the rigid band's depth inside the needle's boundary (half of R = 0.1 m)
ARC_SEGMENTS = 96  # straight pieces on the half circle: sag R (1 - cos(pi / 192)) = 1.3e-5 m
FLANK_SEGMENTS = 20  # pieces on each flank (0.01 m each)
NEEDLE_DENSITY = 1e-9  # kg/m^3: the band's, nearly massless (CalculiX asks for a density)
NEEDLE_E = 1e9  # Pa: the band's Young's modulus (it is moved rigidly: no strain)
# m: node-to-surface sigma_inf = k x SIGMA_INF (Pa), the tension that CalculiX allows at a
# clearance. Measured on contact-MP1, static: at N = 20, k x 1e-3 m gives a needle force 2 %
# below k x 1e-6 m at t = 2 s (25.45 and 25.95 N/m); but with 1e-6 m at N = 40 the block's
# edge lets go of the needle in the first increment after it stops (force 0 from t = 2.03 s
# on, the edge inside the needle), and with 1e-3 m it holds at N = 10, 20 and 40
SIGMA_INF = 1e-3
CONTACT_TYPES = ("NODE TO SURFACE", "SURFACE TO SURFACE")
# a CPE4's faces (CalculiX's S1..S4) by the 0-based corners of its edge
QUAD_FACES = {(0, 1): 1, (1, 2): 2, (2, 3): 3, (3, 0): 4}


def radius_of(data: Exported) -> float:
    """The needle's radius R (m); ExportError for a tool that is not a half-stadium."""
    assert data.contact is not None
    shape = data.contact.get("shape", {})
    if shape.get("kind") != "half-stadium":
        raise ExportError(
            f"the CalculiX contact deck poses a half-stadium needle, not {shape.get('kind')!r}"
        )
    return float(shape["radius"])


def needle_curves(c0: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The needle's boundary and the curve BAND m inside it at rest (each (P, 2), m), from the
    upper flank's far end along the flank, round the half circle and out along the lower
    flank: the needle's inside lies to the left of this way."""
    angles = np.linspace(0.5 * np.pi, 1.5 * np.pi, ARC_SEGMENTS + 1)
    xs = np.linspace(c0[0] + FLANK, c0[0], FLANK_SEGMENTS + 1)

    def curve(r: float) -> np.ndarray:
        top = np.column_stack([xs, np.full_like(xs, c0[1] + r)])
        arc = np.column_stack([c0[0] + r * np.cos(angles), c0[1] + r * np.sin(angles)])
        bottom = np.column_stack([xs[::-1], np.full_like(xs, c0[1] - r)])
        return np.vstack([top[:-1], arc, bottom[1:]])

    return curve(radius), curve(radius - BAND)


def needle_band(data: Exported) -> tuple[np.ndarray, np.ndarray]:
    """The rigid band at rest: nodes (2P, 2) m (the boundary's P, then the inner curve's) and
    quadrilaterals (P - 1, 4), 0-based, counter-clockwise, each with its face S1 (corners 1-2)
    on the needle's boundary, its outward normal out of the needle."""
    assert data.contact is not None
    c0 = np.asarray(data.contact["motion"]["c0"], dtype=float)
    outer, inner = needle_curves(c0, radius_of(data))
    P = len(outer)
    # outer k -> outer k+1 has the needle on its left, so (k, k+1, inner k+1, inner k) turns
    # counter-clockwise
    quads = [[k, k + 1, P + k + 1, P + k] for k in range(P - 1)]
    return np.vstack([outer, inner]), np.array(quads, dtype=np.int64)


def slave_faces(data: Exported) -> list[tuple[int, int]]:
    """(0-based cell, CPE4 face 1..4) of the block's faces on the contact surface (x = 1)."""
    assert data.contact is not None
    surface = {int(n) for n in data.contact["law"]["surface_nodes"]}
    found = [
        (c, face)
        for c, cell in enumerate(np.asarray(data.cells))
        for (a, b), face in QUAD_FACES.items()
        if int(cell[a]) in surface and int(cell[b]) in surface
    ]
    if not found:
        raise ExportError("the export's contact surface holds no edge of its cells")
    return found


def needle_shift(data: Exported) -> np.ndarray:
    """c(t_i) - c(0) (steps + 1, 2), m, from the export's sampled centre."""
    assert data.contact is not None
    c = np.asarray(data.contact["motion"]["c"], dtype=float)
    if c.shape != (data.steps + 1, 2):
        raise ExportError(
            f"the export's needle centre has {len(c)} samples, its time {data.steps + 1}"
        )
    return c - c[0]


def contact_inp_text(
    data: Exported,
    contact_type: str = "NODE TO SURFACE",
    alpha: float = 0.0,
    slope: float | None = None,
) -> str:
    """The deck (see the module docstring); `slope` (Pa/m): the contact stiffness (default:
    the export's penalty k); `alpha`: the HHT parameter of the dynamic procedure."""
    if data.contact is None:
        raise ExportError("this export has no contact block: io/calculix_deck.py writes its deck")
    if data.dim != 2 or (data.plane or "strain") != "strain" or data.cell_type != "quadrilateral":
        raise ExportError("the CalculiX contact deck is plane strain on quadrilaterals (CPE4)")
    if contact_type not in CONTACT_TYPES:
        raise ExportError(
            f"unknown contact type {contact_type!r}: use {' or '.join(CONTACT_TYPES)}"
        )
    check_inp_model(data.model)
    k = float(slope if slope is not None else data.contact["penalty"]["k"])
    if not k > 0:
        raise ExportError(f"the contact stiffness must be > 0 Pa/m, got {k!r}")
    N, C = len(data.nodes), len(data.cells)
    band_nodes, band_quads = needle_band(data)
    m = data.material
    dynamic = data.procedure == "dynamic"
    out = [
        f"** tissuebench export: benchmark {data.benchmark} (SPEC 12), mesh size "
        f"{data.mesh_size}, options {json.dumps(dict(sorted(data.options.items())))}",
        f"** material {m.name}, model {data.model}, {data.procedure}: h = {data.h!r} s, "
        f"T = {data.end_time!r} s; SI units",
        f"** nodes 1..{N}: the block (export node i is i + 1); {N + 1}..: the needle's rigid band",
        "*HEADING",
        f"tissuebench {data.benchmark} {m.name} {data.model} {data.procedure} contact",
        "*NODE, NSET=Nall",
    ]
    for i, x in enumerate(np.vstack([data.nodes, band_nodes])):
        out.append(f"{i + 1}, {number(x[0])}, {number(x[1])}")
    out.append("*ELEMENT, TYPE=CPE4, ELSET=Eblock")
    out += [", ".join(str(v) for v in [c + 1, *(cell + 1)]) for c, cell in enumerate(data.cells)]
    out.append("*ELEMENT, TYPE=CPE4, ELSET=Eneedle")
    out += [
        ", ".join(str(v) for v in [C + j + 1, *(quad + N + 1)]) for j, quad in enumerate(band_quads)
    ]
    out.append("*NSET, NSET=Nneedle, GENERATE")
    out.append(f"{N + 1}, {N + len(band_nodes)}, 1")
    fixed = []
    for name, nodes in data.effective_sets().items():
        if np.abs(data.motions[name][0]).max() > 0:
            raise ExportError(f"the contact deck expects fixed edges, and set {name} moves")
        if len(nodes):
            fixed.append(ccx_name(name))
            out.append(f"*NSET, NSET={fixed[-1]}")
            out += lines_of([str(int(n) + 1) for n in nodes], 16)
    out.append("*SURFACE, NAME=Sblock, TYPE=ELEMENT")
    out += [f"{c + 1}, S{face}" for c, face in slave_faces(data)]
    out.append("*SURFACE, NAME=Sneedle, TYPE=ELEMENT")
    out += [f"{C + j + 1}, S1" for j in range(len(band_quads))]

    material = ccx_name(m.name)
    out.append(f"** material {m.name!r}: E = {m.E!r} Pa, nu = {m.nu!r}, rho = {m.rho!r} kg/m^3")
    out.append(f"*MATERIAL, NAME={material}")
    if data.model == "neo-hookean":
        kappa = m.lmbda + 2 * m.mu / 3
        out += ["*HYPERELASTIC, NEO HOOKE", f"{number(m.mu / 2)}, {number(2 / kappa)}"]
    else:
        out += ["*ELASTIC", f"{number(m.E)}, {number(m.nu)}"]
    out += ["*DENSITY", number(m.rho)]
    out += ["*MATERIAL, NAME=NEEDLE", "*ELASTIC", f"{number(NEEDLE_E)}, 0.3"]
    out += ["*DENSITY", number(NEEDLE_DENSITY)]
    if dynamic:
        out.append(f"*DAMPING, ALPHA={number(m.alpha)}, BETA={number(m.beta)}")
    out += [f"*SOLID SECTION, ELSET=Eblock, MATERIAL={material}", "1."]
    out += ["*SOLID SECTION, ELSET=Eneedle, MATERIAL=NEEDLE", "1."]
    behaviour = number(k) + (
        f", {number(k * SIGMA_INF)}" if contact_type == "NODE TO SURFACE" else ""
    )
    out += [
        f"** frictionless contact, pressure k x overclosure, k = {k!r} Pa/m (the export's penalty)",
        "*SURFACE INTERACTION, NAME=SI",
        "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR",
        behaviour,
        f"*CONTACT PAIR, INTERACTION=SI, TYPE={contact_type}",
        "Sblock, Sneedle",
    ]
    shift = needle_shift(data)
    if np.abs(shift[:, 1]).max() > 0:
        raise ExportError("the CalculiX contact deck moves the needle along x only")
    scale = float(np.abs(shift[:, 0]).max())
    keep = kinks(data.times, shift[:, 0])
    pairs = [f"{number(data.times[i])}, {number(shift[i, 0] / (scale or 1.0))}" for i in keep]
    out += ["*AMPLITUDE, NAME=A_NEEDLE, TIME=TOTAL TIME", *lines_of(pairs, 4)]
    flags = ", NLGEOM" if data.model != "linear" else ""
    out.append(f"*STEP{flags}, INC={data.steps + 10}")
    out.append(dynamic_keyword(alpha) if dynamic else "*STATIC, DIRECT")
    out.append(f"{number(data.h)}, {number(data.end_time)}")
    out += ["*BOUNDARY", *(f"{name}, 1, 2" for name in fixed), "Nneedle, 2, 2"]
    out += ["*BOUNDARY, AMPLITUDE=A_NEEDLE", f"Nneedle, 1, 1, {number(scale)}"]
    out += ["*NODE FILE, FREQUENCY=1", "U, RF", "*END STEP", ""]
    return "\n".join(out)
