"""Each outside simulator's posing of a rigid tool in contact (SPEC 12 and 13: an export with a
`contact` block), one adapter a simulator and tool: `ADAPTERS[name][kind]` is the module that
poses an export whose tool is of that kind (its `contact.shape.kind`: "half-stadium" for SPEC
12's needle in the plane, "capsule" for SPEC 13's in 3D) for the simulator `name`
(workflows/simulators/NAME.py), with the simulator's interface: `variants(data)`,
`skipped(data)` and `run(data, variant, workdir)`, its run handing the tool's force as
`ExternalRun.force`. A simulator without an adapter for the export's tool is never run on it,
lest it pose it as if the tool were absent: its module's `CONTACT_NOTE` says why (or the
runner's "cannot pose a rigid tool in contact here").

Adding a simulator's contact with a tool: one file here and one line in ADAPTERS.
"""

from __future__ import annotations

import importlib
from types import ModuleType

PACKAGE = "tissuebench.workflows.simulators.contact"
# simulator name -> {tool kind: its adapter's module} (imported on first use: a simulator may be
# absent)
ADAPTERS: dict[str, dict[str, str]] = {
    "calculix": {"half-stadium": f"{PACKAGE}.calculix"},
    "sfepy": {"half-stadium": f"{PACKAGE}.sfepy", "capsule": f"{PACKAGE}.sfepy_capsule"},
    "newton": {"half-stadium": f"{PACKAGE}.newton", "capsule": f"{PACKAGE}.newton_capsule"},
    "mujoco": {"half-stadium": f"{PACKAGE}.mujoco", "capsule": f"{PACKAGE}.mujoco_capsule"},
    "drake": {"half-stadium": f"{PACKAGE}.drake", "capsule": f"{PACKAGE}.drake_capsule"},
}


def adapter(simulator: str, kind: str = "half-stadium") -> ModuleType | None:
    """The module that poses a contact export with a tool of `kind` for `simulator`, or None
    when it has none."""
    module = ADAPTERS.get(simulator, {}).get(kind)
    return None if module is None else importlib.import_module(module)
