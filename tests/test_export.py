"""`tissuebench export`, and grading CalculiX's output as it comes: each check against something
independent of the code it tests (the mesh's geometry, the SPEC's closed forms, CalculiX 2.20
itself, hand-written .frd records)."""

import json
import shutil
import subprocess
from pathlib import Path

from mpi4py import MPI

import numpy as np
import pytest
from helpers import needs_ccx, tissuebench
from recipe_solver import region_mask as predicate

from tissuebench.core.errors import UserError
from tissuebench.meshes.block import needle_motion
from tissuebench.metrics.compare import COLUMNS
from tissuebench.metrics.series import InputError
from tissuebench.solvers.materials import get_material
from tissuebench.workflows.compare.grading import compare
from tissuebench.workflows.compare.posing import build, export, truth_case
from tissuebench.workflows.io.calculix import inp_text, kinks, read_frd, to_float
from tissuebench.workflows.io.exported import read_json
from tissuebench.workflows.io.series import read_series

CCX = shutil.which("ccx")
H = 1 / 30  # the paper's h, s


def options(**extra):
    base = dict(options={}, material=get_material("MP3"), model="linear", h=H)
    return {**base, **extra}


def ccx(job: Path) -> None:
    """Run CalculiX on job.inp in its folder."""
    r = subprocess.run(
        [CCX, "-i", job.stem], cwd=job.parent, capture_output=True, text=True, timeout=120
    )
    assert r.returncode == 0 and (job.with_suffix(".frd")).is_file(), r.stdout[-2000:]


def table(path):
    """metrics.csv as (rows of step, time and the metrics; statuses)."""
    rows = path.read_text().strip().splitlines()
    assert tuple(rows[0].split(",")) == COLUMNS
    values = np.array([r.split(",")[1:-1] for r in rows[1:]], dtype=float)
    return values, [r.split(",")[-1] for r in rows[1:]]


# --- JSON -------------------------------------------------------------------------------------


