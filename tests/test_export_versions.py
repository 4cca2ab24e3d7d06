"""The exported JSON's versions (issue 44, item 3): version 2 made `probe` an object and broke a
user's solver written for version 1 without a word. A version 1 file, as version 1 wrote it,
is refused in one line that names what changed; the changes note (exported.CHANGES, the
module's docstring and meshes/BENCHMARKS.md) names fields a version 2 export really has."""

import json
from pathlib import Path

from mpi4py import MPI

import pytest

from tissuebench.metrics.series import InputError
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.posing import export
from tissuebench.workflows.io import exported
from tissuebench.workflows.io.exported import CHANGES, SCHEMA_VERSION, read_json

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.serial  # files in tmp_path, which mpiexec's ranks share
ADDED = ["description", "geometry", "constraint_semantics", "damping", "model_law", "algorithm",
         "metrics", "truth"]  # fmt: skip


@pytest.fixture(scope="module")
def rod(tmp_path_factory) -> dict:
    """A version 2 export of the rod (n = 1, 3 steps, no reference), as a dict."""
    out = tmp_path_factory.mktemp("versions") / "rod.json"
    export("rod", "json", out, mesh_size=1, options={}, material=get_material("MP3"),
           model="linear", h=1 / 30, steps=3, reference=False, comm=MPI.COMM_SELF,
           log=lambda _: None)  # fmt: skip
    return json.loads(out.read_text())


def as_version_1(doc: dict) -> dict:
    """The same benchmark as version 1 wrote it (git history: workflows/io/exported.py before
    f518f98): the probe a point, four base units, none of the fields version 2 added."""
    old = {k: v for k, v in doc.items() if k not in ADDED}
    old["version"] = 1
    old["probe"] = doc["probe"]["point"]
    old["units"] = {"length": "m", "time": "s", "mass": "kg", "stress": "Pa"}
    old["body_force"] = {"gravity": doc["body_force"]["gravity"]}
    old["constraints"] = [{k: v for k, v in c.items() if k != "region"} for c in doc["constraints"]]
    return old


def test_a_version_1_file_is_refused_naming_the_change(rod, tmp_path):
    assert rod["version"] == SCHEMA_VERSION == 2
    path = tmp_path / "old.json"
    path.write_text(json.dumps(as_version_1(rod)))
    with pytest.raises(InputError) as info:
        read_json(path)
    said = str(info.value)
    assert "\n" not in said
    assert said.startswith(f"{path}: tissuebench.benchmark version 1; this tissuebench reads ")
    assert 'probe [x, y, z] became {"point": [x, y, z]' in said and 'probe["point"]' in said
    assert said.endswith("export the benchmark again with `tissuebench export`")
    for version in (3, "2", True, None):  # not older: nothing to name, the same one line
        path.write_text(json.dumps({**rod, "version": version}))
        with pytest.raises(InputError, match="reads version 2 only: export") as info:
            read_json(path)
        assert "became" not in str(info.value)


def test_the_changes_note_names_what_version_2_has(rod):
    assert isinstance(rod["probe"], dict) and len(rod["probe"]["point"]) == 3
    assert "meaning" in rod["probe"] and "meaning" in rod["body_force"]
    assert all("region" in c for c in rod["constraints"])
    assert rod["units"]["body_force.gravity"] == "m/s^2"  # a unit per path
    for key in ADDED:
        assert key in rod, key
        assert key in CHANGES[2] or key == "description", key
    for text in (exported.__doc__ or "", (ROOT / "meshes" / "BENCHMARKS.md").read_text()):
        note = text[text.index("Changes") :]
        assert "probe" in note and 'probe["point"]' in note
        assert all(f"`{key}`" in note for key in ADDED), [k for k in ADDED if f"`{k}`" not in note]
