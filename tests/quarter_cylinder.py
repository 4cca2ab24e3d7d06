"""A quarter of SPEC 13's cylinder (x >= 0, y >= 0) in second-order gmsh tetrahedra graded toward
the top face's centre, for the 3D push that the meridian's truth is checked against
(test_hertz3d.py). The cells are h_near m within `reach` m of (0, 0, H), growing linearly to
h_far m at 0.4 m from it; the side is curved (second-order geometry)."""

from mpi4py import MPI

import numpy as np

from tissuebench.meshes.gmshio import TaggedMesh, start_gmsh, to_dolfinx
from tissuebench.solvers.truth.axisymmetric import R_B, H


def quarter_cylinder(
    h_near: float, h_far: float, reach: float = 0.03, comm: MPI.Comm = MPI.COMM_WORLD
) -> TaggedMesh:
    """The quarter cylinder with its faces "top", "bottom", "side", "x0" (the plane x = 0)
    and "y0" (y = 0) tagged. Collective."""
    import gmsh

    if comm.rank == 0:
        start_gmsh()
        gmsh.model.add("quarter-cylinder")
        occ = gmsh.model.occ
        cylinder = occ.addCylinder(0.0, 0.0, 0.0, 0.0, 0.0, H, R_B)
        box = occ.addBox(0.0, 0.0, 0.0, R_B, R_B, H)
        volumes, _ = occ.intersect([(3, cylinder)], [(3, box)])
        occ.synchronize()
        eps = 1e-3
        centre = gmsh.model.getEntitiesInBoundingBox(-eps, -eps, H - eps, eps, eps, H + eps, 0)
        faces: dict[str, list[int]] = {n: [] for n in ("top", "bottom", "side", "x0", "y0")}
        for _, surface in gmsh.model.getEntities(2):
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(2, surface)
            if z0 > H - eps:
                faces["top"].append(surface)
            elif z1 < eps:
                faces["bottom"].append(surface)
            elif x1 < eps:
                faces["x0"].append(surface)
            elif y1 < eps:
                faces["y0"].append(surface)
            else:
                faces["side"].append(surface)
        gmsh.model.addPhysicalGroup(3, [v for _, v in volumes], 1, name="quarter")
        for tag, (name, surfaces) in enumerate(faces.items(), start=1):
            gmsh.model.addPhysicalGroup(2, surfaces, tag, name=name)
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "PointsList", [centre[0][1]])
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", h_near)
        field.setNumber(threshold, "SizeMax", h_far)
        field.setNumber(threshold, "DistMin", reach)
        field.setNumber(threshold, "DistMax", 0.4)
        field.setAsBackgroundMesh(threshold)
        for name, value in {
            "Mesh.MeshSizeFromPoints": 0,
            "Mesh.MeshSizeFromCurvature": 0,
            "Mesh.MeshSizeExtendFromBoundary": 0,
        }.items():
            gmsh.option.setNumber(name, value)
        gmsh.model.mesh.generate(3)
        gmsh.model.mesh.setOrder(2)
    return to_dolfinx(comm, gdim=3)


if __name__ == "__main__":  # the sizes of a few meshes
    import sys

    for h in map(float, sys.argv[1:]):
        tagged = quarter_cylinder(h, 0.1)
        cells = tagged.mesh.topology.index_map(3).size_global
        print(h, cells, np.round(tagged.mesh.geometry.x[:, 2].max(), 6))
