"""CalculiX output read as it comes: the ASCII .frd (mesh and nodal results at every increment)
and the .dat of *NODE PRINT (nodal values, no mesh: the mesh is read from the deck, the .inp
of the same name beside it).

The .frd is CalculiX GraphiX's fixed-width format (cgx manual, "Result Format"): records
begin with a key (`    2C` nodes, `    3C` elements, `  100C` a result block, ` -1` a record,
` -2` its continuation, ` -3` the end of a block, ` 9999` the end of the file); numbers
are E12.5 fields that run together when negative (` -1         1-1.23456E-01-2.34567E-02`),
so they are cut by column, never split on spaces. Short (I5 node numbers) and long (I10)
formats are read; the binary one is refused. Six significant digits are printed, of the
times too (`3.33333E-02`).

No maintained package reads .frd results into arrays: meshio reads neither .frd nor .dat;
ccx2paraview converts .frd into VTK files through module-global state and needs VTK; so
this module is small and tested on CalculiX's own output (tests/test_export.py).

Every reader raises InputError with one line naming the file (and the line) on anything it
cannot take; a file that ends inside a block or without its closing record is truncated.

The deck that CalculiX runs is written by calculix_deck.py.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tissuebench.metrics.series import InputError
from tissuebench.workflows.io.calculix_deck import (  # noqa: F401 (read here before)
    check_inp_model,
    inp_text,
    kinks,
)
from tissuebench.workflows.io.fields import FieldData

# .frd element types -> (nodes per element, our cell type or None when not supported)
FRD_ELEMENTS = {
    1: (8, "hexahedron"),  # he8
    2: (6, None),  # pe6
    3: (4, None),  # te4
    4: (20, "hexahedron"),  # he20: read at its 8 corners (FRD_CORNERS)
    5: (15, None),  # pe15
    6: (10, None),  # te10
    7: (3, None),  # tr3
    8: (6, None),  # tr6
    9: (4, "quadrilateral"),  # qu4
    10: (8, None),  # qu8
    11: (2, None),  # be2
    12: (3, None),  # be3
}
FRD_NAMES = {2: "pe6", 3: "te4", 4: "he20", 5: "pe15", 6: "te10", 7: "tr3", 8: "tr6", 10: "qu8"}
# second-order cells read at their corners: the first 8 of the 20 nodes (CalculiX's C3D20 order)
FRD_CORNERS = {4: 8}
FRD_NAMES.update({11: "be2", 12: "be3"})
# the names of nodal results as *NODE FILE requests them -> as the .frd stores them
FRD_ALIASES = {"U": "DISP", "V": "VELO", "RF": "FORC", "NT": "NDTEMP"}
WIDTH = 12  # an E12.5 field
# CalculiX deck elements -> nodes per element, our cell type (20-node ones read at their 8
# corners, the first 8 of their nodes)
INP_ELEMENTS = {
    **{e: (8, "hexahedron") for e in ("C3D8", "C3D8R", "C3D8I", "C3D8H", "C3D8RH")},
    **{e: (20, "hexahedron") for e in ("C3D20", "C3D20R", "C3D20H", "C3D20RH")},
    **{
        e: (4, "quadrilateral")
        for e in ("CPE4", "CPE4R", "CPE4I", "CPS4", "CPS4R", "CPS4I", "CAX4", "CAX4R")
    },
}
DAT_FIELD = "U"  # the .dat's displacements, named by the *NODE PRINT key that requests them


def to_float(text: str) -> float:
    """A Fortran E field; one too large for its exponent is printed without the E
    (`1.23456-100`), NaN and Infinity as words. ValueError if it is none of these."""
    try:
        return float(text)
    except ValueError:
        match = re.fullmatch(r"\s*([+-]?\d*\.\d*)([+-]\d+)\s*", text)
        if match is None:
            raise
        return float(f"{match.group(1)}e{match.group(2)}")


class _Lines:
    """The lines of a text file with their numbers, for messages."""

    def __init__(self, path: Path):
        self.path = path
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None
        if b"\0" in raw[:4096]:
            raise InputError(
                f"{path}: a binary file; write the ASCII form (CalculiX's default for .frd)"
            )
        self.lines = raw.decode("latin-1").splitlines()
        self.k = 0

    def next(self, inside: str) -> str:
        if self.k >= len(self.lines):
            raise InputError(
                f"{self.path}: truncated: the file ends inside {inside} (line {self.k})"
            )
        line = self.lines[self.k]
        self.k += 1
        return line

    def error(self, what: str) -> InputError:
        return InputError(f"{self.path}: line {self.k}: {what}")


def _fields(src: _Lines, line: str, start: int, count: int, what: str) -> list[float]:
    """`count` E12.5 numbers of `line` from column `start`."""
    end = start + count * WIDTH
    if len(line.rstrip("\r\n")) < end:
        raise src.error(f"{what}: the record is cut short (truncated file?)")
    values = []
    for j in range(start, end, WIDTH):
        try:
            values.append(to_float(line[j : j + WIDTH]))
        except ValueError:
            text = line[j : j + WIDTH].strip()
            raise src.error(
                f"{what}: {text!r} (columns {j + 1}-{j + WIDTH}) is not a number"
            ) from None
    return values


def _integer(src: _Lines, text: str, what: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise src.error(f"{what}: {text.strip()!r} is not a whole number") from None


def _block_format(src: _Lines, line: str) -> int:
    """The format indicator that ends a 2C, 3C or 100C line: 0 short, 1 long, 2 binary."""
    token = line.split()[-1] if line.split() else ""
    value = int(token) if token.isdigit() else 1
    if value == 2:
        raise src.error("a binary block; write the ASCII .frd (CalculiX's default)")
    if value not in (0, 1):
        raise src.error(f"unknown format indicator {token!r}")
    return value


def read_frd(path: str | Path, names: Sequence[str] = ("DISP",)) -> FieldData:
    """(points, cells, cell_type, times, values, field) of an ASCII .frd: its nodes (n, 3),
    first-order cells (one type: hexahedra or quadrilaterals, VTK node order, which is
    CalculiX's; a 20-node hexahedron is read as the hexahedron of its 8 corners), the times of
    the result blocks of the first of `names` that the file holds (U names DISP, as in *NODE
    FILE), the (n, components) values of each, and that name. Nodes that no cell uses (a
    20-node hexahedron's midside nodes) are left out."""
    path = Path(path)
    src = _Lines(path)
    nodes: dict[int, list[float]] = {}
    elements: list[tuple[int, list[int]]] = []
    blocks: dict[str, list] = {}  # name -> [(time, {node: values})]
    ended = False
    while src.k < len(src.lines):
        line = src.next("the file")
        key = line[:5].strip()
        if key == "9999":
            ended = True
            break
        if key == "2" and line[5:6] == "C":
            _read_nodes(src, line, nodes)
        elif key == "3" and line[5:6] == "C":
            _read_elements(src, line, elements)
        elif key == "100" and line[5:6] == "C":
            name, t, by_node = _read_results(src, line)
            blocks.setdefault(name, []).append((t, by_node))
    if not ended:
        raise InputError(
            f"{path}: truncated: no closing 9999 record (cut short, or CalculiX has not "
            "finished writing it)"
        )
    if not nodes or not elements:
        raise InputError(f"{path}: no {'nodes' if not nodes else 'elements'} in the file")
    wanted = [FRD_ALIASES.get(n, n) if FRD_ALIASES.get(n, n) in blocks else n for n in names]
    found = next((n for n in wanted if n in blocks), None)
    if found is None:
        asked = f"{names[0]!r}" + (f" (nor {', '.join(names[1:])})" if len(names) > 1 else "")
        raise InputError(
            f"{path}: no nodal result {asked}; results: {', '.join(blocks) or 'none'}"
            + ("" if blocks else " (request U with *NODE FILE)")
        )
    kinds = {FRD_ELEMENTS[t][1] for t, _ in elements}
    if len(kinds) != 1:
        raise InputError(f"{path}: cells of several types; expected one of he8, he20 or qu4")
    cell_type = kinds.pop()
    assert cell_type is not None  # _read_elements refuses the other types
    used = sorted({n for _, conn in elements for n in conn})
    missing = [n for n in used if n not in nodes]
    if missing:
        raise InputError(f"{path}: cells use node {missing[0]}, which has no coordinates")
    index = {n: i for i, n in enumerate(used)}
    points = np.array([nodes[n] for n in used])
    cells = np.array([[index[n] for n in conn] for _, conn in elements], dtype=np.int64)
    times: list[float] = []
    values: list[np.ndarray] = []
    for t, result in blocks[found]:
        lacking = [n for n in used if n not in result]
        if lacking:
            raise InputError(
                f"{path}: {found} at t = {t:g} has no value for node {lacking[0]} "
                f"({len(lacking)} node(s) of the cells lack one)"
            )
        times.append(t)
        values.append(np.array([result[n] for n in used]))
    return points, cells, cell_type, times, values, found


def _read_nodes(src: _Lines, header: str, nodes: dict) -> None:
    long = _block_format(src, header) == 1
    start = 13 if long else 8
    while True:
        line = src.next("the node block")
        key = line[:3].strip()
        if key == "-3":
            return
        if key != "-1":
            raise src.error("expected a node record (-1) or the end of the block (-3)")
        node = _integer(src, line[3:start], "node number")
        nodes[node] = _fields(src, line, start, 3, f"node {node}")


def _read_elements(src: _Lines, header: str, elements: list) -> None:
    long = _block_format(src, header) == 1
    start, width = (13, 10) if long else (8, 5)
    while True:
        line = src.next("the element block")
        key = line[:3].strip()
        if key == "-3":
            return
        if key != "-1":
            raise src.error("expected an element record (-1) or the end of the block (-3)")
        element = _integer(src, line[3:start], "element number")
        kind = _integer(src, line[start : start + 5], f"type of element {element}")
        if kind not in FRD_ELEMENTS or FRD_ELEMENTS[kind][1] is None:
            name = FRD_NAMES.get(kind, f"type {kind}")
            raise InputError(
                f"{src.path}: element {element} is a {name}; only hexahedra (he8: C3D8, C3D8R, "
                "C3D8I; he20: C3D20R, at its corners) and quadrilaterals (qu4: CPE4, CPS4, ...) "
                "are graded"
            )
        count = FRD_ELEMENTS[kind][0]
        connectivity: list[int] = []
        while len(connectivity) < count:
            row = src.next(f"element {element}")
            if row[:3].strip() != "-2":
                raise src.error(f"element {element}: expected its nodes (-2)")
            text = row[3:].rstrip()
            cut = [text[j : j + width] for j in range(0, len(text), width)]
            connectivity += [_integer(src, c, f"element {element}") for c in cut if c.strip()]
        elements.append((kind, connectivity[: FRD_CORNERS.get(kind, count)]))


def _read_results(src: _Lines, header: str) -> tuple[str, float, dict[int, list[float]]]:
    """A nodal result block: (name, time, {node: values})."""
    long = _block_format(src, header) == 1
    start = 13 if long else 8
    try:
        t = to_float(header[12:24])
    except ValueError:
        raise src.error(f"the time {header[12:24].strip()!r} is not a number") from None
    line = src.next("a result block")
    if line[:3].strip() != "-4":
        raise src.error("expected the result's name (-4)")
    name = line[5:13].strip()
    components = _integer(src, line[13:18], f"components of {name}")
    stored = 0
    for _ in range(components):
        line = src.next(f"the components of {name}")
        if line[:3].strip() != "-5":
            raise src.error(f"{name}: expected a component (-5)")
        exists = line[33:38].strip()
        stored += exists in ("", "0")  # 1: computed by the viewer (ALL), not stored
    values: dict[int, list[float]] = {}
    what = f"{name} at t = {t:g}"
    while True:
        line = src.next(what)
        key = line[:3].strip()
        if key == "-3":
            return name, t, values
        if key != "-1":
            raise src.error(f"{what}: expected a node record (-1) or the end of the block (-3)")
        node = _integer(src, line[3:start], f"{what}: node number")
        row = _fields(src, line, start, min(stored, 6), f"{what}, node {node}")
        while len(row) < stored:
            more = src.next(what)
            if more[:3].strip() != "-2":
                raise src.error(f"{what}, node {node}: expected its continuation (-2)")
            row += _fields(src, more, start, min(stored - len(row), 6), f"{what}, node {node}")
        values[node] = row


# --- .dat ---------------------------------------------------------------------------------------

DAT_HEADER = re.compile(r"^\s*(\w[\w ]*?)\s*\(([^)]*)\)\s*for set\s+(\S+)\s+and time\s+(\S+)\s*$")


def read_dat(path: str | Path, names: Sequence[str] = (DAT_FIELD,)) -> FieldData:
    """(points, cells, cell_type, times, values, field) of a CalculiX .dat with the
    displacements that *NODE PRINT writes (`U`), on the mesh of the deck beside it (the .inp
    of the same name)."""
    path = Path(path)
    if not any(n in (DAT_FIELD, "DISP") for n in names):
        raise InputError(
            f"{path}: no nodal result {names[0]!r}; a .dat's displacements are {DAT_FIELD}"
        )
    deck = path.with_suffix(".inp")
    if not deck.is_file():
        raise InputError(f"{path}: a .dat holds no mesh: its deck {deck.name} must be beside it")
    points, cells, cell_type, ids = read_inp_mesh(deck)
    src = _Lines(path)
    steps: dict[str, dict[int, list[float]]] = {}
    order: list[str] = []
    lines = src.lines
    while src.k < len(lines):
        line = src.next("the file")
        match = DAT_HEADER.match(line)
        if not match or not match.group(1).startswith("displacements"):
            continue
        stamp = match.group(4)
        if stamp not in steps:
            steps[stamp] = {}
            order.append(stamp)
        values = steps[stamp]
        while src.k < len(lines) and not lines[src.k].strip():
            src.k += 1
        while src.k < len(lines) and lines[src.k].strip():
            row = src.next("a displacement block")
            if DAT_HEADER.match(row):
                src.k -= 1
                break
            node = _integer(src, row[:10], "node number")
            values[node] = _dat_fields(src, row, f"node {node} at t = {stamp}")
    if not order:
        raise InputError(
            f"{path}: no displacements (request U with *NODE PRINT, NSET=Nall, every increment)"
        )
    times, series = [], []
    for stamp in order:
        try:
            t = to_float(stamp)
        except ValueError:
            raise InputError(f"{path}: the time {stamp!r} is not a number") from None
        values = steps[stamp]
        lacking = [n for n in ids if n not in values]
        if lacking:
            raise InputError(
                f"{path}: the displacements at t = {stamp} lack node {lacking[0]} "
                f"({len(lacking)} of the {len(ids)} nodes of {deck.name}): print every node "
                "(*NODE PRINT, NSET=Nall)"
            )
        times.append(t)
        series.append(np.array([values[n] for n in ids]))
    return points, cells, cell_type, times, series, DAT_FIELD


def _dat_fields(src: _Lines, row: str, what: str) -> list[float]:
    """The values after the node number: 1X,E13.6 fields of 14 columns."""
    text = row[10:].rstrip()
    if not text or len(text) % 14:
        raise src.error(f"{what}: the record is cut short or not in 14-column fields")
    try:
        return [to_float(text[j : j + 14]) for j in range(0, len(text), 14)]
    except ValueError:
        raise src.error(f"{what}: {text.strip()!r} are not numbers") from None


# --- .inp (the mesh only) -------------------------------------------------------------------------


def _keyword(line: str) -> tuple[str, dict]:
    parts = [p.strip() for p in line[1:].split(",")]
    params = {}
    for p in parts[1:]:
        if p:
            key, _, value = p.partition("=")
            params[key.strip().upper()] = value.strip()
    return parts[0].upper(), params


def read_inp_mesh(
    path: str | Path, depth: int = 0
) -> tuple[np.ndarray, np.ndarray, str, list[int]]:
    """(points (n, 3), cells (VTK order), cell_type, node ids) of a CalculiX deck: its *NODE
    and *ELEMENT cards (following *INCLUDE), hexahedra or quadrilaterals of one shape (a
    20-node hexahedron taken at its 8 corners); the nodes that no element uses (its midside
    nodes) are left out."""
    path = Path(path)
    nodes: dict[int, list[float]] = {}
    elements: list[list[int]] = []
    kinds: set[str] = set()
    _scan_inp(path, nodes, elements, kinds, depth)
    if not elements:
        raise InputError(f"{path}: no *ELEMENT card of hexahedra or quadrilaterals")
    types = {INP_ELEMENTS[k][1] for k in kinds}
    if len(types) != 1:
        raise InputError(f"{path}: elements of several shapes ({', '.join(sorted(kinds))})")
    used = sorted({n for conn in elements for n in conn})
    missing = [n for n in used if n not in nodes]
    if missing:
        raise InputError(f"{path}: elements use node {missing[0]}, which no *NODE card defines")
    index = {n: i for i, n in enumerate(used)}
    points = np.array([nodes[n] + [0.0] * (3 - len(nodes[n])) for n in used])
    cells = np.array([[index[n] for n in conn] for conn in elements], dtype=np.int64)
    return points, cells, types.pop(), used


def _scan_inp(path: Path, nodes: dict, elements: list, kinds: set, depth: int) -> None:
    if depth > 8:
        raise InputError(f"{path}: *INCLUDE nested more than 8 deep")
    src = _Lines(path)
    card, count = None, 0
    pending: list[int] = []
    for number, raw in enumerate(src.lines, start=1):
        line = raw.strip()
        if not line or line.startswith("**"):
            continue
        if line.startswith("*"):
            card, params = _keyword(line)
            if card == "INCLUDE":
                target = path.parent / params.get("INPUT", "")
                if not target.is_file():
                    raise InputError(
                        f"{path}: line {number}: *INCLUDE names {target}, no such file"
                    )
                _scan_inp(target, nodes, elements, kinds, depth + 1)
                card = None
            elif card == "ELEMENT":
                kind = params.get("TYPE", "").upper()
                if kind not in INP_ELEMENTS:
                    raise InputError(
                        f"{path}: line {number}: elements of type {kind or '(none)'}; only "
                        f"hexahedra and quadrilaterals ({', '.join(INP_ELEMENTS)}) are graded"
                    )
                kinds.add(kind)
                count, pending = INP_ELEMENTS[kind][0], []
            continue
        values = [v.strip() for v in line.split(",")]
        try:
            if card == "NODE":
                nodes[int(values[0])] = [float(v) for v in values[1:4] if v]
            elif card == "ELEMENT":
                pending += [int(v) for v in values if v]
                if len(pending) >= count + 1:  # a 20-node hexahedron: its 8 corners
                    elements.append(pending[1 : 1 + (8 if count == 20 else count)])
                    pending = []
        except ValueError:
            raise InputError(f"{path}: line {number}: cannot read {line[:60]!r}") from None
