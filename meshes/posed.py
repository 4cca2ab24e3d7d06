"""A benchmark posed on a mesh that is not ours (a candidate's own, SPEC 9 and 10's "our implicit
on M'"): its regions (meshes/regions.py) found geometrically on the mesh, through the registry.

`on_mesh` finds each region's nodes on any first-order mesh of the benchmark's body within a
tolerance (SPEC 9's τ = 1e-6 of the benchmark's extent by default) and returns the Benchmark
with those constraints, the benchmark's gravity, load scale and needle motion, so that
solvers.system.System assembles on that mesh as on ours; a benchmark with a rigid tool has the
tool's surface found there too (`tool_on_mesh`).
"""

from __future__ import annotations

from mpi4py import MPI

import dolfinx.mesh
import numpy as np

from tissuebench.meshes import BENCHMARKS
from tissuebench.meshes.benchmark import Benchmark, Constraint, Contact, Entry
from tissuebench.meshes.gmshio import MeshError, TaggedMesh
from tissuebench.meshes.regions import SAME_BODY, Posing, Touching, shortest_edge


def posing(benchmark: str, **options: object) -> tuple[Entry, Posing]:
    """A benchmark's entry and posing with its options (those its entry takes: load_scale,
    needle_width; others, such as our mesh's cell and mesh kind, are not the posing's)."""
    entry = BENCHMARKS.get(benchmark)
    if entry is None or entry.posing is None:
        posed = ", ".join(name for name, e in BENCHMARKS.items() if e.posing is not None)
        raise MeshError(f"benchmark {benchmark!r} states no regions: use one of {posed}")
    return entry, entry.posing(**{k: v for k, v in options.items() if k in entry.options})


def on_mesh(
    benchmark: str,
    mesh: dolfinx.mesh.Mesh,
    tolerance: float | None = None,
    **options: object,
) -> Benchmark:
    """The benchmark posed on `mesh` (any first-order mesh of its body, m): each region's nodes
    found geometrically within `tolerance` (m; default SPEC 9's τ = 1e-6 of the extent), with
    the benchmark's gravity, load scale, motions and defaults (material, h, T). MeshError, one
    line, for a mesh of another dimension or a region that holds no node of it. Collective."""
    entry, posed = posing(benchmark, **options)
    gdim = mesh.geometry.dim
    if gdim != entry.gdim:
        raise MeshError(f"a {gdim}D mesh cannot pose the {entry.gdim}D benchmark {benchmark}")
    tol = SAME_BODY * posed.extent if tolerance is None else tolerance
    constraints = []
    for region in posed.regions:
        vertices = dolfinx.mesh.locate_entities(
            mesh, 0, lambda x, region=region: region.mask(x[:gdim].T, tol)
        )
        owned = mesh.topology.index_map(0).size_local
        found = mesh.comm.allreduce(int(np.sum(vertices < owned)), op=MPI.SUM)
        if found == 0:
            raise MeshError(
                f"no node of the mesh lies on {benchmark}'s region {region.name} "
                f"({region.predicate}, within {tol:.3g} m)"
            )
        constraints.append(Constraint(region.name, 0, vertices, region.motion))
    contact = None if posed.tool is None else tool_on_mesh(benchmark, posed.tool, mesh, tol)
    return Benchmark(
        name=benchmark,
        tagged=TaggedMesh(mesh, {}, {}),
        constraints=constraints,
        gravity=posed.gravity,
        material=entry.material,
        dt=entry.dt,
        end_time=entry.end_time,
        extent=posed.extent,
        mesh_size=0,  # not one of our meshes
        probe=entry.probe,
        options={k: v for k, v in options.items() if k in entry.options},
        contact=contact,
    )


def tool_on_mesh(
    benchmark: str, tool: Touching, mesh: dolfinx.mesh.Mesh, tolerance: float
) -> Contact:
    """The tool's contact on `mesh`: the boundary facets whose vertices all lie on its surface
    within tolerance (m), h_e the shortest of them over every rank (m). MeshError, one line,
    when the mesh has no such facet. Collective."""
    gdim, tdim = mesh.geometry.dim, mesh.topology.dim
    facets = dolfinx.mesh.locate_entities_boundary(
        mesh, tdim - 1, lambda x: tool.mask(x[:gdim].T, tolerance)
    )
    mesh.topology.create_connectivity(tdim - 1, 0)
    owned = facets[facets < mesh.topology.index_map(tdim - 1).size_local]
    found = mesh.comm.allreduce(len(owned), op=MPI.SUM)
    if found == 0:
        raise MeshError(
            f"no boundary facet of the mesh lies on {benchmark}'s contact surface "
            f"({tool.predicate}, within {tolerance:.3g} m)"
        )
    h_e = shortest_edge(mesh, facets)
    return Contact(facets=facets, tool=tool.tool, kappa=tool.kappa, edge_size=h_e)
