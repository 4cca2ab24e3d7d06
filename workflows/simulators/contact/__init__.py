"""Each outside simulator's posing of a rigid tool in contact (SPEC 12: an export with a
`contact` block), one adapter a simulator: `ADAPTERS[name]` is the module that poses such an
export for the simulator `name` (workflows/simulators/NAME.py), with the simulator's interface:
`variants(data)`, `skipped(data)` and `run(data, variant, workdir)`, its run handing the tool's
force as `ExternalRun.force`. A simulator without an adapter is never run on a contact export,
lest it pose it as if the tool were absent: its module's `CONTACT_NOTE` says why (or the
runner's "cannot pose a rigid tool in contact here").

Adding a simulator's contact: one file here and one line in ADAPTERS.
"""

from __future__ import annotations

import importlib
from types import ModuleType

# simulator name -> its adapter's module (imported on first use: a simulator may be absent)
ADAPTERS = {
    "calculix": "tissuebench.workflows.simulators.contact.calculix",
    "sfepy": "tissuebench.workflows.simulators.contact.sfepy",
    "newton": "tissuebench.workflows.simulators.contact.newton",
    "mujoco": "tissuebench.workflows.simulators.contact.mujoco",
    "drake": "tissuebench.workflows.simulators.contact.drake",
}


def adapter(simulator: str) -> ModuleType | None:
    """The module that poses a contact export for `simulator`, or None when it has none."""
    module = ADAPTERS.get(simulator)
    return None if module is None else importlib.import_module(module)
