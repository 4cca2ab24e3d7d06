"""CalculiX (`ccx`, Debian package calculix-ccx) on the exported deck (workflows/io/exported.py).

Variants (dynamic procedure, on the export's own nodes and cells):
- `implicit-ELEMENT`: *DYNAMIC, DIRECT, ALPHA=0: the trapezoidal rule, our `implicit`;
- `hht-ELEMENT`: ALPHA=-0.05, CalculiX's default HHT-alpha, which damps high frequencies;
with ELEMENT C3D8 (full integration), C3D8I (incompatible modes), C3D8R (reduced
integration, hourglass control) and C3D20R (20-node hexahedra, reduced integration: the
export's hexahedra with a node added at the middle of every edge, io/calculix_deck.py's
quadratic_hexahedra; graded at the corners, which are the export's nodes) in 3D; CPE4 and
CPE4R in plane strain (CPS4, CPS4R in plane stress). The models `linear`, `svk` and
`neo-hookean` (NLGEOM); the static procedure has one `static-ELEMENT` per element.

A contact export (SPEC 12: its `contact` block) is posed by its adapter, contact/calculix.py,
with CalculiX's own contact against a rigid needle.

Not posed (`skipped`): CalculiX's explicit dynamics. CalculiX 2.20 refuses stiffness
proportional damping there ("the coefficient beta of the stiffness proportional term must be
zero"), and every SPEC material has beta = 0.1 s; with beta = 0 it chooses its own stable
increment (0.072 s on the rod MP3 at n = 3, above h = 1/30 s) and writes its output at those
increments, not at the t_i, so its series cannot be graded step by step.

The wall time is the `ccx` process's, one thread (OMP_NUM_THREADS=1), as measured around
it: reading the deck, assembling, factorising at every increment (CalculiX treats every
dynamic step as a nonlinear one) and writing the .frd and .dat.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np

from tissuebench.core import interrupt
from tissuebench.workflows.io.calculix_deck import ELEMENTS, SECOND_ORDER, quadratic_hexahedra
from tissuebench.workflows.simulators import ExternalRun, given

NAME = "calculix"
TITLE = "CalculiX"
JOB = "job"
SCHEMES = {"implicit": 0.0, "hht": -0.05}  # variant prefix -> HHT alpha
MODELS = ("linear", "svk", "neo-hookean")
TIMEOUT = 3600.0  # s: a ccx run beyond this is stopped and recorded as failed


def available() -> str | None:
    if shutil.which("ccx") is None:
        return (
            "ccx (CalculiX) is not on PATH: `make external-tools` installs the Debian package "
            "calculix-ccx where it can"
        )
    return None


def version() -> str:
    """CalculiX's version as `ccx -v` prints it ("2.20"), or "" if it does not say."""
    try:
        text = subprocess.run(["ccx", "-v"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError):
        return ""
    found = re.search(r"[Vv]ersion\s+([0-9][0-9.]*)", text)
    return found.group(1).rstrip(".") if found else ""


def elements(data) -> tuple[str, ...]:
    """The deck's elements that pose this export (io/calculix_deck.py's ELEMENTS)."""
    plane = None if data.dim == 3 else (data.plane or "strain")
    return tuple(e for e, (dim, p) in ELEMENTS.items() if dim == data.dim and p == plane)


# what a second-order element changes, said in its variants' descriptions
SECOND_ORDER_NOTE = {
    "C3D20R": "20-node hexahedra (the export's, with midside nodes: {nodes} nodes), 2 x 2 x 2 "
    "Gauss points for stiffness, consistent mass and gravity (27 for the initial acceleration), "
    "graded at the corner nodes (trilinear between them)"
}


def element_words(data, element: str) -> str:
    """The element as a variant's description names it (with what a 20-node one adds)."""
    if element not in SECOND_ORDER:
        return element
    nodes = len(quadratic_hexahedra(data).nodes)
    return f"{element} ({SECOND_ORDER_NOTE[element].format(nodes=nodes)})"


def variants(data) -> dict[str, str]:
    """The variants that pose this export: scheme x element (see the module docstring); a
    contact export's are its adapter's (contact/calculix.py)."""
    if data.model not in MODELS:
        return {}
    flags = ", NLGEOM" if data.model != "linear" else ""
    if data.procedure == "static":
        return {
            f"static-{e}": f"*STATIC{flags}, one step per t_i, {element_words(data, e)}; "
            + elastic(data)
            for e in elements(data)
        }
    known = ""  # departures measured in tests/test_export.py, said where they apply
    if data.model != "linear" and data.material.beta > 0:
        known += "; NLGEOM damps with beta K(u), the SPEC with beta K_0"
    if any(np.abs(m[0]).max() > 0 for m in data.motions.values()):
        known += "; CalculiX's prescribed motion in *DYNAMIC departs from the SPEC's"
    return {
        f"{scheme}-{e}": f"*DYNAMIC, DIRECT, ALPHA={alpha:g}{flags}, {element_words(data, e)}, "
        f"fixed h{known}; " + elastic(data)
        for scheme, alpha in SCHEMES.items()
        for e in elements(data)
    }


def elastic(data) -> str:
    """How the deck takes the export's E and nu (io/calculix_deck.py's *MATERIAL), with values."""
    m = data.material
    if data.model == "neo-hookean":
        kappa = m.lmbda + 2 * m.mu / 3
        return (
            f"*HYPERELASTIC, NEO HOOKE with C10 = mu/2 = {m.mu / 2:.5g} Pa, D1 = 2/kappa = "
            f"{2 / kappa:.5g} 1/Pa of {given(m)}"
        )
    return f"*ELASTIC with the export's {given(m)}"


def skipped(data) -> dict[str, str]:
    """Variants that cannot pose this export, with why."""
    if data.model not in MODELS:
        return {"all": f"the {data.model} model has no CalculiX material"}
    if data.procedure != "dynamic":
        return {}
    why = (
        f"CalculiX refuses stiffness damping in explicit dynamics (beta = {data.material.beta:g} s)"
        if data.material.beta > 0
        else "CalculiX chooses its own explicit increment and writes no output at the t_i"
    )
    return {"explicit": why}


def run(data, variant: str, workdir: Path) -> ExternalRun:
    """Write the deck of this variant to workdir/job.inp, run ccx on it, and return its
    .frd (DISP) as the series."""
    from tissuebench.workflows.io.calculix_deck import write_inp

    scheme, element = variant.split("-", 1)
    workdir = Path(workdir)
    write_inp(data, workdir / f"{JOB}.inp", element, SCHEMES.get(scheme, 0.0))
    env = {**os.environ, "OMP_NUM_THREADS": "1", "CCX_NPROC_EQUATION_SOLVER": "1"}
    # the unknowns ccx solves for: a 20-node element's midside nodes included
    dofs = (quadratic_hexahedra(data) if element in SECOND_ORDER else data).nodes.size
    start = time.perf_counter()
    # stopped at once by a signal, which then ends the job (core/interrupt.py)
    done = interrupt.run_child(["ccx", "-i", JOB], TIMEOUT, cwd=workdir, env=env)
    if done is None:
        return ExternalRun(None, None, dofs, status="failed", reason=f"ccx ran over {TIMEOUT:g} s")
    wall = time.perf_counter() - start
    (workdir / "ccx.log").write_text(done.stdout + done.stderr)
    errors = [line.strip() for line in done.stdout.splitlines() if "*ERROR" in line]
    frd = workdir / f"{JOB}.frd"
    timing = "the ccx process, 1 thread (deck, assembly, factorisations, .frd and .dat output)"
    if done.returncode != 0 or errors or not frd.is_file():
        reason = errors[0] if errors else f"ccx exited with status {done.returncode}"
        return ExternalRun(
            frd if frd.is_file() else None,
            wall,
            dofs,
            field="DISP",
            status="failed",
            reason=reason,
            timing=timing,
            version=version(),
        )
    return ExternalRun(frd, wall, dofs, field="DISP", timing=timing, version=version())