@pytest.mark.parallel
def test_json_round_trips_and_holds_the_benchmark(tmp_path):
    """The block with a needle width: read_json gives back what was exported, nodes are the
    reference XDMF's, the sets are where the SPEC puts them (by coordinates), and the needle's
    samples are SPEC section 4's closed form at t_i = i h. Collective (serial and 2 ranks)."""
    comm = MPI.COMM_WORLD
    out = tmp_path / "block.json"
    steps, width = 75, 0.25  # the needle stops at t = 2 s = step 60
    export(
        "block",
        "json",
        out,
        mesh_size=8,
        steps=steps,
        log=lambda _: None,
        **options(options={"needle_width": width, "load_scale": 1.5}, material=get_material("MP1")),
    )
    built, _, _ = build(
        "block", 8, {"needle_width": width, "load_scale": 1.5}, get_material("MP1"), "linear",
        H, steps, "strain", "dynamic", comm,
    )  # fmt: skip
    problems = []
    if comm.rank == 0:
        got = read_json(out)

        def check(ok, what):
            if not ok:
                problems.append(what)

        for name in ("benchmark", "mesh_size", "options", "plane", "material", "model", "h"):
            check(getattr(got, name) == getattr(built, name), name)
        check(got.steps == steps and np.array_equal(got.times, np.arange(steps + 1) * H), "t")
        check(np.array_equal(got.nodes, built.nodes), "nodes")
        check(np.array_equal(got.cells, built.cells) and got.cell_type == "quadrilateral", "cells")
        check(list(got.node_sets) == ["needle", "left", "bottom", "top"], "set names")
        for name in got.node_sets:
            check(np.array_equal(got.node_sets[name], built.node_sets[name]), f"set {name}")
            for a, b in zip(got.motions[name], built.motions[name], strict=True):
                check(np.array_equal(a, b), f"motion {name}")
        check(np.array_equal(got.gravity, [0.0, 0.0]), "gravity")

        # independent: geometry and the SPEC's closed form
        x = got.nodes
        ref = read_series(tmp_path / "block.reference.xdmf")
        check(np.array_equal(ref.points, x) and len(ref.times) == steps + 1, "reference mesh")
        right = np.isclose(x[:, 0], 1.0) & (np.abs(x[:, 1] - 0.5) <= width / 2 + 1e-9)
        check(np.array_equal(got.node_sets["needle"], np.flatnonzero(right)), "needle nodes")
        for name, axis, at in (("left", 0, 0.0), ("bottom", 1, 0.0), ("top", 1, 1.0)):
            on = np.flatnonzero(np.isclose(x[:, axis], at))
            check(np.array_equal(got.node_sets[name], on), f"{name} nodes")
        closed = np.array([needle_motion(i * H, 1.5) for i in range(steps + 1)])  # (t, 3, 2)
        for k in range(3):
            check(np.allclose(got.motions["needle"][k], closed[:, k], rtol=0, atol=1e-15), "g(t)")
        check(got.motions["needle"][0][60, 0] == pytest.approx(-0.08 * 1.5 * 2), "g(2)")
        check(all(not np.any(m) for name in ("left", "top") for m in got.motions[name]), "fixed")
        doc = json.loads(out.read_text())
        check(doc["schema"] == "tissuebench.benchmark" and doc["version"] == 2, "schema")
        check(doc["reference"]["file"] == "block.reference.xdmf", "reference file")

        # self-describing (version 2): each region's predicate, read by a parser of our own,
        # picks exactly the set's nodes; units and the reference's Newmark parameters
        geometry = doc["geometry"]
        check(geometry["extents"] == [[0.0, 1.0], [0.0, 1.0]], "extents")
        for c in doc["constraints"]:
            on = np.flatnonzero(predicate(c["region"], x, geometry["tolerance"]))
            check(np.array_equal(on, got.node_sets[c["set"]]), f"region of {c['set']}")
            check(c["fixed"] == (c["set"] != "needle"), f"fixed {c['set']}")
        check(doc["constraints"][0]["region"] == "x = 1 and |y - 0.5| <= 0.125", "needle text")
        units = doc["units"]
        check(units["body_force.gravity"] == "m/s^2" and units["constraints.a"] == "m/s^2", "acc")
        check(units["metrics.E_i"] == "m^2" and units["material.beta"] == "s", "units")
        numbers = {k for k in units if "." in k and not k.startswith(("metrics.", "probe."))}
        for key in numbers - {"body_force.density", "reference.wall_time_s"}:
            head, _, tail = key.partition(".")
            check(tail in doc[head] or any(tail in c for c in doc[head]), f"unit of {key}")
        algorithm = doc["algorithm"]
        check((algorithm["newmark_beta"], algorithm["newmark_gamma"]) == (0.25, 0.5), "Newmark")
        check(
            algorithm["mass"] == "consistent" and doc["damping"]["C"] == "alpha M + beta K_0", "C"
        )
        check(doc["probe"] is None and got.probe is None, "probe")
        # s = 1.5, w = 0.25 m is no truth case; the same block at s = 1, w = 0.2 m is one
        check(doc["truth"]["case"] is None and "truth cases" in doc["truth"]["why"], "no truth")
        check(got.truth == doc["truth"] and got.geometry == geometry, "round trip")
        check(
            truth_case("block", {"needle_width": 0.2}, get_material("MP1"), "linear", H, 300,
                       "strain", "dynamic")["case"] == "block-MP1-w0.2", "truth case")  # fmt: skip
        check(
            "point" in truth_case("block", {"needle_width": 0.0}, get_material("MP1"), "linear",
                                  H, 300, "strain", "dynamic")["why"], "point needle")  # fmt: skip
    problems = comm.bcast(problems, root=0)
    assert problems == []


