"""Time series of nodal vector fields as XDMF 3 + HDF5, written once after a run.

DOLFINx's XDMFFile rewrites its whole XML file at every write_function, which makes a
300-step series cost O(steps^2); a run's history is in memory anyway, so it is gathered to
rank 0 and written in one go. The HDF5 file is built in memory and written by Python, so
that a full disk raises OSError (HDF5 itself crashes the process on ENOSPC). Every DataItem
states its number type and precision (ParaView reads float64 as float32 otherwise). Layout as DOLFINx writes it (/Mesh/mesh/geometry,
/Mesh/mesh/topology, /Function/<name>/<step>), one temporal collection holding every field
at every time; ParaView opens it with its XDMF readers.
"""

import io
from pathlib import Path

import h5py
import numpy as np
from dolfinx.io.utils import cell_perm_vtk

TOPOLOGY = {
    "triangle": "Triangle",
    "quadrilateral": "Quadrilateral",
    "tetrahedron": "Tetrahedron",
    "hexahedron": "Hexahedron",
}


def gather_mesh(V):
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


def write_xdmf(path, V, times, fields):
    """Write fields {name: [owned dof values per step]} at `times` (s) to path (.xdmf) and
    path with suffix .h5. Collective; rank 0 writes (OSError on rank 0 only)."""
    gathered = gather_series(V, fields)
    if gathered is not None:
        write_series(path, gathered, times)


def gather_series(V, fields):
    """Collective: on rank 0 (mesh, {name: (steps, nodes, 3) array}); None on other ranks."""
    comm, bs = V.mesh.comm, V.dofmap.bs
    mesh_data, owned = gather_mesh(V)
    gathered = {
        name: comm.gather((owned, np.asarray(values).reshape(len(values), len(owned), bs)), root=0)
        for name, values in fields.items()
    }
    if comm.rank != 0:
        return None
    points = mesh_data[0]
    n_steps = min(len(v) for v in fields.values())
    data = {}
    for name, parts in gathered.items():
        data[name] = np.zeros((n_steps, len(points), 3))
        for nodes, values in parts:
            data[name][:, nodes, :bs] = values[:n_steps]
    return mesh_data, data


def write_series(path, gathered, times):
    """Write a gathered series (see gather_series) at `times` (s): path (.xdmf) and its .h5."""
    (points, cells, cell_type), data = gathered
    path = Path(path)
    h5name = path.with_suffix(".h5").name
    n_steps = min(len(v) for v in data.values())
    image = io.BytesIO()
    with h5py.File(image, "w") as h5:
        h5["/Mesh/mesh/geometry"] = points
        h5["/Mesh/mesh/topology"] = cells
        for name, values in data.items():
            for i in range(n_steps):
                h5[f"/Function/{name}/{i}"] = values[i]
    path.with_suffix(".h5").write_bytes(image.getbuffer())
    fields = list(data)
    N, (n_cells, per_cell) = len(points), cells.shape
    lines = [
        '<?xml version="1.0"?>',
        '<Xdmf Version="3.0" xmlns:xi="http://www.w3.org/2001/XInclude">',
        "  <Domain>",
        '    <Grid Name="mesh" GridType="Uniform">',
        f'      <Topology TopologyType="{TOPOLOGY[cell_type]}" NumberOfElements="{n_cells}" NodesPerElement="{per_cell}">',
        f'        <DataItem Dimensions="{n_cells} {per_cell}" NumberType="Int" Precision="8" Format="HDF">{h5name}:/Mesh/mesh/topology</DataItem>',
        "      </Topology>",
        '      <Geometry GeometryType="XYZ">',
        f'        <DataItem Dimensions="{N} 3" NumberType="Float" Precision="8" Format="HDF">{h5name}:/Mesh/mesh/geometry</DataItem>',
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
                f'          <DataItem Dimensions="{N} 3" NumberType="Float" Precision="8" Format="HDF">{h5name}:/Function/{name}/{i}</DataItem>',
                "        </Attribute>",
            ]
        lines.append("      </Grid>")
    lines += ["    </Grid>", "  </Domain>", "</Xdmf>", ""]
    path.write_text("\n".join(lines))
