"""The CalculiX deck (.inp) of an exported benchmark, as write_inp and inp_text write it (CalculiX's
output is read by calculix.py).

*NODE and *ELEMENT (C3D8, C3D8I, C3D8R in 3D; CPE4, CPE4R in plane strain, CPS4, CPS4R in
plane stress, thickness 1 m; C3D20R on the export's hexahedra with a node added at the middle
of every edge, numbered after the export's nodes, each set holding the midside nodes of its
edges: quadratic_hexahedra), one *NSET per set, *MATERIAL with *ELASTIC (linear; with
NLGEOM it is St Venant-Kirchhoff: `svk`) or *HYPERELASTIC, NEO HOOKE with C10 = mu/2,
D1 = 2/kappa (`neo-hookean`, NLGEOM), *DENSITY, *DAMPING ALPHA, BETA (Rayleigh, whole model);
`corotational` has no CalculiX counterpart and is refused, and so is `neo-hookean-barrier`
(NEO HOOKE is the (J - 1)^2 law, another than its name says). Dynamic: one *STEP of fixed
increments h up to T, *DYNAMIC, DIRECT, ALPHA=0 (the trapezoidal rule); static: one
*STATIC step of length h per t_i (a linear static step is solved once, at its end). The
constrained nodes by *BOUNDARY (a moving component with an *AMPLITUDE in total time through
the kinks of its sampled motion, exact at every t_i) and *INITIAL CONDITIONS, TYPE=VELOCITY
for the needle's initial speed; gravity by *DLOAD GRAV with a constant amplitude from t = 0;
U at every increment to the .frd (*NODE FILE) and the .dat (*NODE PRINT). CalculiX writes no
result at t = 0: `compare` takes such a series to start from the zero initial state.

Measured against CalculiX 2.20 (tests/test_export.py): the rod, C3D8, linear, dynamic: E_n
below 1e-5 after the first 5 steps (CalculiX's initial acceleration solves
(M + (h/10)^2 K / 4) a_0 = f, not M a_0 = f: up to 4e-5 before); static: 2e-7. Known
departures, said in the deck as comments: with NLGEOM CalculiX damps with the current
stiffness, not beta K_0 (the rod: 0.8 % at t = 2 s; without damping 1e-6); a prescribed
motion in *DYNAMIC is followed otherwise than the SPEC (the block in CPE4: E_n up to 0.3 in
the first steps, E_i time-mean 7e-4; a one-layer C3D8 slab of it with u_z = 0 departs alike,
E_i time-mean 1.7e-4, with or without the initial velocity; the static block: 1e-7).

C3D20R (tests/test_external_calculix_c3d20r.py): CalculiX integrates its stiffness, its
consistent mass and the gravity at the same 2 x 2 x 2 Gauss points (e_c3d.f; 27 points for
the initial acceleration only). Its output is read at the corners (the export's nodes), and
graded there with trilinear interpolation between them, as the other hexahedra: the
quadratic field between the corners is not graded. The static rod's tip (MP3; the truth's
Q2, n = 8: -0.13060 m): C3D20R -0.12915 m at n = 2 and -0.13022 m at n = 4 (C3D8 -0.11473,
-0.12553 m); in MP2 (nu = 0.495; truth -1.6717e-3 m) -1.4826e-3, -1.6012e-3 and at n = 6
-1.6297e-3 m (C3D8 -6.880e-4, -9.532e-4, -1.1290e-3 m; C3D8I -1.3522e-3, -1.5444e-3,
-1.5986e-3 m): the reduced 20-node element locks a little at nu = 0.495 on coarse meshes
(C3D20, full integration, more: -1.5571e-3 and -1.6042e-3 m at n = 4 and 6).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from tissuebench.workflows.io.exported import ZERO, Exported, ExportError

STATIC_KEYWORD = "*STATIC, DIRECT"
# CalculiX element -> (dimension, plane: None in 3D)
ELEMENTS = {
    "C3D8": (3, None),
    "C3D8I": (3, None),
    "C3D8R": (3, None),
    "C3D20R": (3, None),
    "CPE4": (2, "strain"),
    "CPE4R": (2, "strain"),
    "CPS4": (2, "stress"),
    "CPS4R": (2, "stress"),
}
# the second-order elements of ELEMENTS, written on the export's hexahedra with a node added at
# the middle of every edge (quadratic_hexahedra)
SECOND_ORDER = ("C3D20R",)
# CalculiX's C3D20 (and C3D20R) node order: corners 1-8 as C3D8, then the midside nodes 9-20 of
# the edges 1-2, 2-3, 3-4, 4-1, 5-6, 6-7, 7-8, 8-5, 1-5, 2-6, 3-7, 4-8 (ccx's shape20h.f: node
# 9 at xi = 0, eta = zeta = -1, ...); here 0-based corners of the VTK (= C3D8) order
HEX20_EDGES = (
    (0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7),
)  # fmt: skip


MAX_FIELD = 20  # characters CalculiX reads of a number (f20.0)


def number(x: float) -> str:
    """A float as CalculiX reads it in full: the shortest repr when it fits 20 characters,
    else 14 significant digits."""
    text = repr(float(x))
    if len(text) <= MAX_FIELD:
        return text
    return f"{x:.13e}" if len(f"{x:.13e}") <= MAX_FIELD else f"{x:.11e}"


def ccx_name(name: str) -> str:
    """A set or material name as CalculiX takes it: letters, digits and _, at most 80."""
    return (re.sub(r"[^A-Za-z0-9_]", "_", name) or "X")[:80]


def kinks(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The indices of the samples that a piecewise linear function through them needs: the
    first, the last, and every one where the slope changes (beyond round-off). Linear
    interpolation between the kept samples gives every sample back."""
    n = len(times)
    if n <= 2:
        return np.arange(n)
    scale = max(float(np.abs(values).max()), ZERO)
    slopes = np.diff(values) / np.diff(times)
    change = np.abs(np.diff(slopes)) * np.diff(times)[1:] > 1e-12 * scale
    return np.flatnonzero(np.r_[True, change, True])