@pytest.mark.serial
def test_json_reader_refuses_other_files(tmp_path):
    for text, message in [
        ("{", "not a readable JSON"),
        ('{"schema": "x"}', "not a tissuebench.benchmark JSON"),
        ('{"schema": "tissuebench.benchmark", "version": 1}', "version 1.*export .* again"),
        ('{"schema": "tissuebench.benchmark", "version": 2}', "KeyError"),
    ]:
        (tmp_path / "bad.json").write_text(text)
        with pytest.raises(InputError, match=message) as info:
            read_json(tmp_path / "bad.json")
        assert "\n" not in str(info.value)


# --- the CalculiX deck, without CalculiX --------------------------------------------------------


def test_amplitude_keeps_only_the_kinks():
    t = np.arange(301) * H
    u = -0.08 * np.minimum(t, 2.0)
    keep = kinks(t, u)
    assert list(keep) == [0, 60, 300]
    assert np.allclose(np.interp(t, t[keep], u[keep]), u, rtol=0, atol=1e-15)
    t = np.arange(35) * 0.3  # the kink at t = 2 falls between samples: both neighbours kept
    u = -0.08 * np.minimum(t, 2.0)
    keep = kinks(t, u)
    assert list(keep) == [0, 6, 7, 34]
    assert np.allclose(np.interp(t, t[keep], u[keep]), u, rtol=0, atol=1e-15)


@pytest.mark.serial
def test_deck_cards(tmp_path):
    """The block's deck: CPE4 cells counter-clockwise (positive area), the needle by an
    amplitude through (0, 0), (2, -1), (T, -1) times 0.16 m, Rayleigh damping, plane strain
    thickness; the neo-Hookean rod: C10 = mu/2, D1 = 2/kappa and NLGEOM."""
    data, _, _ = build("block", 4, {}, get_material("MP1"), "linear", H, 90, "strain", "dynamic")
    deck = inp_text(data)
    lines = deck.splitlines()
    assert "*ELEMENT, TYPE=CPE4, ELSET=Eall" in lines and "*DAMPING, ALPHA=1.0, BETA=0.1" in lines
    k = lines.index("*AMPLITUDE, NAME=A_needle_1, TIME=TOTAL TIME")
    assert [float(x) for x in lines[k + 1].split(",")] == pytest.approx([0, 0, 2, -1, 3, -1])
    assert "needle, 1, 1, 0.16" in lines and "needle, 2, 2" in lines and "left, 1, 2" in lines
    assert lines[lines.index("*DYNAMIC, DIRECT, ALPHA=0.0") + 1] == "0.03333333333333333, 3.0"
    start = lines.index("*ELEMENT, TYPE=CPE4, ELSET=Eall") + 1
    cells = np.array([[int(v) for v in line.split(",")[1:]] for line in lines[start : start + 16]])
    x = data.nodes[cells - 1]
    area = 0.5 * np.sum(
        x[..., 0] * np.roll(x[..., 1], -1, 1) - np.roll(x[..., 0], -1, 1) * x[..., 1], 1
    )
    assert np.allclose(area, 1 / 16)

    rod, _, _ = build("rod", 2, {}, get_material("MP3"), "neo-hookean", H, 3, "strain", "dynamic")
    lines = inp_text(rod).splitlines()
    m = get_material("MP3")
    c10, d1 = (float(v) for v in lines[lines.index("*HYPERELASTIC, NEO HOOKE") + 1].split(","))
    assert c10 == pytest.approx(m.E / (4 * (1 + m.nu)), rel=1e-13)
    assert d1 == pytest.approx(2 / (m.E / (3 * (1 - 2 * m.nu))), rel=1e-12)  # kappa = E/3(1-2nu)
    assert "*STEP, NLGEOM, INC=13" in lines and "*ELASTIC" not in lines
    assert "Eall, GRAV, 0.05, 0.0, -1.0, 0.0" in lines and "clamped, 1, 3" in lines


