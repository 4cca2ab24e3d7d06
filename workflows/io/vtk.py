"""ParaView .pvd collections of .vtu files, one per time step, read as a displacement series
(read_pvd). The benchmark's own .vtu mesh is written with the export (io/exported.py)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from tissuebench.metrics.series import InputError, check_same_mesh
from tissuebench.workflows.io.fields import FieldData, missing_field
from tissuebench.workflows.io.xdmf import parse_xml


def read_pvd(path: Path, names: Sequence[str]) -> FieldData:
    import meshio

    root = parse_xml(path)
    datasets = list(root.iter("DataSet"))
    if not datasets:
        raise InputError(f"{path}: no DataSet entries in the collection")
    if len({d.get("part", "0") for d in datasets}) > 1:
        raise InputError(
            f"{path}: multi-part (parallel) collections are not supported; write one .vtu per step"
        )
    points = cells = cell_type = field = None
    times, values = [], []
    for k, dataset in enumerate(sorted(datasets, key=lambda d: float(d.get("timestep", 0)))):
        vtu = path.parent / (dataset.get("file") or "")
        if vtu.suffix.lower() != ".vtu":
            raise InputError(
                f"{path}: step {k} refers to {vtu.name!r}; only .vtu files are supported"
            )
        if not vtu.is_file():
            raise InputError(f"{vtu}: no such file (step {k} of {path})")
        try:
            mesh = meshio.vtu.read(str(vtu))  # meshio.read would sys.exit on a bad file
        except Exception as exc:  # meshio raises many kinds on bad files
            message = " ".join(str(exc).split()) or "truncated or corrupt?"
            raise InputError(f"{vtu}: not a readable VTU file ({message})") from None
        if field is None:  # the first step decides
            field = next((n for n in names if n in mesh.point_data), None)
            if field is None:
                raise missing_field(vtu, names, list(mesh.point_data))
        if field not in mesh.point_data:
            raise missing_field(vtu, (field,), list(mesh.point_data))
        if points is None:
            points = mesh.points
            blocks = [block for block in mesh.cells if len(block.data)]
            if len(blocks) != 1:
                raise InputError(
                    f"{vtu}: cells of types {[b.type for b in blocks]}; "
                    "expected one of triangle, quad, tetra or hexahedron"
                )
            cells, cell_type = blocks[0].data, blocks[0].type
        else:
            blocks = [block for block in mesh.cells if len(block.data)]
            same_type = len(blocks) == 1 and blocks[0].type == cell_type
            check_same_mesh(
                f"{vtu} (step {k} of {path.name})",
                (points, cells),
                (mesh.points, blocks[0].data if same_type else None),
            )
        try:
            times.append(float(dataset.get("timestep", k)))
        except ValueError:
            raise InputError(
                f"{path}: timestep {dataset.get('timestep')!r} is not a number"
            ) from None
        values.append(mesh.point_data[field])
    assert points is not None and cells is not None  # the first step's (there is one)
    assert cell_type is not None and field is not None
    return points, cells, cell_type, times, values, field