def check_element(element: str, dim: int, plane: str | None) -> None:
    if element not in ELEMENTS:
        raise ExportError(f"unknown element {element!r}: use one of {', '.join(ELEMENTS)}")
    edim, eplane = ELEMENTS[element]
    if edim != dim:
        raise ExportError(
            f"element {element} is {edim}D and the benchmark is {dim}D: use "
            f"{', '.join(e for e, (d, _) in ELEMENTS.items() if d == dim)}"
        )
    if dim == 2 and eplane != (plane or "strain"):
        same = [e for e, (d, p) in ELEMENTS.items() if d == 2 and p == (plane or "strain")]
        raise ExportError(
            f"element {element} is plane {eplane} and the export is plane {plane or 'strain'}: use "
            f"{', '.join(same)}"
        )


def default_element(dim: int, plane: str | None) -> str:
    return "C3D8" if dim == 3 else ("CPE4" if (plane or "strain") == "strain" else "CPS4")


def check_inp_model(model: str) -> None:
    """ExportError (one line) for a model that CalculiX has no material for."""
    if model == "neo-hookean-barrier":
        raise ExportError(
            "neo-hookean-barrier has no CalculiX material: CalculiX's NEO HOOKE is the "
            "(kappa/2)(J - 1)^2 law, neo-hookean, not the barrier's (kappa/4)(J^2 - 1 - 2 ln J); "
            "export it as json, or export --models neo-hookean for a deck of that law (a run "
            "of it graded against the barrier's truth carries the difference of the laws)"
        )
    if model == "corotational":
        raise ExportError(
            "the corotational model has no CalculiX material: export it as json, or use "
            "linear, svk (*ELASTIC with NLGEOM) or neo-hookean (*HYPERELASTIC, NEO HOOKE)"
        )


def lines_of(values: list[str], per_line: int) -> list[str]:
    return [", ".join(values[k : k + per_line]) for k in range(0, len(values), per_line)]


def dynamic_keyword(alpha: float = 0.0) -> str:
    """CalculiX's *DYNAMIC line with fixed increments h: implicit HHT-alpha, alpha in
    [-1/3, 0] (alpha = 0 is the trapezoidal rule, the SPEC's `implicit`; CalculiX's own
    default is -0.05, which damps high frequencies)."""
    if not -1 / 3 <= alpha <= 0:
        raise ExportError(f"CalculiX's HHT alpha must lie in [-1/3, 0], got {alpha!r}")
    return f"*DYNAMIC, DIRECT, ALPHA={number(alpha)}"


