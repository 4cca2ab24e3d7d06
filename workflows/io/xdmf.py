"""Time series of nodal vector fields as XDMF 3 + HDF5: written once after a run (write_series),
and read from any simulator that writes XDMF as DOLFINx or meshio do (read_xdmf).

DOLFINx's XDMFFile rewrites its whole XML file at every write_function, which makes a
300-step series cost O(steps^2); a run's history is in memory anyway, so it is gathered to
rank 0 and written in one go. The HDF5 file is built in memory and written by Python, so
that a full disk raises OSError (HDF5 itself crashes the process on ENOSPC). Every DataItem
states its number type and precision (ParaView reads float64 as float32 otherwise). Layout as
DOLFINx writes it (/Mesh/mesh/geometry, /Mesh/mesh/topology, /Function/<name>/<step>), one
temporal collection holding every field at every time; ParaView opens it with its XDMF readers.
"""

from __future__ import annotations

import io
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from mpi4py import MPI  # noqa: F401 (loads libmpi before DOLFINx does)

import h5py
import numpy as np
from dolfinx.io.utils import cell_perm_vtk

from tissuebench.metrics.series import InputError, Series, check_same_mesh, series_of
from tissuebench.workflows.io.fields import FieldData, missing_field

if TYPE_CHECKING:
    from dolfinx import fem

# a mesh gathered on rank 0: node coordinates (N, 3), cells (VTK node order), cell type name
MeshData = tuple[np.ndarray, np.ndarray, str]

TOPOLOGY = {
    "triangle": "Triangle",
    "quadrilateral": "Quadrilateral",
    "tetrahedron": "Tetrahedron",
    "hexahedron": "Hexahedron",
}


def gather_mesh(V: fem.FunctionSpace) -> tuple[MeshData | None, np.ndarray]:
    """On rank 0: node coordinates (N, 3) and cells (VTK node order) in global node numbers of
    V; on other ranks None. Also returns this rank's owned global node numbers."""
    mesh, imap = V.mesh, V.dofmap.index_map
    n_owned = imap.size_local
    owned = np.arange(*imap.local_range, dtype=np.int64)
    x = V.tabulate_dof_coordinates()[:n_owned]
    n_cells = mesh.topology.index_map(mesh.topology.dim).size_local
    local_cells = V.dofmap.list[:n_cells]
    cells = imap.local_to_global(local_cells.ravel()).reshape(local_cells.shape)
    parts = mesh.comm.gather((owned, x, cells), root=0)
    if mesh.comm.rank != 0:
        return None, owned
    N = imap.size_global
    points = np.zeros((N, 3))
    for nodes, coords, _ in parts:
        points[nodes] = coords
    cell_type = mesh.topology.cell_type.name
    perm = np.argsort(cell_perm_vtk(mesh.topology.cell_type, local_cells.shape[1]))
    cells = np.concatenate([c for _, _, c in parts])[:, perm]
    return (points, cells, cell_type), owned


def write_xdmf(
    path: str | Path,
    V: fem.FunctionSpace,
    times: Sequence[float],
    fields: dict[str, list[np.ndarray]],
) -> None:
    """Write fields {name: [owned dof values per step]} at `times` (s) to path (.xdmf) and
    path with suffix .h5. Collective; rank 0 writes (OSError on rank 0 only)."""
    gathered = gather_series(V, fields)
    if gathered is not None:
        write_series(path, gathered, times)


def gather_series(
    V: fem.FunctionSpace, fields: dict[str, list[np.ndarray]]
) -> tuple[MeshData, dict[str, np.ndarray]] | None:
    """Collective: on rank 0 (mesh, {name: (steps, nodes, 3) array}); None on other ranks."""
    comm, bs = V.mesh.comm, V.dofmap.bs
    mesh_data, owned = gather_mesh(V)
    gathered = {
        name: comm.gather((owned, np.asarray(values).reshape(len(values), len(owned), bs)), root=0)
        for name, values in fields.items()
    }
    if comm.rank != 0:
        return None
    assert mesh_data is not None  # gathered on rank 0
    points = mesh_data[0]
    n_steps = min(len(v) for v in fields.values())
    data = {}
    for name, parts in gathered.items():
        data[name] = np.zeros((n_steps, len(points), 3))
        for nodes, values in parts:
            data[name][:, nodes, :bs] = values[:n_steps]
    return mesh_data, data


