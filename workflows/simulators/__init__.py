"""Outside simulators that tissuebench drives end to end (`tissuebench external`,
`tissuebench leaderboard`): each poses an exported benchmark (workflows/io/exported.py,
`Exported`) in its own terms, runs it, and leaves a displacement series that
`tissuebench compare` grades against our reference.

One module per simulator, with a small fixed interface (as benchopt's solvers):

- `NAME`: its name on the command line; `TITLE`: how tables name it ("CalculiX 2.20").
- `available() -> str | None`: None when it can run here, else one line saying what is
  missing and how to install it.
- `variants(data: Exported) -> dict[str, str]`: the variants that pose this export
  faithfully, name -> one line of what the variant is (scheme, element, parameters), ending
  with how the export's E and nu become the simulator's own parameters, with their values
  (`given`).
- `skipped(data: Exported) -> dict[str, str]`: what it cannot pose of this export and why
  (name -> one line; {} when nothing is left out).
- `run(data: Exported, variant: str, workdir: Path) -> ExternalRun`: run one variant in
  workdir (an empty folder of its own), serially, and return what it produced. A run that
  fails or blows up is not an exception: it comes back with status "failed" and the reason,
  and the leaderboard records it as a divergence.

- A rigid tool in contact (SPEC 12: an export with a `contact` block) is posed by the
  simulator's contact adapter, one file in contact/ and one line in its ADAPTERS, with the same
  three functions: its `skipped()` says which variants cannot pose the contact and why, and its
  runs hand the tool's force as `ExternalRun.force` (io/tables.py write_force_csv), which
  compare grades as the force error; the interpenetration is graded from the series. A
  simulator without an adapter is never run on such an export (runner.py: SimulatorError with
  its module's `CONTACT_NOTE`, a line on why not, or "cannot pose a rigid tool in contact
  here", which the leaderboard shows as the simulator skipped), lest it pose the export as if
  the tool were absent.

Adding a simulator: one file here and one line in SIMULATORS (and its contact: one file in
contact/ and one line in ADAPTERS).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from types import ModuleType

# name -> module (imported on first use: a simulator's package may be absent)
SIMULATORS = {
    "calculix": "tissuebench.workflows.simulators.calculix",
    "sfepy": "tissuebench.workflows.simulators.sfepy",
    "newton": "tissuebench.workflows.simulators.newton",
    "mujoco": "tissuebench.workflows.simulators.mujoco",
    "kratos": "tissuebench.workflows.simulators.kratos",
    "drake": "tissuebench.workflows.simulators.drake",
}


@dataclass
class ExternalRun:
    """What one variant of an outside simulator produced.

    `series`: the displacement series file (.xdmf, .pvd, .frd or .dat: what compare reads),
    or None when the run failed before writing one; `field`: its point field (None: compare
    tries its default names); `wall_time_s`: s, the simulator's solve measured around it,
    from the posed problem to the last step (assembly and factorisations included,
    interpreter start and file conversion not), as `timing` says; `dofs`: displacement
    unknowns of its mesh (nodes x dimension); `mesh`: "reference" when it runs on the
    exported nodes and cells, else a few words on its own mesh ("tetrahedra, 6 per hex");
    `status`: "ok" or "failed"; `reason`: why it failed, one line; `version`: the
    simulator's version; `force`: on a contact benchmark (SPEC 12), the needle force the
    simulator reports, as io/tables.py's write_force_csv writes it (None: it reports none)."""

    series: Path | None
    wall_time_s: float | None
    dofs: int
    field: str | None = None
    mesh: str = "reference"
    status: str = "ok"
    reason: str | None = None
    timing: str = ""
    version: str = ""
    force: Path | None = None


def get_simulator(name: str) -> ModuleType:
    """The simulator module registered under name (ValueError for an unknown name)."""
    if name not in SIMULATORS:
        raise ValueError(f"unknown simulator {name!r}: use one of {', '.join(SIMULATORS)}")
    return importlib.import_module(SIMULATORS[name])


def integrated(
    series: Path,
    wall_time_s: float,
    dofs: int,
    field: str,
    mesh: str,
    diverged: int | None,
    reason: str | None,
    h: float,
    timing: str,
    version: str,
) -> ExternalRun:
    """What a run that stepped to the end, or diverged at step `diverged` (None: it did not)
    for `reason`, produced: status "failed" and "diverged at step i (t = i h s): reason" when it
    diverged (h in s)."""
    failed = diverged is not None
    said = (
        f"diverged at step {diverged} (t = {diverged * h:.6g} s): {reason}"
        if diverged is not None
        else None
    )
    return ExternalRun(
        series=series,
        wall_time_s=wall_time_s,
        dofs=dofs,
        field=field,
        mesh=mesh,
        status="failed" if failed else "ok",
        reason=said,
        timing=timing,
        version=version,
    )


def given(material) -> str:
    """The export's elastic constants in words, as a row states what it was given: "E = 60000
    Pa, nu = 0.495 (mu = 20067 Pa, lambda = 1.9866e+06 Pa)"."""
    return (
        f"E = {material.E:g} Pa, nu = {material.nu:g} (mu = {material.mu:.5g} Pa, "
        f"lambda = {material.lmbda:.5g} Pa)"
    )


def installed_version(*distributions: str) -> str:
    """The version of the first of these installed distributions, without importing it ("" when
    none is installed)."""
    for name in distributions:
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return ""
