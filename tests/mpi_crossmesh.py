"""Run by tests/test_crossmesh.py: given OLD_METRICS REFERENCE CANDIDATE, grade the candidate
series against the reference series with the metrics package found in the folder
OLD_METRICS (the metrics/ folder of an older commit, imported as tissuebench.metrics in place
of the installed one) and print (rank 0) one JSON line {"curves": {metric: [values]},
"notes": [...]} with the curves that version gives (floats as repr: exact)."""

import importlib.util
import json
import sys
from pathlib import Path

from mpi4py import MPI


def load_metrics(folder: Path):
    """The package in `folder` as tissuebench.metrics (its submodules load from there too)."""
    import tissuebench.core.errors

    # that commit's metrics imported UserError from its old place, workflows/errors.py
    sys.modules.setdefault("tissuebench.workflows.errors", tissuebench.core.errors)

    spec = importlib.util.spec_from_file_location(
        "tissuebench.metrics", folder / "__init__.py", submodule_search_locations=[str(folder)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["tissuebench.metrics"] = module
    spec.loader.exec_module(module)
    return module


def main():
    folder, reference, candidate = map(Path, sys.argv[1:4])
    metrics = load_metrics(folder)
    assert Path(metrics.compare.__file__).parent == folder, metrics.compare.__file__
    g = metrics.compare.grade(reference, candidate, comm=MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        curves = {name: [repr(float(v)) for v in c] for name, c in g.curves.items()}
        print(json.dumps({"curves": curves, "notes": g.notes}))


if __name__ == "__main__":
    main()