def _write_steps(group: h5py.Group, values: np.ndarray) -> None:
    """One float64 dataset per step, named by its index, as `group[str(i)] = values[i]` writes
    them, through h5py's low-level calls: a third of the time for a few hundred steps (each
    high-level assignment builds its property lists again)."""
    values = np.ascontiguousarray(values, dtype=np.float64)
    space = h5py.h5s.create_simple(values.shape[1:])
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_obj_track_times(False)  # as h5py's default: no time stamps in the file
    for i, step in enumerate(values):
        dataset = h5py.h5d.create(group.id, str(i).encode(), h5py.h5t.IEEE_F64LE, space, dcpl=dcpl)
        dataset.write(h5py.h5s.ALL, h5py.h5s.ALL, step)


def write_series(
    path: str | Path,
    gathered: tuple[MeshData, dict[str, np.ndarray]] | None,
    times: Sequence[float] | np.ndarray,
) -> None:
    """Write a gathered series (see gather_series) at `times` (s): path (.xdmf) and its .h5.
    Rank 0, where gather_series' result is not None."""
    assert gathered is not None  # gather_series' on rank 0
    (points, cells, cell_type), data = gathered
    path = Path(path)
    h5name = path.with_suffix(".h5").name
    n_steps = min(len(v) for v in data.values())
    image = io.BytesIO()
    with h5py.File(image, "w") as h5:
        h5["/Mesh/mesh/geometry"] = points
        h5["/Mesh/mesh/topology"] = cells
        for name, values in data.items():
            if n_steps:  # no group for a series without steps, as before
                _write_steps(h5.require_group(f"/Function/{name}"), values[:n_steps])
    path.with_suffix(".h5").write_bytes(image.getbuffer())
    fields = list(data)
    N, (n_cells, per_cell) = len(points), cells.shape
    lines = [
        '<?xml version="1.0"?>',
        '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">',
        "  <Domain>",
        '    <Grid Name="mesh" GridType="Uniform">',
        f'      <Topology TopologyType="{TOPOLOGY[cell_type]}" NumberOfElements="{n_cells}" '
        f'NodesPerElement="{per_cell}">',
        f'        <DataItem Dimensions="{n_cells} {per_cell}" NumberType="Int" Precision="8" '
        f'Format="HDF">{h5name}:/Mesh/mesh/topology</DataItem>',
        "      </Topology>",
        '      <Geometry GeometryType="XYZ">',
        f'        <DataItem Dimensions="{N} 3" NumberType="Float" Precision="8" '
        f'Format="HDF">{h5name}:/Mesh/mesh/geometry</DataItem>',
        "      </Geometry>",
        "    </Grid>",
        '    <Grid Name="series" GridType="Collection" CollectionType="Temporal">',
    ]
    include = (
        "xpointer(/Xdmf/Domain/Grid[@GridType='Uniform'][1]/*[self::Topology or self::Geometry])"
    )
    for i in range(n_steps):
        lines += [
            f'      <Grid Name="step {i}" GridType="Uniform">',
            f'        <xi:include xpointer="{include}" />',
            f'        <Time Value="{float(times[i])!r}" />',
        ]
        for name in fields:
            lines += [
                f'        <Attribute Name="{name}" AttributeType="Vector" Center="Node">',
                f'          <DataItem Dimensions="{N} 3" NumberType="Float" Precision="8" '
                f'Format="HDF">{h5name}:/Function/{name}/{i}</DataItem>',
                "        </Attribute>",
            ]
        lines.append("      </Grid>")
    lines += ["    </Grid>", "  </Domain>", "</Xdmf>", ""]
    path.write_text("\n".join(lines))


def as_series(
    path: str | Path,
    gathered: tuple[MeshData, dict[str, np.ndarray]],
    times: Sequence[float] | np.ndarray,
    field: str = "displacement",
) -> Series:
    """The Series of `field` that read_series(path) gives of the file that write_series(path,
    gathered, times) writes, made from the gathered arrays in memory (rank 0): the same
    points, cells, times and values, checked alike (InputError, e.g. for a run that kept no
    step)."""
    (points, cells, cell_type), data = gathered
    n_steps = min(len(v) for v in data.values())
    values = [data[field][i] for i in range(n_steps)]
    stamps = [float(t) for t in times[:n_steps]]  # as the file's Time values
    return series_of(Path(path), field, points, cells, cell_type, stamps, values)


