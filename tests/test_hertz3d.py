"""SPEC 13's Hertz check on the meridian: the axisymmetric forms (solvers/truth/axisymmetric.py)
against an exact solution, Sneddon's sphere against the numbers SPEC 13 quotes, and the static
push of the capsule (solvers/truth/hertz3d.py) against Hertz's and Sneddon's laws."""

from mpi4py import MPI

import dolfinx.fem.petsc
import numpy as np
import pytest
import ufl
from dolfinx import fem
from helpers import run_script

from tissuebench.solvers.truth import axisymmetric as axi
from tissuebench.solvers.truth import hertz3d

E, NU = 200.0, 0.47  # MP1
D = hertz3d.DEPTH


def test_sneddon_gives_the_spec_numbers():
    """SPEC 13: at d = 0.005 m, MP1, R = 0.1 m, Sneddon's rigid sphere has a = 0.022174 m and
    P = 0.038076 N, 0.5 % below Hertz; its pressure integrates to that P and is Hertz's at a
    vanishing depth."""
    a, P = hertz3d.sneddon(E, NU, D)
    assert a == pytest.approx(0.022174, abs=5e-7)
    assert P == pytest.approx(0.038076, abs=5e-7)
    assert P / hertz3d.hertz_force(E, NU, D) - 1 == pytest.approx(-0.005, abs=5e-5)
    assert a / 2 * np.log((0.1 + a) / (0.1 - a)) == pytest.approx(D, rel=1e-12)
    # the pressure's integral over the contact disc (rho = a sin theta) is the closed-form P
    x, w = np.polynomial.legendre.leggauss(64)
    theta = (x + 1) / 2 * np.pi / 2
    rho = a * np.sin(theta)
    p = hertz3d.sneddon_pressure(rho, E, NU, D)
    assert np.sum(w * np.pi / 4 * a * np.cos(theta) * 2 * np.pi * rho * p) == pytest.approx(
        P, rel=1e-10
    )
    # a shallow push is Hertz's: p0 = 2 E* a / (pi R), second-moment radius a
    d = 1e-6
    a, P = hertz3d.sneddon(E, NU, d)
    assert P == pytest.approx(hertz3d.hertz_force(E, NU, d), rel=1e-5)
    E_star = hertz3d.effective_modulus(E, NU)
    assert hertz3d.sneddon_pressure(np.array([0.0]), E, NU, d)[0] == pytest.approx(
        2 * E_star * a / (np.pi * 0.1), rel=1e-5
    )
    assert hertz3d.sneddon_second_moment(E, NU, d) == pytest.approx(a, rel=1e-5)