def quadratic_hexahedra(data: Exported) -> Exported:
    """The export on 20-node hexahedra (C3D20R): its nodes, then one node at the middle of
    every edge of its hexahedra (the cells' straight edges: the midpoint of their corners),
    numbered after the corners in the order of the sorted edges; each cell's 20 nodes in
    CalculiX's C3D20 order (HEX20_EDGES); every node set holds, besides its nodes, the midside
    node of every edge whose two corners it holds (a clamped face keeps its midside nodes
    clamped; a set's motion moves them with it)."""
    from dataclasses import replace

    if data.cell_type != "hexahedron" or data.cells.shape[1] != 8:
        raise ExportError(
            f"20-node hexahedra are built on hexahedra, and the export has {data.cell_type}s"
        )
    cells = np.asarray(data.cells, dtype=np.int64)
    ends = cells[:, np.array(HEX20_EDGES)]  # (C, 12, 2): the corners of each cell's edges
    ends = np.sort(ends, axis=2)
    edges, which = np.unique(ends.reshape(-1, 2), axis=0, return_inverse=True)
    first = len(data.nodes)
    midside = first + which.reshape(len(cells), len(HEX20_EDGES))
    nodes = np.vstack([data.nodes, 0.5 * (data.nodes[edges[:, 0]] + data.nodes[edges[:, 1]])])
    node_sets = {}
    for name, members in data.node_sets.items():
        inside = np.isin(edges, members).all(axis=1)
        node_sets[name] = np.concatenate([members, first + np.flatnonzero(inside)])
    return replace(data, nodes=nodes, cells=np.hstack([cells, midside]), node_sets=node_sets)


