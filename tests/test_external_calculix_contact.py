"""CalculiX's own contact on the contact benchmark (SPEC 12; workflows/io/calculix_contact.py,
workflows/simulators/contact/calculix.py), each check against something independent of the
code it tests: the needle's shape from meshes/contact.py's signed distance, our own contact
(solvers/contact.py's penalty, quasi-static) on the same mesh, and static equilibrium (the
needle's force equals the fixed edges' reactions)."""

import shutil
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import needs_ccx

from tissuebench.meshes.contact import needle
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.compare.posing import build, run_reference
from tissuebench.workflows.io.calculix import read_frd
from tissuebench.workflows.io.calculix_contact import (
    BAND,
    contact_inp_text,
    needle_band,
    slave_faces,
)
from tissuebench.workflows.io.summary import read_compare_summary
from tissuebench.workflows.io.tables import read_force_csv
from tissuebench.workflows.io.xdmf import write_series
from tissuebench.workflows.simulators.contact import adapter
from tissuebench.workflows.simulators.contact import calculix as calculix_contact

CCX = shutil.which("ccx")
H = 1 / 30  # s
STOP = 60  # steps: t = 2 s, where the needle stops (0.16 m deep)


def contact(n: int, steps: int, procedure: str, model: str = "linear"):
    material = get_material("MP1")
    data, bench, _ = build(
        "contact", n, {}, material, model, H, steps, "strain", procedure, MPI.COMM_SELF
    )
    return data, bench, material


def test_band_is_the_needle_and_faces_point_out():
    """The rigid band's outer nodes lie on the half-stadium (signed distance 0 within the arc's
    chord sag), its inner ones BAND inside; every quadrilateral turns counter-clockwise, and
    its face S1 (corners 1-2) is on the boundary with its outward normal out of the needle;
    the slave faces are the N edges of the block on x = 1."""
    data, _, _ = contact(8, 3, "static")
    nodes, quads = needle_band(data)
    c0 = np.asarray(data.contact["motion"]["c0"])
    P = len(nodes) // 2
    assert np.abs(needle().signed_distance(nodes[:P], c0)).max() < 1e-12
    assert np.allclose(needle().signed_distance(nodes[P:], c0), -BAND, atol=1e-12)
    a, b, c, d = (nodes[quads[:, k]] for k in range(4))
    p, q = c - a, d - b
    area = 0.5 * (p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0])
    assert (area > 0).all()
    middle, edge = 0.5 * (a + b), b - a
    out = np.column_stack([edge[:, 1], -edge[:, 0]])  # right of 1 -> 2: out of a CCW cell
    out /= np.linalg.norm(out, axis=1)[:, None]
    assert (needle().signed_distance(middle + 1e-4 * out, c0) > 0).all()
    faces = slave_faces(data)
    assert len(faces) == 8
    corners = {1: (0, 1), 2: (1, 2), 3: (2, 3), 4: (3, 0)}
    for cell, face in faces:
        ends = data.nodes[data.cells[cell][list(corners[face])]]
        assert np.allclose(ends[:, 0], 1.0)


def graded(data, bench, material, run, folder: Path) -> tuple[float, float]:
    """(E_i max of the run against our quasi-static on the same mesh, and of the zero field
    against it), m^2."""
    folder.mkdir()
    reference = folder / "ours.xdmf"
    info = run_reference(data, bench, material, reference, comm=MPI.COMM_SELF, log=lambda s: None)
    data.reference = info
    out = {}
    zero = folder / "zero.xdmf"
    points = np.column_stack([data.nodes, np.zeros(len(data.nodes))])
    mesh = (points, np.asarray(data.cells, dtype=np.int64), data.cell_type)
    write_series(zero, (mesh, {"u": np.zeros((data.steps + 1, len(data.nodes), 3))}), data.times)
    for name, series, field in (("run", run.series, run.field), ("zero", zero, "u")):
        compare(
            reference, series, folder / name, comm=MPI.COMM_SELF, candidate_field=field,
            reference_field="displacement", label=name,
        )  # fmt: skip
        summary = read_compare_summary(folder / name)["runs"][name]
        out[name] = summary["interior_error_max"]
    return out["run"], out["zero"]


