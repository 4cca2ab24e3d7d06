"""Kratos's nonlinear rod (workflows/simulators/kratos_nonlinear.py): TotalLagrangian elements
with KirchhoffSaintVenant3DLaw and HyperElastic3DLaw and Kratos's Newton loop, against our own
implicit+svk and implicit+neo-hookean on the same hexahedra. The rod n = 2 at load scale 1.5
(SPEC 8), 150 steps of 1/30 s (5 s: the tip sags by about 0.18 m); serial (a child process)."""

import dataclasses
from importlib import metadata

from mpi4py import MPI

import h5py
import numpy as np
import pytest

from tissuebench.workflows.simulators import kratos as kr

if kr.available() is not None:
    pytest.skip(kr.available(), allow_module_level=True)
try:
    metadata.version("KratosConstitutiveLawsApplication")  # the hyperelastic laws
except metadata.PackageNotFoundError:
    pytest.skip("KratosConstitutiveLawsApplication is not installed", allow_module_level=True)

from tissuebench.solvers.materials import get_material  # noqa: E402
from tissuebench.workflows.compare.posing import build, run_reference  # noqa: E402

pytestmark = [pytest.mark.serial, pytest.mark.outside]  # an outside simulator: make external-tests

H = 1 / 30  # s
STEPS = 150
TIP = (0.5, 0.25, 0.125)  # m, SPEC 5
# Without stiffness damping (beta = 0) Kratos's svk is the SPEC's law and its Newmark our
# trapezoidal rule: measured 5e-11 (tip, largest difference over largest displacement). The
# bound is the Newton tolerance 1e-10 per step with room for its growth over 150 steps.
SAME_LAW_TOL = 1e-8
# With the SPEC's damping Kratos's rayleigh_beta multiplies its current tangent, not K_0:
# svk departs by 0.053 for that alone. HyperElastic3DLaw is the ln J neo-Hookean, which
# differs from the SPEC's from the third order in the strain: 0.012 at beta = 0, 0.041 with
# the damping (measured). The bound leaves room for the two, and Kratos's own linear run of
# the same rod departs from our neo-hookean by 0.156 (measured): above LINEAR_DEPARTS.
NEO_HOOKEAN_TOL = 0.06
LINEAR_DEPARTS = 0.1


def setup(folder, model: str, beta: float | None = None):
    """(Exported rod n = 2 at s = 1.5, our implicit+MODEL's .xdmf)."""
    m = get_material("MP3")
    if beta is not None:
        m = dataclasses.replace(m, beta=beta)
    data, bench, _ = build(
        "rod", 2, {"load_scale": 1.5}, m, model, H, STEPS, "strain", "dynamic", MPI.COMM_WORLD
    )
    ref = folder / "reference.xdmf"
    assert run_reference(data, bench, m, ref, log=lambda *a: None)["status"] == "ok"
    return data, ref


def displacements(series) -> np.ndarray:
    with h5py.File(series.with_suffix(".h5"), "r") as h5:
        group = h5["Function/displacement"]
        return np.array([group[str(i)][()] for i in range(len(group))])


def departure(data, run, ref) -> float:
    """The tip's largest displacement difference over its largest displacement in ref."""
    assert run.status == "ok", run.reason
    tip = int(np.argmin(np.linalg.norm(data.nodes - np.array(TIP), axis=1)))
    assert np.allclose(data.nodes[tip], TIP)
    ours, theirs = displacements(ref)[:, tip], displacements(run.series)[:, tip]
    assert ours.shape == theirs.shape == (STEPS + 1, 3)
    return float(np.linalg.norm(theirs - ours, axis=1).max() / np.linalg.norm(ours, axis=1).max())


@pytest.fixture(scope="module")
def neo(tmp_path_factory):
    return setup(tmp_path_factory.mktemp("kratos-nh"), "neo-hookean")


def test_nonlinear_variants_and_refusals(neo):
    data, _ = neo
    offered = kr.variants(data)
    assert set(offered) == {"hex8-newmark", "hex8-bossak", "tet4-newmark", "tet4-bossak"}
    assert "TotalLagrangianElement3D8N" in offered["hex8-newmark"]
    assert "HyperElastic3DLaw, the ln J neo-Hookean" in offered["hex8-newmark"]
    assert (
        "NOT the SPEC's" in offered["hex8-newmark"]
        and "our implicit" not in offered["hex8-newmark"]
    )
    assert kr.skipped(data) == {
        "hex8-newmark-lumped": "lumped mass not posed with a nonlinear model here"
    }
    svk = kr.variants(dataclasses.replace(data, model="svk"))["hex8-newmark"]
    assert "KirchhoffSaintVenant3DLaw" in svk and "the SPEC's svk exactly" in svk
    for model in ("neo-hookean-barrier", "corotational"):
        other = dataclasses.replace(data, model=model)
        assert kr.variants(other) == {}
        assert kr.skipped(other) == {
            "all": f"the {model} model is not posed in Kratos here (linear, neo-hookean, svk only)"
        }
    flat = dataclasses.replace(data, cell_type="quadrilateral")
    assert kr.variants(flat) == {} and "hexahedra only" in kr.skipped(flat)["all"]


def test_svk_without_stiffness_damping_is_our_implicit(tmp_path):
    data, ref = setup(tmp_path, "svk", beta=0.0)
    (tmp_path / "run").mkdir()
    assert departure(data, kr.run(data, "hex8-newmark", tmp_path / "run"), ref) < SAME_LAW_TOL


def test_neo_hookean_near_ours_and_far_from_linear(neo, tmp_path):
    data, ref = neo
    (tmp_path / "nh").mkdir()
    nh = departure(data, kr.run(data, "hex8-newmark", tmp_path / "nh"), ref)
    (tmp_path / "linear").mkdir()
    linear = kr.run(dataclasses.replace(data, model="linear"), "hex8-newmark", tmp_path / "linear")
    assert SAME_LAW_TOL < nh < NEO_HOOKEAN_TOL < LINEAR_DEPARTS < departure(data, linear, ref)
