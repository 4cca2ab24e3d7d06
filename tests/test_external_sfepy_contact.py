"""SfePy on the contact benchmark (SPEC 12; workflows/simulators/contact/sfepy.py) against our
own implicit run on the same mesh: SfePy's dw_contact_sphere / dw_contact_plane penalty terms
with the export's k = kappa E / h_e and 3 Gauss points an edge are the same penalty law and
discretisation as ours (solvers/contact.py), stepped by the same trapezoidal rule, so the
two agree up to the one thing that differs: SfePy's terms are 3D, and the disc is its sphere
on a slab SLAB thick, whose section at a quadrature point is at most SLAB^2 / (8 R) = 1.25e-8
m smaller than R. N = 8, 60 steps (t = 2 s, the needle at its deepest); serial."""

import csv
import dataclasses
import json

from mpi4py import MPI

import numpy as np
import pytest

pytest.importorskip("sfepy")

from tissuebench.solvers.materials import get_material  # noqa: E402
from tissuebench.workflows.compare.grading import compare  # noqa: E402
from tissuebench.workflows.compare.posing import build, run_reference  # noqa: E402
from tissuebench.workflows.io.tables import read_force_csv  # noqa: E402
from tissuebench.workflows.simulators.contact import adapter  # noqa: E402
from tissuebench.workflows.simulators.contact import sfepy as sc  # noqa: E402

pytestmark = [pytest.mark.serial, pytest.mark.outside]  # an outside simulator: make external-tests

H = 1 / 30  # s
STEPS = 60  # t = 2 s: the needle stops at its deepest
# E_i max (m^2) over the 60 steps against our implicit: measured 1.1e-9 (s = 1, the disc
# alone touches) and 2.4e-9 (s = 2, the flanks touch too); with a 10 x thicker slab (1e-3 m)
# 1.1e-7 and 2.5e-7, the sphere's section. A wrong posing is far above: k / 2 2.3e-3 (s = 1);
# at s = 2 SfePy's sphere as it is (no split at x = c_x, no flanks) 6.1e-4, the half-disc
# without the flanks 1.2e-3.
E_I_TOL = 1e-7
# the needle force F_x at t = 2 s, relative to ours: measured 8e-8 (s = 1) and 9e-7 (s = 2);
# the sphere as it is -10 %, the half-disc without flanks +7 %, k / 2 -23 % (s = 1)
FORCE_TOL = 1e-5


def contact_export(folder, load_scale: float):
    """(Exported, reference .xdmf, our run's contact readings) of contact-MP1 at N = 8."""
    m = get_material("MP1")
    options = {"load_scale": load_scale}
    data, bench, _ = build(
        "contact", 8, options, m, "linear", H, STEPS, "strain", "dynamic", MPI.COMM_WORLD
    )
    ref = folder / "reference.xdmf"
    info = run_reference(data, bench, m, ref, log=lambda *a: None)
    assert info["status"] == "ok"
    return data, ref, info["contact"]


@pytest.fixture(scope="module")
def pushed(tmp_path_factory):
    return contact_export(tmp_path_factory.mktemp("sfepy-contact"), 1.0)


@pytest.fixture(scope="module")
def deep(tmp_path_factory):
    return contact_export(tmp_path_factory.mktemp("sfepy-contact-deep"), 2.0)


def graded(data, ref, ours, tmp_path) -> tuple[float, float, float, float]:
    """SfePy's run against ours: (E_i max m^2, F_x(2 s) relative to ours, SfePy's largest
    interpenetration m, ours)."""
    run = sc.run(data, "newmark", tmp_path)
    assert run.status == "ok", run.reason
    out = tmp_path / "graded"
    compare(ref, run.series, out, reference_field="displacement", candidate_field=run.field)
    summary = json.loads((out / "summary.json").read_text())
    (entry,) = summary["runs"].values()
    times, force = read_force_csv(run.force)
    assert len(times) == STEPS + 1 and times[-1] == pytest.approx(STEPS * H)
    theirs = np.asarray(ours["force"])
    assert np.all(np.abs(force[:, 1]) < 1e-6 * np.abs(theirs[:, 0]).max())  # symmetric
    with open(tmp_path / sc.DEPTH) as f:
        depth = max(float(row["interpenetration"]) for row in csv.DictReader(f))
    relative = force[-1, 0] / theirs[-1, 0] - 1
    return entry["interior_error_max"], relative, depth, max(ours["interpenetration"])


def test_contact_variants_and_refusals(pushed):
    data, _, _ = pushed
    assert adapter("sfepy") is sc
    offered = sc.variants(data)
    assert (
        list(offered) == ["newmark"]
        and "k = kappa E / h_e = 10 x 200 / 0.125" in offered["newmark"]
    )
    assert "16000 Pa/m" in offered["newmark"]
    assert {"central-difference", "velocity-verlet"} <= set(sc.skipped(data))
    for other in (
        dataclasses.replace(data, model="neo-hookean-barrier"),
        dataclasses.replace(data, procedure="static"),
    ):
        assert sc.variants(other) == {} and "all" in sc.skipped(other)
        with pytest.raises(ValueError, match="SfePy cannot pose this contact export"):
            sc.run(other, "newmark", None)
    with pytest.raises(ValueError, match="unknown SfePy contact variant"):
        sc.run(data, "bathe", None)


def test_contact_newmark_matches_our_implicit(pushed, tmp_path):
    """s = 1: the needle 0.16 m deep at t = 2 s; on this mesh the disc alone touches."""
    data, ref, ours = pushed
    e_i, relative, depth, our_depth = graded(data, ref, ours, tmp_path)
    assert e_i < E_I_TOL and abs(relative) < FORCE_TOL
    assert depth == pytest.approx(our_depth, rel=1e-3) and depth > 0.02  # k = 16000 Pa/m


def test_contact_flanks_match_our_implicit(deep, tmp_path):
    """s = 2: the needle 0.32 m deep at t = 2 s, its flanks touch the edge (without them the
    force is 7 % off): SfePy's planes, split from its sphere at x = c_x, pose them."""
    data, ref, ours = deep
    e_i, relative, depth, our_depth = graded(data, ref, ours, tmp_path)
    assert e_i < E_I_TOL and abs(relative) < FORCE_TOL
    assert depth == pytest.approx(our_depth, rel=1e-3)