@pytest.mark.serial
def test_export_refusals(tmp_path):
    """In the library, before any mesh is built; one line each."""
    run = dict(mesh_size=2, steps=2, **options())
    for kwargs, fmt, message in [
        (dict(element="CPE4"), "inp", "element CPE4 is 2D and the benchmark is 3D"),
        (dict(element="C3D20"), "inp", "unknown element 'C3D20'"),
        (dict(model="corotational"), "inp", "corotational model has no CalculiX material"),
        (dict(model="neo-hookean-barrier"), "inp", "barrier has no CalculiX material: .*NEO HOOKE"),
        (dict(element="C3D8"), "json", "--element applies to --format inp only"),
    ]:
        with pytest.raises(UserError, match=message) as info:
            export("rod", fmt, tmp_path / f"rod.{fmt}", **{**run, **kwargs})
        assert "\n" not in str(info.value)
    with pytest.raises(UserError, match="plane strain and the export is plane stress"):
        export("block", "inp", tmp_path / "b.inp", element="CPE4", plane="stress", **run)
    with pytest.raises(UserError, match="must end in .inp"):
        export("rod", "inp", tmp_path / "rod.json", **run)
    (tmp_path / "rod.vtu").write_text("")
    for force in (False, True):  # a user's file: never replaced
        with pytest.raises(UserError, match="exists and was not written by tissuebench"):
            export("rod", "vtu", tmp_path / "rod.vtu", force=force, **run)
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())
    export("rod", "vtu", tmp_path / "ours.vtu", **run)
    with pytest.raises(UserError, match="exists: --force replaces it"):
        export("rod", "vtu", tmp_path / "ours.vtu", **run)
    export("rod", "vtu", tmp_path / "ours.vtu", force=True, **run)


@pytest.mark.serial
def test_mesh_files_open_in_gmsh_and_meshio(tmp_path):
    import gmsh
    import meshio

    for fmt in ("vtu", "msh"):
        export("rod", fmt, tmp_path / f"rod.{fmt}", mesh_size=2, steps=1, **options())
    assert not (tmp_path / "rod.reference.xdmf").exists()  # the mesh alone
    mesh = meshio.read(tmp_path / "rod.vtu")
    assert mesh.cells[0].type == "hexahedron" and mesh.cells[0].data.shape == (16, 8)
    assert mesh.point_data["clamped"].sum() == 9  # the 3 x 3 nodes of the face x = 0
    assert np.allclose(mesh.points[mesh.point_data["clamped"] == 1, 0], 0)
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(tmp_path / "rod.msh"))
        types, elements, _ = gmsh.model.mesh.getElements(3)
        assert list(types) == [5] and len(elements[0]) == 16  # 5: 8-node hexahedron
        assert len(gmsh.model.mesh.getNodes()[0]) == 45
    finally:
        gmsh.finalize()


# --- the .frd reader on hand-written records ------------------------------------------------------

FRD = """\
    1C
    1UUSER
    2C                             4                                     1
 -1         1-1.00000E+00-2.50000E-01 0.00000E+00
 -1         2 1.00000E+00-2.50000E-01 0.00000E+00
 -1         3 1.00000E+00 7.50000E-01 0.00000E+00
 -1         4-1.00000E+00 7.50000E-01 0.00000E+00
 -3
    3C                             1                                     1
 -1         1    9    0    1
 -2         1         2         3         4
 -3
    1PSTEP                         1           1           1
  100CL  101 3.33333E-02           4                     1    1           1
 -4  DISP        4    1
 -5  D1          1    2    1    0
 -5  D2          1    2    2    0
 -5  D3          1    2    3    0
 -5  ALL         1    2    0    0    1ALL
 -1         1-1.23456E-01-2.34567E-02 0.00000E+00
 -1         2 1.23456E-01-9.87654-101 0.00000E+00
 -1         3-1.00000E-05 2.00000E+00 0.00000E+00
 -1         4 0.00000E+00-0.00000E+00 0.00000E+00
 -3
  100CL  102 6.66667E-02           4                     1    2           1
 -4  DISP        4    1
 -5  D1          1    2    1    0
 -5  D2          1    2    2    0
 -5  D3          1    2    3    0
 -5  ALL         1    2    0    0    1ALL
 -1         1-1.00000E+00-1.00000E+00 0.00000E+00
 -1         2-2.00000E+00-2.00000E+00 0.00000E+00
 -1         3-3.00000E+00-3.00000E+00 0.00000E+00
 -1         4-4.00000E+00-4.00000E+00 0.00000E+00
 -3
 9999
"""