@pytest.mark.parametrize("mixed", [False, True], ids=["Q2", "Q2-Q1"])
def test_the_axisymmetric_forms_give_an_exact_loaded_column(mixed):
    """A cylinder standing on a frictionless base under its own weight w (N/m^3), side and top
    free, has sigma_zz = w (z - H) and no other stress: u_r = -nu w r (z - H) / E and u_z =
    w (z^2/2 - H z) / E + nu w r^2 / (2 E). Added to it, the homogeneous u_r = A r, u_z = B z,
    held by the uniform tractions sigma_rr = sigma_tt = 2 mu A + lambda (2 A + B) on the side and
    sigma_zz = 2 mu B + lambda (2 A + B) on the top. The sum is quadratic, so that Q2 (and the
    Q1 pressure p = -lambda div u) reproduce it to round-off on the graded meridian. The hoop
    strain u_r / r and the weight 2 pi r carry it: without either (checked by hand) it fails."""
    weight = 10.0  # N/m^3
    meridian = axi.meridian_mesh(6)
    mesh = meridian.mesh
    mu, lmbda = axi.lame(E, NU)
    W = axi.space(mesh, mixed)
    r = axi.radius(mesh)
    body = ufl.as_vector([0.0, -weight])
    if mixed:
        u, p = ufl.TrialFunctions(W)
        w, q = ufl.TestFunctions(W)
        a = axi.mixed_form(u, p, w, q, mu, lmbda)
        U = W.sub(0)
    else:
        u, w = ufl.TrialFunction(W), ufl.TestFunction(W)
        a = axi.displacement_form(u, w, mu, lmbda)
        U = W
    A, B = 0.004, -0.01
    trace = lmbda * (2 * A + B)
    side = ufl.as_vector([2 * mu * A + trace, 0.0])  # Pa, the traction on r = R_B
    top = ufl.as_vector([0.0, 2 * mu * B + trace])  # Pa, on z = H
    ds = ufl.Measure("ds", mesh, subdomain_data=meridian.edges)
    L = (
        ufl.inner(body, w) * axi.volume(r) * ufl.dx
        + ufl.inner(side, w) * axi.volume(r) * ds(axi.TAGS["side"])
        + ufl.inner(top, w) * axi.volume(r) * ds(axi.TAGS["top"])
    )

    def exact(x):
        z = x[1]
        return np.stack(
            [
                -NU * weight * x[0] * (z - axi.H) / E + A * x[0],
                weight * (z * z / 2 - axi.H * z) / E + NU * weight * x[0] ** 2 / (2 * E) + B * z,
            ]
        )

    V = U.collapse()[0] if mixed else W
    base = fem.Function(V)
    base.interpolate(exact)
    axis = meridian.edges.find(axi.TAGS["axis"])
    bottom = meridian.edges.find(axi.TAGS["bottom"])
    Vz, _ = U.sub(1).collapse()
    base_z = fem.Function(Vz)
    base_z.interpolate(lambda x: exact(x)[1])
    bcs = [
        fem.dirichletbc(np.float64(0.0), fem.locate_dofs_topological(U.sub(0), 1, axis), U.sub(0)),
        fem.dirichletbc(
            base_z,
            fem.locate_dofs_topological((U.sub(1), Vz), 1, bottom),
            U.sub(1),
        ),
    ]
    problem = dolfinx.fem.petsc.LinearProblem(
        a,
        L,
        bcs=bcs,
        petsc_options={
            "ksp_type": "preonly",
            "pc_type": "lu",
            "pc_factor_mat_solver_type": "mumps",
        },
        petsc_options_prefix=f"column_{int(mixed)}_",
    )
    solution = problem.solve()
    uh = solution.sub(0).collapse() if mixed else solution
    comm = mesh.comm
    error = comm.allreduce(np.abs(uh.x.array - base.x.array).max(), op=MPI.MAX)
    scale = comm.allreduce(np.abs(base.x.array).max(), op=MPI.MAX)
    assert scale > 0.01  # m: a real deformation (the top sinks w H^2 / (2 E) = 0.025 m)
    assert error < 1e-10 * scale
    if mixed:
        ph = solution.sub(1).collapse()
        X = ph.function_space.tabulate_dof_coordinates()
        # p = -lambda div u = -lambda (1 - 2 nu) sigma_zz / E
        expected = -lmbda * (1 - 2 * NU) * weight * (X[:, 1] - axi.H) / E - trace
        perr = comm.allreduce(np.abs(ph.x.array - expected).max(), op=MPI.MAX)
        assert perr < 1e-9 * weight * axi.H