# --- reading -----------------------------------------------------------------------------------


def parse_xml(path: str | Path) -> ET.Element:
    try:
        return ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise InputError(f"{path}: not valid XML ({exc})") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror or exc})") from None


class _HDF:
    """Opened HDF5 files of one XDMF file, read through their DataItems."""

    def __init__(self, xdmf):
        self.xdmf = xdmf
        self.files = {}

    def close(self) -> None:
        for f in self.files.values():
            f.close()

    def read(self, item: ET.Element | None, what: str) -> np.ndarray:
        if item is None:
            raise InputError(f"{self.xdmf}: {what} has no DataItem")
        form = item.get("Format", "XML").upper()
        shape = tuple(int(s) for s in item.get("Dimensions", "").split())
        text = (item.text or "").strip()
        if form == "XML":
            try:
                data = np.array(text.split(), dtype=np.float64)
                return data.reshape(shape) if shape else data
            except ValueError:
                raise InputError(
                    f"{self.xdmf}: {what}: inline data does not match Dimensions {shape}"
                ) from None
        if form != "HDF":
            raise InputError(
                f"{self.xdmf}: {what}: DataItem format {form!r} is not supported (HDF or XML)"
            )
        filename, _, dataset = text.partition(":")
        h5 = self.xdmf.parent / filename
        if h5 not in self.files:
            if not h5.is_file():
                raise InputError(f"{h5}: no such file (the HDF5 data of {self.xdmf})")
            try:
                self.files[h5] = h5py.File(h5, "r")
            except OSError:
                raise InputError(
                    f"{h5}: not a readable HDF5 file (truncated or corrupt?)"
                ) from None
        try:
            data = self.files[h5][dataset][()]
        except KeyError:
            raise InputError(f"{h5}: no dataset {dataset!r} ({what})") from None
        except OSError:
            raise InputError(
                f"{h5}: dataset {dataset!r} cannot be read (truncated or corrupt?)"
            ) from None
        if shape and data.shape != shape:
            raise InputError(
                f"{h5}: dataset {dataset!r} has shape {data.shape}, {self.xdmf} says {shape}"
            )
        return data


def read_xdmf(path: Path, names: Sequence[str]) -> FieldData:
    root = parse_xml(path)
    grids = list(root.iter("Grid"))
    mesh = next(
        (g for g in grids if g.find("Topology") is not None and g.find("Geometry") is not None),
        None,
    )
    if mesh is None:
        raise InputError(f"{path}: no grid with a Topology and a Geometry")
    steps = [
        g
        for g in grids
        if g.get("GridType", "Uniform") == "Uniform" and g.find("Attribute") is not None
    ]
    fields = sorted(  # a nameless Attribute, which no name given matches, is left out
        {name for g in steps for a in g.findall("Attribute") if (name := a.get("Name")) is not None}
    )
    field = next((n for n in names if n in fields), None)
    if field is None:
        raise missing_field(path, names, fields)
    steps = [g for g in steps if _attribute(g, field) is not None]
    hdf = _HDF(path)
    try:
        topology, geometry = mesh.find("Topology"), mesh.find("Geometry")
        assert topology is not None and geometry is not None  # mesh was chosen for them
        cell_type = topology.get("TopologyType", topology.get("Type", "")).lower()
        if geometry.get("GeometryType", geometry.get("Type", "XYZ")).upper() not in ("XY", "XYZ"):
            raise InputError(
                f"{path}: geometry type {geometry.get('GeometryType')!r} is not supported (XY or "
                "XYZ)"
            )
        points = hdf.read(geometry.find("DataItem"), "the geometry")
        cells = hdf.read(topology.find("DataItem"), "the topology")
        times, values = [], []
        for k, grid in enumerate(steps):
            time = grid.find("Time")
            try:
                times.append(float(time.get("Value", "")) if time is not None else float(k))
            except (TypeError, ValueError):
                assert time is not None  # float(k) does not fail
                raise InputError(
                    f"{path}: time value {time.get('Value')!r} is not a number"
                ) from None
            step_mesh = (
                _step_data(hdf, grid.find("Geometry"), geometry, points, "the geometry"),
                _step_data(hdf, grid.find("Topology"), topology, cells, "the topology"),
            )
            if step_mesh[0] is not points or step_mesh[1] is not cells:
                where = f"{path} (step {k}, t = {times[-1]:g})"
                check_same_mesh(where, (points, cells), step_mesh)
            attribute = _attribute(grid, field)
            if attribute.get("Center", "Node") != "Node":
                raise InputError(f"{path}: field {field!r} is not a point (Node) field")
            values.append(
                hdf.read(attribute.find("DataItem"), f"field {field!r} at time {times[-1]:g}")
            )
    finally:
        hdf.close()
    return points, cells, cell_type, times, values, field


