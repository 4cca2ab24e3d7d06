"""tissuebench.meshes: gmsh scripts for the benchmarks' meshes, and the benchmarks themselves.

A benchmark is one file here with a `benchmark(mesh_size, comm=..., msh_path=..., **options)`
function, registered below.
"""

from tissuebench.meshes import block, rod
from tissuebench.meshes.gmshio import MeshError

BENCHMARKS = {
    "block": block.benchmark,
    "rod": rod.benchmark,
}


def get_benchmark(name, **kwargs):
    """Build the benchmark `name` (see BENCHMARKS) with its keyword options."""
    if name not in BENCHMARKS:
        raise MeshError(f"unknown benchmark {name!r}: use one of {', '.join(BENCHMARKS)}")
    return BENCHMARKS[name](**kwargs)