@pytest.mark.serial  # a file reader: nothing parallel, and tmp_path is shared by the ranks
def test_frd_reader_cuts_fields_by_column(tmp_path):
    """Negative numbers that run together, a three-digit exponent printed without its E, and
    the six-digit times."""
    (tmp_path / "a.frd").write_text(FRD)
    points, cells, cell_type, times, values, field = read_frd(tmp_path / "a.frd", ("U",))
    assert field == "DISP" and cell_type == "quadrilateral" and cells.tolist() == [[0, 1, 2, 3]]
    assert points[:, :2].tolist() == [[-1, -0.25], [1, -0.25], [1, 0.75], [-1, 0.75]]
    assert times == [0.0333333, 0.0666667]
    assert values[0][:, :2].tolist() == [
        [-0.123456, -0.0234567],
        [0.123456, -9.87654e-101],
        [-1e-05, 2.0],
        [0.0, -0.0],
    ]
    assert values[1][:, 0].tolist() == [-1, -2, -3, -4]
    assert to_float("-1.23456-100") == -1.23456e-100 and np.isnan(to_float("         NaN"))
    series = read_series(tmp_path / "a.frd")  # 2D: the zero third components are dropped
    assert series.dim == 2 and series.field == "DISP"


@pytest.mark.serial  # a file reader: nothing parallel, and tmp_path is shared by the ranks
@pytest.mark.parametrize(
    "cut, message",
    [
        (lambda t: t[: t.index(" -1         3-3.0") + 20], "truncated"),
        (lambda t: t[: t.index(" -1         3-3.0")], "truncated: the file ends inside DISP"),
        (lambda t: t[: t.index(" 9999")], "truncated: no closing 9999"),
        (
            lambda t: t.replace(" -2         1         2         3         4\n", ""),
            "expected its nodes",
        ),
        (lambda t: t.replace("    9    0    1", "    3    0    1"), "element 1 is a te4"),
        (
            lambda t: t.replace("2.00000E+00", "2.0000xE+00"),
            r"'2.0000xE\+00' \(columns 26-37\) is not a number",
        ),
    ],
)
def test_frd_reader_refuses_in_one_line(tmp_path, cut, message):
    (tmp_path / "a.frd").write_text(cut(FRD))
    with pytest.raises(InputError, match=message) as info:
        read_series(tmp_path / "a.frd")
    assert "\n" not in str(info.value) and str(info.value).startswith(str(tmp_path / "a.frd"))


# --- against CalculiX 2.20 -------------------------------------------------------------------


@pytest.fixture(scope="module")
def rod_dynamic(tmp_path_factory):
    """The rod, n = 2, the paper's h, T = 2 s, exported and run by CalculiX (C3D8)."""
    folder = tmp_path_factory.mktemp("ccx-dynamic")
    job = folder / "rod.inp"
    export("rod", "inp", job, mesh_size=2, steps=60, comm=MPI.COMM_SELF, log=lambda _: None,
           **options())  # fmt: skip
    ccx(job)
    return folder


# CalculiX starts from (M + (h/10)^2 K / 4) a_0 = f instead of M a_0 = f (SPEC section 3), so
# its first steps differ by up to ~6e-5 in E_n; the difference is damped out within a few steps.
FIRST_STEPS = 5