def inp_text(data: Exported, element: str | None = None, alpha: float = 0.0) -> str:
    """The CalculiX deck of the export (see the module docstring); `alpha` is the HHT
    parameter of the dynamic procedure (dynamic_keyword)."""
    element = element or default_element(data.dim, data.plane)
    check_element(element, data.dim, data.plane)
    check_inp_model(data.model)
    corners = len(data.nodes)
    if element in SECOND_ORDER:
        data = quadratic_hexahedra(data)
    m = data.material
    nlgeom = data.model != "linear"
    times, end = data.times, data.end_time
    out = [
        f"** tissuebench export: benchmark {data.benchmark} (SPEC sections 4-5, 8), mesh size "
        f"{data.mesh_size}, options {json.dumps(dict(sorted(data.options.items())))}",
        f"** material {m.name}, model {data.model}, {data.procedure}: h = {data.h!r} s, "
        f"T = {end!r} s, {data.steps} steps; SI units (m, s, kg, N, Pa)",
        "** node i + 1 is node i of the JSON export; the zero initial state is at t = 0",
        *(
            [
                f"** nodes {corners + 1} to {len(data.nodes)}: the midside nodes of {element}, "
                "at the middle of each edge; a set holds those of the edges whose corners it holds"
            ]
            if len(data.nodes) > corners
            else []
        ),
        "*HEADING",
        f"tissuebench {data.benchmark} {m.name} {data.model} {data.procedure}",
        "*NODE, NSET=Nall",
    ]
    for i, x in enumerate(data.nodes):
        out.append(", ".join([str(i + 1), *(number(c) for c in x)]))
    out.append(f"*ELEMENT, TYPE={element}, ELSET=Eall")
    for c, nodes in enumerate(data.cells):
        # at most 16 entries a line (CalculiX's limit): a 20-node cell goes on to a second line
        entries = [str(c + 1), *(str(int(n) + 1) for n in nodes)]
        out.append(",\n".join(", ".join(entries[k : k + 16]) for k in range(0, len(entries), 16)))
    names = {name: ccx_name(name) for name in data.node_sets}
    for name, nodes in data.node_sets.items():
        out.append(f"*NSET, NSET={names[name]}")
        out += lines_of([str(int(n) + 1) for n in nodes], 16)
    effective = data.effective_sets()
    bc_sets = {}
    for name, nodes in effective.items():
        if len(nodes) == len(data.node_sets[name]):
            bc_sets[name] = names[name]
        elif len(nodes):
            bc_sets[name] = f"{names[name]}_BC"[:80]
            out.append(f"*NSET, NSET={bc_sets[name]}")
            out += lines_of([str(int(n) + 1) for n in nodes], 16)

    material = ccx_name(m.name)
    out.append(f"** material {m.name!r}: E = {m.E!r} Pa, nu = {m.nu!r}, rho = {m.rho!r} kg/m^3")
    out.append(f"*MATERIAL, NAME={material}")
    if data.model == "neo-hookean":
        kappa = m.lmbda + 2 * m.mu / 3
        out.append(f"** NEO HOOKE: C10 = mu/2 = {m.mu / 2!r} Pa, D1 = 2/kappa = {2 / kappa!r} 1/Pa")
        out += ["*HYPERELASTIC, NEO HOOKE", f"{number(m.mu / 2)}, {number(2 / kappa)}"]
    else:
        out += ["*ELASTIC", f"{number(m.E)}, {number(m.nu)}"]
    out += ["*DENSITY", number(m.rho)]
    if data.procedure == "dynamic":
        if nlgeom and m.beta > 0:
            out.append(
                "** NLGEOM: CalculiX's stiffness damping follows the current stiffness, the "
                "SPEC's is beta K_0 (section 8): measured 0.8 % apart on the rod at t = 2 s"
            )
        out.append(f"*DAMPING, ALPHA={number(m.alpha)}, BETA={number(m.beta)}")
    out.append(f"*SOLID SECTION, ELSET=Eall, MATERIAL={material}")
    if data.dim == 2:
        out.append("1.")  # thickness, m

    amplitudes, boundaries, velocities = [], [], []
    for name, (u, v, _) in data.motions.items():
        if name not in bc_sets:
            continue
        scales = np.abs(u).max(axis=0)
        if np.all(scales <= ZERO):
            boundaries.append(("", f"{bc_sets[name]}, 1, {data.dim}"))
            continue
        for k in range(data.dim):
            scale = float(scales[k])
            if scale <= ZERO:
                boundaries.append(("", f"{bc_sets[name]}, {k + 1}, {k + 1}"))
                continue
            amp = f"A_{bc_sets[name]}_{k + 1}"[:80]
            keep = kinks(times, u[:, k])
            pairs = [f"{number(times[i])}, {number(u[i, k] / scale)}" for i in keep]
            amplitudes += [f"*AMPLITUDE, NAME={amp}, TIME=TOTAL TIME", *lines_of(pairs, 4)]
            boundaries.append((amp, f"{bc_sets[name]}, {k + 1}, {k + 1}, {number(scale)}"))
            if abs(v[0, k]) > ZERO:
                velocities.append(f"{bc_sets[name]}, {k + 1}, {number(v[0, k])}")
    gravity = float(np.linalg.norm(data.gravity))
    if gravity > 0:
        amplitudes += ["*AMPLITUDE, NAME=A_ON, TIME=TOTAL TIME", f"0., 1., {number(end)}, 1."]
    out += amplitudes
    if data.procedure == "dynamic" and len(amplitudes):
        out.append(
            "** CalculiX 2.20 follows a prescribed motion in *DYNAMIC otherwise than the SPEC "
            "(measured: the block at E_n up to 0.3 in CPE4 and in a C3D8 slab; static: 1e-7)"
        )
    if velocities and data.procedure == "dynamic":
        out += ["** the prescribed velocity at t = 0 (SPEC: the right derivative)"]
        out += ["*INITIAL CONDITIONS, TYPE=VELOCITY", *velocities]

    flags = ", NLGEOM" if nlgeom else ""
    output = ["*NODE FILE, FREQUENCY=1", "U", "*NODE PRINT, NSET=Nall, FREQUENCY=1", "U"]
    if data.procedure == "dynamic":  # one step of fixed increments h
        out += [f"*STEP{flags}, INC={data.steps + 10}", dynamic_keyword(alpha)]
        out.append(f"{number(data.h)}, {number(end)}")
    else:
        # one *STATIC step per t_i: a linear static step is solved once, at its end, whatever
        # its increments; the loads and boundaries carry over from step to step
        out += ["** quasi-static: one *STATIC step of length h per t_i (amplitudes in total time)"]
        out += [f"*STEP{flags}", STATIC_KEYWORD, f"{number(data.h)}, {number(data.h)}"]
    fixed = [line for amp, line in boundaries if not amp]
    if fixed:
        out += ["*BOUNDARY", *fixed]
    for amp, line in boundaries:
        if amp:
            out += [f"*BOUNDARY, AMPLITUDE={amp}", line]
    if gravity > 0:
        direction = [number(g / gravity) for g in data.gravity] + ["0."] * (3 - data.dim)
        out += ["*DLOAD, AMPLITUDE=A_ON", f"Eall, GRAV, {number(gravity)}, {', '.join(direction)}"]
    out += [*output, "*END STEP"]
    if data.procedure == "static":
        for _ in range(data.steps - 1):
            out += [f"*STEP{flags}", STATIC_KEYWORD, f"{number(data.h)}, {number(data.h)}"]
            out += [*output, "*END STEP"]
    out.append("")
    return "\n".join(out)


def write_inp(
    data: Exported,
    path: Path,
    element: str | None = None,
    alpha: float = 0.0,
) -> None:
    Path(path).write_text(inp_text(data, element, alpha))
