"""Displacement time series read from files written by other simulators.

Formats: XDMF with HDF5 (or inline XML) data, as DOLFINx's XDMFFile.write_function and
meshio's TimeSeriesWriter write it, and ParaView .pvd collections of .vtu files. The mesh is
vector Q1: quadrilaterals (2D; a zero third coordinate, as meshio and ParaView store 2D
data, is dropped) or hexahedra (3D). Cells are returned in VTK node order, as the files hold
them. Anything else raises InputError with one line naming the file and the problem.
"""

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

# file cell names -> (our cell type, nodes per cell)
CELLS = {
    "quadrilateral": ("quadrilateral", 4), "quad": ("quadrilateral", 4),
    "hexahedron": ("hexahedron", 8),
}


class InputError(ValueError):
    """Input files that cannot be compared: the message is one line naming file and problem."""


@dataclass
class Series:
    """A displacement time series on one mesh: points (n, d), cells (VTK node order),
    cell_type ("quadrilateral" or "hexahedron"), times (steps,) and displacements, a list of
    (n, d) arrays, one per time."""

    path: Path
    points: np.ndarray
    cells: np.ndarray
    cell_type: str
    times: np.ndarray
    displacements: list

    @property
    def dim(self):
        return self.points.shape[1]


def read_series(path, field="displacement"):
    """The Series of point field `field` in an .xdmf or .pvd file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    readers = {".xdmf": _read_xdmf, ".pvd": _read_pvd}
    if path.suffix.lower() not in readers:
        raise InputError(f"{path}: unknown format {path.suffix!r}; expected .xdmf (with .h5) or .pvd (with .vtu)")
    points, cells, cell_type, times, values = readers[path.suffix.lower()](path, field)
    return _finish(path, field, points, cells, cell_type, times, values)


def _finish(path, field, points, cells, cell_type, times, values):
    """Check shapes, reduce 2D data stored in 3D to d columns and build the Series."""
    if cell_type not in CELLS:
        raise InputError(f"{path}: cells of type {cell_type!r}; only quadrilaterals and hexahedra are supported")
    cell_type, per_cell = CELLS[cell_type]
    points = np.asarray(points, dtype=np.float64)
    cells = np.asarray(cells, dtype=np.int64)
    n = len(points)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or n == 0:
        raise InputError(f"{path}: point coordinates of shape {points.shape}, expected (n, 2) or (n, 3)")
    if cells.ndim != 2 or cells.shape[1] != per_cell or len(cells) == 0:
        raise InputError(f"{path}: {cell_type} cells of shape {cells.shape}, expected (cells, {per_cell})")
    if cells.min() < 0 or cells.max() >= n:
        raise InputError(f"{path}: cells refer to points outside 0..{n - 1}")
    if not np.isfinite(points).all():
        raise InputError(f"{path}: point coordinates are not finite")
    dim = 2 if cell_type == "quadrilateral" else 3
    if points.shape[1] < dim:
        raise InputError(f"{path}: hexahedra with 2D points")
    if points.shape[1] > dim and np.any(points[:, dim:] != 0):
        raise InputError(f"{path}: quadrilaterals with a non-zero third coordinate (a surface in 3D is not supported)")
    times = np.asarray(times, dtype=np.float64)
    if len(times) == 0:
        raise InputError(f"{path}: no time steps")
    if np.any(np.diff(times) <= 0):
        raise InputError(f"{path}: time stamps are not increasing")
    displacements = []
    for t, u in zip(times, values):
        u = np.asarray(u, dtype=np.float64)
        if u.ndim != 2 or u.shape[0] != n or u.shape[1] < dim or u.shape[1] > 3:
            raise InputError(f"{path}: field {field!r} at time {t:g} has shape {u.shape}, expected ({n}, {dim})")
        if u.shape[1] > dim and np.any(u[:, dim:] != 0):
            raise InputError(f"{path}: 2D mesh but field {field!r} at time {t:g} has a non-zero third component")
        displacements.append(np.ascontiguousarray(u[:, :dim]))
    return Series(path, np.ascontiguousarray(points[:, :dim]), cells, cell_type, times, displacements)


# --- XDMF -----------------------------------------------------------------------------------


def _parse_xml(path):
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

    def close(self):
        for f in self.files.values():
            f.close()

    def read(self, item, what):
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
                raise InputError(f"{self.xdmf}: {what}: inline data does not match Dimensions {shape}") from None
        if form != "HDF":
            raise InputError(f"{self.xdmf}: {what}: DataItem format {form!r} is not supported (HDF or XML)")
        filename, _, dataset = text.partition(":")
        h5 = self.xdmf.parent / filename
        if h5 not in self.files:
            if not h5.is_file():
                raise InputError(f"{h5}: no such file (the HDF5 data of {self.xdmf})")
            try:
                self.files[h5] = h5py.File(h5, "r")
            except OSError:
                raise InputError(f"{h5}: not a readable HDF5 file (truncated or corrupt?)") from None
        try:
            data = self.files[h5][dataset][()]
        except KeyError:
            raise InputError(f"{h5}: no dataset {dataset!r} ({what})") from None
        except OSError:
            raise InputError(f"{h5}: dataset {dataset!r} cannot be read (truncated or corrupt?)") from None
        if shape and data.shape != shape:
            raise InputError(f"{h5}: dataset {dataset!r} has shape {data.shape}, {self.xdmf} says {shape}")
        return data


def _read_xdmf(path, field):
    root = _parse_xml(path)
    grids = list(root.iter("Grid"))
    mesh = next((g for g in grids if g.find("Topology") is not None and g.find("Geometry") is not None), None)
    if mesh is None:
        raise InputError(f"{path}: no grid with a Topology and a Geometry")
    steps = [g for g in grids if g.get("GridType", "Uniform") == "Uniform" and g.find("Attribute") is not None]
    names = sorted({a.get("Name") for g in steps for a in g.findall("Attribute")})
    steps = [g for g in steps if _attribute(g, field) is not None]
    if not steps:
        raise InputError(f"{path}: no point field {field!r}; fields: {', '.join(names) or 'none'}")
    hdf = _HDF(path)
    try:
        topology, geometry = mesh.find("Topology"), mesh.find("Geometry")
        cell_type = topology.get("TopologyType", topology.get("Type", "")).lower()
        if geometry.get("GeometryType", geometry.get("Type", "XYZ")).upper() not in ("XY", "XYZ"):
            raise InputError(f"{path}: geometry type {geometry.get('GeometryType')!r} is not supported (XY or XYZ)")
        points = hdf.read(geometry.find("DataItem"), "the geometry")
        cells = hdf.read(topology.find("DataItem"), "the topology")
        times, values = [], []
        for k, grid in enumerate(steps):
            time = grid.find("Time")
            try:
                times.append(float(time.get("Value")) if time is not None else float(k))
            except (TypeError, ValueError):
                raise InputError(f"{path}: time value {time.get('Value')!r} is not a number") from None
            attribute = _attribute(grid, field)
            if attribute.get("Center", "Node") != "Node":
                raise InputError(f"{path}: field {field!r} is not a point (Node) field")
            values.append(hdf.read(attribute.find("DataItem"), f"field {field!r} at time {times[-1]:g}"))
    finally:
        hdf.close()
    return points, cells, cell_type, times, values


def _attribute(grid, field):
    return next((a for a in grid.findall("Attribute") if a.get("Name") == field), None)


# --- PVD + VTU ------------------------------------------------------------------------------


def _read_pvd(path, field):
    import meshio

    root = _parse_xml(path)
    datasets = list(root.iter("DataSet"))
    if not datasets:
        raise InputError(f"{path}: no DataSet entries in the collection")
    if len({d.get("part", "0") for d in datasets}) > 1:
        raise InputError(f"{path}: multi-part (parallel) collections are not supported; write one .vtu per step")
    points = cells = cell_type = None
    times, values = [], []
    for k, dataset in enumerate(sorted(datasets, key=lambda d: float(d.get("timestep", 0)))):
        vtu = path.parent / (dataset.get("file") or "")
        if vtu.suffix.lower() != ".vtu":
            raise InputError(f"{path}: step {k} refers to {vtu.name!r}; only .vtu files are supported")
        if not vtu.is_file():
            raise InputError(f"{vtu}: no such file (step {k} of {path})")
        try:
            mesh = meshio.vtu.read(str(vtu))  # meshio.read would sys.exit on a bad file
        except Exception as exc:  # meshio raises many kinds on bad files
            message = " ".join(str(exc).split()) or "truncated or corrupt?"
            raise InputError(f"{vtu}: not a readable VTU file ({message})") from None
        if field not in mesh.point_data:
            raise InputError(f"{vtu}: no point field {field!r}; fields: {', '.join(mesh.point_data) or 'none'}")
        if points is None:
            points = mesh.points
            blocks = [block for block in mesh.cells if len(block.data)]
            if len(blocks) != 1:
                raise InputError(f"{vtu}: cells of types {[b.type for b in blocks]}; expected one of quad or hexahedron")
            cells, cell_type = blocks[0].data, blocks[0].type
        elif len(mesh.points) != len(points):
            raise InputError(f"{vtu}: {len(mesh.points)} points, the first step has {len(points)}")
        try:
            times.append(float(dataset.get("timestep", k)))
        except ValueError:
            raise InputError(f"{path}: timestep {dataset.get('timestep')!r} is not a number") from None
        values.append(mesh.point_data[field])
    return points, cells, cell_type, times, values