@needs_ccx
@pytest.mark.serial
def test_calculix_implicit_rod_reproduces_our_implicit(rod_dynamic):
    """E_n of CalculiX's *DYNAMIC, ALPHA=0 (the trapezoidal rule) against our implicit: at most
    1e-5 after the first steps, from the .frd (six digits) and the .dat (seven), whose curves
    are the same to the digits printed."""
    d = rod_dynamic
    lines = compare(d / "rod.reference.xdmf", d / "rod.frd", d / "frd", label="ccx C3D8")
    compare(d / "rod.reference.xdmf", d / "rod.dat", d / "dat", wall_time=0.6)
    assert lines["note 1"].startswith("candidate rod.frd starts at t = 0.0333333 s = h: taken")
    frd, frd_status = table(d / "frd" / "metrics.csv")
    dat, dat_status = table(d / "dat" / "metrics.csv")
    assert frd_status == dat_status == ["ok"] * 61
    assert np.allclose(frd[:, 1], np.arange(61) * H, rtol=1e-15)  # the reference's own times
    e_frd, e_dat = frd[:, 2], dat[:, 2]
    assert np.isnan(e_frd[0]) and np.isnan(e_dat[0])  # the zero initial state
    assert np.all(e_frd[1 : FIRST_STEPS + 1] < 6e-5) and np.all(e_dat[1 : FIRST_STEPS + 1] < 6e-5)
    assert np.all(e_frd[FIRST_STEPS + 1 :] <= 1e-5) and np.all(e_dat[FIRST_STEPS + 1 :] <= 1e-5)
    assert e_dat[20:].max() <= 1e-6  # seven digits: the agreement is the printing's
    # the same curves: the .frd and the .dat differ by their printed digits only
    assert np.allclose(e_frd[1:], e_dat[1:], rtol=0, atol=5e-6)
    assert np.allclose(frd[:, 3:], dat[:, 3:], rtol=0, atol=1e-6)  # E_s, E_i (both tiny)
    summary = json.loads((d / "frd" / "summary.json").read_text())
    run = summary["runs"]["ccx C3D8"]
    assert summary["candidate"]["field"] == "DISP" and run["status"] == "ok"
    assert run["relative_error_max"] == pytest.approx(np.nanmax(e_frd), rel=1e-12)
    assert run["wall_time_s"] is None and run["steps"] == 60
    dat_summary = json.loads((d / "dat" / "summary.json").read_text())
    assert dat_summary["runs"]["rod"]["wall_time_s"] == 0.6
    assert dat_summary["candidate"]["field"] == "U"


@needs_ccx
@pytest.mark.serial
def test_calculix_static_rod_reproduces_our_quasi_static(tmp_path):
    """A *STATIC step per t_i against quasi-static: within 1e-6 relative (the .dat's seven
    digits; the .frd's six give 5e-6)."""
    job = tmp_path / "rod.inp"
    export("rod", "inp", job, mesh_size=2, steps=2, procedure="static", comm=MPI.COMM_SELF,
           log=lambda _: None, **options())  # fmt: skip
    assert "*STATIC, DIRECT" in job.read_text()
    ccx(job)
    ref = read_series(tmp_path / "rod.reference.xdmf")
    for name, bound in (("rod.dat", 1e-6), ("rod.frd", 5e-6)):
        compare(ref.path, tmp_path / name, tmp_path / name.replace(".", "-"))
        values, status = table(tmp_path / name.replace(".", "-") / "metrics.csv")
        assert status == ["ok"] * 3 and np.all(values[1:, 2] <= bound), (name, values[:, 2])
    u = read_series(tmp_path / "rod.dat").displacements[-1]
    tip = np.argmin(np.linalg.norm(ref.points - [0.5, 0.25, 0.125], axis=1))
    assert u[tip] == pytest.approx(ref.displacements[-1][tip], rel=1e-6, abs=1e-12)