@needs_ccx
@pytest.mark.serial  # runs ccx in a folder of its own: one process
def test_static_contact_against_ours_and_in_equilibrium(tmp_path):
    """Against our quasi-static on the same mesh (contact-MP1, s = 1, to t = 2 s), two contact
    discretisations (CalculiX: node to surface, the block's nodes kept out of the needle; ours:
    the penalty along the whole edge, between the nodes too). Measured: the needle force at
    t = 2 s 23 % (N = 10), 14 % (N = 20) and 3.5 % (N = 40) below ours, E_i max 21 %, 16 % and
    4 % of the zero field's: the test asks for the brief's 15 % on the force at N = 20, for
    the gap to close from N = 10 to 20, and for E_i max at N = 20 below 20 % of the zero
    field's. At every step the needle's x force equals the fixed edges' reactions (the static
    block's equilibrium, which CalculiX's RF of the band and of the edges must meet apart)
    within 1e-4 of the largest force (the .frd prints six digits; measured 3e-6)."""
    gaps = {}
    for n in (10, 20):
        data, bench, material = contact(n, STOP, "static")
        assert adapter("calculix") is calculix_contact
        assert list(calculix_contact.variants(data)) == ["static-contact-CPE4"]
        work = tmp_path / f"n{n}"
        work.mkdir()
        run = calculix_contact.run(data, "static-contact-CPE4", work)
        assert run.status == "ok", run.reason
        times, force = read_force_csv(run.force)
        assert np.allclose(times, data.times) and force[0].tolist() == [0.0, 0.0]
        _, _, _, _, rf, _ = read_frd(work / "job.frd", ("FORC",))
        fixed = np.unique(np.concatenate(list(data.node_sets.values())))
        reaction = np.array([r[fixed, 0].sum() for r in rf])
        assert np.abs(force[1:, 0] - reaction).max() <= 1e-4 * np.abs(force[:, 0]).max()
        e_run, e_zero = graded(data, bench, material, run, tmp_path / f"g{n}")
        ours = np.asarray(data.reference["contact"]["force"])
        assert force[STOP, 0] > 0 and abs(force[STOP, 1]) < 1e-6 * force[STOP, 0]
        gaps[n] = abs(force[STOP, 0] - ours[STOP, 0]) / ours[STOP, 0]
        print(f"N = {n}: F(2 s) {force[STOP, 0]:.4g} N/m, ours {ours[STOP, 0]:.4g}; E_i max "
              f"{e_run:.3g} m^2, the zero field's {e_zero:.3g}")  # fmt: skip
    assert gaps[20] < 0.15 and gaps[20] < gaps[10]
    assert e_run < 0.2 * e_zero


@needs_ccx
@pytest.mark.serial  # runs ccx in a folder of its own: one process
def test_dynamic_contact_is_not_posed(tmp_path):
    """CalculiX 2.20 stops the dynamic deck (DYNAMIC_REFUSED): the variants offer only the
    quasi-static one (the load history by *STATIC) and skipped says why; if a later CalculiX
    runs the dynamic deck to the end, this test fails, and the dynamic variant can be offered."""
    data, _, _ = contact(8, 30, "dynamic")
    assert list(calculix_contact.variants(data)) == [calculix_contact.QUASI_STATIC]
    assert "contact-implicit-CPE4" in calculix_contact.skipped(data)
    (tmp_path / "job.inp").write_text(contact_inp_text(data))
    import subprocess

    done = subprocess.run(
        ["ccx", "-i", "job"], cwd=tmp_path, capture_output=True, text=True, timeout=600,
        env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert "solution seems to diverge" in done.stdout, calculix_contact.DYNAMIC_REFUSED