def xdmf_size(path: Path, names: Sequence[str]) -> tuple[float, int, int] | None:
    """(bytes, nodes, steps): a lower bound of the memory (bytes) that read_xdmf and
    series_of hold for the series of the first of `names` in the XDMF file, from the shapes
    and types of its datasets alone (h5py opens the HDF5 files; no data is read): every
    step's field, the larger of as read (read_xdmf reads every step before series_of converts
    them) and as kept (float64, d columns: d = 2 for triangles and quadrilaterals, else 3),
    and the mesh. None when the file does not say (a reader then names the problem)."""
    try:
        root = ET.parse(path).getroot()
        grids = list(root.iter("Grid"))
        mesh = next(g for g in grids if g.find("Topology") is not None)
        topology = mesh.find("Topology")
        assert topology is not None  # mesh was chosen for it
        kind = topology.get("TopologyType", topology.get("Type", "")).lower()
        dim = 2 if kind in ("triangle", "quadrilateral", "quad") else 3
        attributes = [a for g in grids for a in g.findall("Attribute")]
        field = next(n for n in names if any(a.get("Name") == n for a in attributes))
        items = [a.find("DataItem") for a in attributes if a.get("Name") == field]
        files, shapes = {}, []
        try:
            for item in [topology.find("DataItem"), *items]:
                assert item is not None  # else no size: None, below
                shape = tuple(int(x) for x in (item.get("Dimensions") or "").split())
                size = 8  # bytes per value: inline XML data is read as float64
                if item.get("Format", "XML").upper() == "HDF":
                    name, _, dataset = (item.text or "").strip().partition(":")
                    h5 = path.parent / name
                    if h5 not in files:
                        files[h5] = h5py.File(h5, "r")
                    data = files[h5][dataset]  # its shape and type only: nothing is read
                    shape, size = data.shape, data.dtype.itemsize
                shapes.append((shape, size))
        finally:
            for f in files.values():
                f.close()
        ((cells, *per_cell), _), fields = shapes[0], shapes[1:]
        if not fields or any(len(shape) != 2 for shape, _ in fields):
            return None
        nodes = fields[0][0][0]
        read = sum(n * c * size for (n, c), size in fields)
        kept = 8 * sum(n * min(c, dim) for (n, c), _ in fields)
        mesh = 8 * (nodes * dim + cells * int(np.prod(per_cell, dtype=np.int64)))
        return float(max(read, kept) + mesh), int(nodes), len(fields)
    except Exception:  # anything a file can hold: the reader will say what is wrong
        return None


def _step_data(hdf, element, first_element, first_data, what):
    """The data of a step grid's own Geometry or Topology `element`: the first's
    (`first_data`) when the step has none (XDMF's xi:include of the first, as DOLFINx and
    meshio write), names the same HDF5 dataset, or is a Reference to other data."""
    item = None if element is None else element.find("DataItem")
    first = first_element.find("DataItem")
    if item is None or item is first or item.get("Reference") is not None:
        return first_data
    same_form = item.get("Format", "XML").upper() == first.get("Format", "XML").upper() == "HDF"
    if same_form and (item.text or "").strip() == (first.text or "").strip():
        return first_data
    return hdf.read(item, what)


def _attribute(grid, field):
    return next((a for a in grid.findall("Attribute") if a.get("Name") == field), None)


# --- PVD + VTU ------------------------------------------------------------------------------