@needs_ccx
@pytest.mark.serial
def test_compare_refusals_of_calculix_output(rod_dynamic, tmp_path):
    """One line each: a truncated .frd, a .dat without its deck or missing nodes, a field
    that is not there, times that do not match, a bad label or wall time."""
    d = rod_dynamic
    ref = d / "rod.reference.xdmf"
    text = (d / "rod.frd").read_text()
    (tmp_path / "cut.frd").write_text(text[: len(text) // 2])
    shutil.copy(d / "rod.dat", tmp_path / "alone.dat")
    dat = (d / "rod.dat").read_text().splitlines()
    (tmp_path / "part.dat").write_text(
        "\n".join(line for line in dat if not line.startswith("        45"))
    )
    shutil.copy(d / "rod.inp", tmp_path / "part.inp")
    # the candidate at h' = 1.001 h: its first step is 1e-3 h away, beyond the tolerance
    late = text.replace("3.33333E-02", "3.33667E-02")
    (tmp_path / "late.frd").write_text(late)
    cases = [
        (dict(candidate=tmp_path / "cut.frd"), "cut.frd: truncated"),
        (dict(candidate=tmp_path / "alone.dat"), "a .dat holds no mesh: its deck alone.inp"),
        (dict(candidate=tmp_path / "part.dat"), "lack node 45"),
        (dict(candidate=d / "rod.frd", candidate_field="VELO"), "no nodal result 'VELO'"),
        (dict(candidate=d / "rod.frd", reference_field="U"), "no point field 'U'"),
        (dict(candidate=tmp_path / "late.frd"), "step 1 is at t = 0.0333667 s"),
        (dict(candidate=d / "rod.frd", label=" x"), "--label must be printable"),
        (dict(candidate=d / "rod.frd", wall_time="-1"), "--wall-time must be a finite"),
    ]
    for kwargs, message in cases:
        candidate = kwargs.pop("candidate")
        with pytest.raises(UserError, match=message) as info:
            compare(ref, candidate, tmp_path / "out", **kwargs)
        assert "\n" not in str(info.value)
    assert not (tmp_path / "out").exists()

    # on the command line: exit status 2, one line on stderr, nothing written
    r = tissuebench("compare", ref, tmp_path / "cut.frd", "--out", tmp_path / "cli")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert r.stderr.startswith(f"tissuebench compare: error: {tmp_path / 'cut.frd'}: truncated")
    assert not (tmp_path / "cli").exists()


@needs_ccx
@pytest.mark.serial
def test_export_and_compare_on_the_command_line(tmp_path):
    """The short affair: export, ccx, compare with a label and wall time; refusals exit 2."""
    r = tissuebench(
        "export", "rod", "--mesh-size", "2", "--end-time", "0.2", "--out", tmp_path / "rod.inp"
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert (
        f"tissuebench compare {tmp_path / 'rod.reference.xdmf'} {tmp_path / 'rod'}.frd" in r.stdout
    )
    ccx(tmp_path / "rod.inp")
    r = tissuebench("compare", tmp_path / "rod.reference.xdmf", tmp_path / "rod.frd",
                    "--out", tmp_path / "graded", "--label", "CalculiX C3D8",
                    "--wall-time", "0.25")  # fmt: skip
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.splitlines()[0].startswith("candidate rod.frd starts at t = 0.0333333 s = h")
    summary = json.loads((tmp_path / "graded" / "summary.json").read_text())
    assert summary["runs"]["CalculiX C3D8"]["wall_time_s"] == 0.25
    assert table(tmp_path / "graded" / "metrics.csv")[0].shape == (7, 6)
    for out, args, message in [
        ("x.inp", ["--models", "linear,svk"], "one model at a time"),
        ("x.txt", [], "cannot tell the format from its suffix"),
    ]:
        r = tissuebench("export", "rod", "--out", tmp_path / out, *args)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
        assert message in r.stderr
