"""tissuebench.meshes: gmsh scripts for the benchmarks' meshes, and the benchmarks themselves.

A benchmark is one file here with a `benchmark(mesh_size, comm=..., msh_path=..., **options)`
function and an `ENTRY` (meshes.benchmark.Entry: everything the commands know of it: its
defaults and options, regions, truth levels and names for reports), registered below; a
benchmark defined elsewhere (a test's) joins with register(name, entry).
"""

from mpi4py import MPI  # noqa: F401 (loads libmpi before PETSc and DOLFINx do)

from tissuebench.meshes import block, contact, cylinder, rod
from tissuebench.meshes.benchmark import Benchmark, Entry
from tissuebench.meshes.gmshio import MeshError

BENCHMARKS = {
    "block": block.ENTRY,
    "rod": rod.ENTRY,
    "contact": contact.ENTRY,
    "cylinder": cylinder.ENTRY,
}


def register(name: str, entry: Entry) -> None:
    """Add benchmark `name` to the registry (MeshError if the name is taken)."""
    if name in BENCHMARKS:
        raise MeshError(f"benchmark {name!r} is already registered")
    BENCHMARKS[name] = entry


def unregister(name: str) -> None:
    """Take benchmark `name`, which register added, out of the registry."""
    del BENCHMARKS[name]


def get_entry(name: str) -> Entry:
    """The registry entry of benchmark `name` (see BENCHMARKS)."""
    if name not in BENCHMARKS:
        raise MeshError(f"unknown benchmark {name!r}: use one of {', '.join(BENCHMARKS)}")
    return BENCHMARKS[name]


def in_contact(name: object) -> bool:
    """Whether `name` is a benchmark whose entry has a rigid tool in contact with the body
    (SPEC 12): the one place that says which benchmarks pose the needle as contact."""
    entry = BENCHMARKS.get(name) if isinstance(name, str) else None
    return entry is not None and entry.tool is not None


def get_benchmark(name: str, **kwargs: object) -> Benchmark:
    """Build the benchmark `name` (see BENCHMARKS) with its keyword options."""
    return get_entry(name).build(**kwargs)