def test_hertz_push_against_the_laws():
    """SPEC 13's static 5 mm push, the quick path of `tissuebench hertz --dim 3` on two coarse
    levels (n = 16, 32) and the body-size study at n = 32 on cylinders 2 and 4 times as large.
    The push is a contact (P above half of Hertz's), the stiffer penalty moves P by less than
    1e-3 and leaves an interpenetration below 1e-4 d. The finite cylinder lowers P, a and p0:
    the finite body's effect is negative and shrinks like 1 / s, so that P rises with s toward
    the half-space's. The half-space laws, judged on the half-space's values extrapolated in
    1 / s, hold within SPEC 13's tolerances: P within 0.5 % of Sneddon's exact sphere and 1.5 %
    of Hertz's, a within 2 % of (3 P R / (4 E*))^(1/3), 3 P / (2 pi a^2) within 2 % of the
    largest pressure; and `holds` is theirs, computed. SPEC 13's own cylinder misses Sneddon's
    0.5 % (measured: P -1.0 %; results/contact/hertz3d.json). The second moment over the
    reference radius is below the deformed point's (the capsule pushes the face outward)."""
    from tissuebench.workflows.contact import hertz3d as check

    pushes, study = check.compute(levels=(16, 32), bodies=(2.0, 4.0))
    r = check.record(pushes, study, 0.0)
    P_hertz = hertz3d.hertz_force(E, NU, D)
    _, P_sneddon = hertz3d.sneddon(E, NU, D)
    soft, stiff = (p for p in pushes if p.n == 16)
    assert stiff.P > 0.5 * P_hertz
    assert abs(stiff.P / soft.P - 1) < 1e-3
    assert stiff.interpenetration < 1e-4 * D
    assert stiff.p0 > 0 and stiff.rho.max() < 1.2 * stiff.a
    # the body-size study: the finite body lowers every measure, less on a larger body
    sizes = r["body_size"]
    assert sizes["scale"] == [1.0, 2.0, 4.0] and sizes["n"] == 32
    for key in ("P", "a", "p0"):
        effect = sizes["finite_body_effect"][key]
        assert all(e < 0 for e in effect), key
        assert abs(effect[0]) > abs(effect[1]) > abs(effect[2]), key
        assert r["finite_body"][key] == effect[0]
    effect = sizes["finite_body_effect"]["P"]
    assert 0.4 < effect[1] / effect[0] < 0.6 and 0.4 < effect[2] / effect[1] < 0.6  # ~ 1 / s
    assert sizes["P"][0] < sizes["P"][1] < sizes["P"][2] < r["half_space"]["P"]
    assert -0.015 < r["finite_body"]["P"] < -0.005  # not SPEC 13's "less than 0.1 %"
    # the laws on the half-space's values, and holds computed from them
    half = r["half_space"]
    assert half["P"] == pytest.approx(P_sneddon, rel=check.TOLERANCE["P_sneddon"])
    assert half["P"] == pytest.approx(P_hertz, rel=check.TOLERANCE["P_hertz"])
    errors = check.law_errors(half["P"], half["a"], half["p0"], E, NU)
    assert errors == r["errors"]
    for key, tolerance in check.TOLERANCE.items():
        assert abs(errors[key]) <= tolerance, key
    assert r["holds"] is True and all(r["holds_each"].values())
    # SPEC 13's own cylinder, beside: its P misses Sneddon's 0.5 %
    cylinder = r["cylinder"]
    assert cylinder["n"] == 32 and cylinder["P"] == sizes["P"][0]
    assert cylinder["errors"]["P_sneddon"] < -check.TOLERANCE["P_sneddon"]
    assert cylinder["within_tolerance"]["P_sneddon"] is False
    assert cylinder["a"] < cylinder["a_deformed"] < 1.02 * cylinder["a"]


@pytest.mark.serial
def test_hertz_push_serial_equals_two_ranks():
    """The push on 2 ranks gives the serial numbers and pressure profile."""
    serial = run_script("mpi_hertz3d.py", ranks=1)
    parallel = run_script("mpi_hertz3d.py", ranks=2)
    assert len(serial) == len(parallel) == 2
    for one, two in zip(serial, parallel, strict=True):
        assert one["dofs"] == two["dofs"]
        for key in ("P", "p0", "a"):
            assert two[key] == pytest.approx(one[key], rel=1e-8), key
        assert np.allclose(one["rho"], two["rho"], rtol=0, atol=1e-12)
        assert np.allclose(one["p"], two["p"], rtol=1e-7)


def test_the_meridian_truth_equals_a_3d_computation():
    """SPEC 13: the truth on the meridian is the 3D problem's solution. The same static push,
    with the same penalty k = 5e6 Pa/m (so that both discretise one continuum problem), on a
    quarter of the cylinder in second-order tetrahedra (P2-P1, symmetry on the planes x = 0
    and y = 0, the capsule's own 3D signed distance) graded to h = 16 and 8 mm at the contact:
    the meridian's P (N) and contact radius a (m) lie within the 3D solution's own
    discretisation error at 8 mm, estimated as its change from 16 mm."""
    from quarter_cylinder import quarter_cylinder

    k = 5e6  # Pa/m
    n = 32
    h_axi = 2 * axi.FINE / n
    truth = hertz3d.push(E, NU, n, kappas=(k * h_axi / E,))[-1]
    runs = []
    for h_near, h_far in ((0.016, 0.2), (0.008, 0.1)):
        tagged = quarter_cylinder(h_near, h_far)
        runs.append(
            hertz3d.push_3d(
                E,
                NU,
                tagged.mesh,
                tagged.entities("top")[1],
                tagged.entities("bottom")[1],
                h_near,
                symmetry={0: tagged.entities("x0")[1], 1: tagged.entities("y0")[1]},
                share=0.25,
                kappas=(k * h_near / E,),
            )[-1]
        )
    coarse, fine = runs
    assert truth.k == pytest.approx(k) and fine.k == pytest.approx(k)
    for key in ("P", "a"):
        own_error = abs(getattr(fine, key) - getattr(coarse, key))
        assert own_error < 0.05 * getattr(fine, key), key  # the 3D levels are near the answer
        assert abs(getattr(truth, key) - getattr(fine, key)) <= own_error, key
