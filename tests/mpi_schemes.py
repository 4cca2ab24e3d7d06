"""Each scheme of SPEC 11 on the rod (hexahedra or tetrahedra, n = 2, MP2): the norm of K, the
compiled block-CSR product against PETSc's MatMult (anp's K reaches the neighbours'
neighbours), and the tip after 30 steps of explicit-lumped with auto sub-steps and of
implicit, printed as JSON by rank 0 (run in serial and under mpiexec by test_schemes.py)."""

import json

from mpi4py import MPI

from tissuebench.meshes import get_benchmark
from tissuebench.solvers.simulate import simulate
from tissuebench.solvers.substeps import sub_stepped
from tissuebench.solvers.system import System, probe

out = {}
for scheme, cell in [
    ("standard", "hexahedron"),
    ("mean-dilatation", "hexahedron"),
    ("hourglass", "hexahedron"),
    ("anp", "tetrahedron"),
    ("penalty", "tetrahedron"),
]:
    options = {} if cell == "hexahedron" else {"cell": cell}
    bench = get_benchmark("rod", mesh_size=2, **options)
    s = System(bench, "MP2", scheme=scheme)
    out[f"{scheme}-K"] = s.K.norm()
    x = s.K.createVecRight()
    x.setRandom()
    y, y_petsc = s.K.createVecLeft(), s.K.createVecLeft()
    s.K.mult(x, y_petsc)
    s.K_csr.mult(x, y)
    y.axpy(-1.0, y_petsc)
    out[f"{scheme}-kernel"] = 0.0 if y.norm() < 1e-13 * y_petsc.norm() else y.norm()
    for algorithm in ("explicit-lumped", "implicit"):
        integrator, k, critical = sub_stepped(algorithm, s, 1 / 30, "auto")
        run = simulate(integrator, 30, bench.extent, algorithm)
        assert run.status == "ok", (scheme, algorithm, run.reason)
        out[f"{scheme}-{algorithm}-tip"] = probe(s.V, run.u[-1], bench.probe).tolist()
        out[f"{scheme}-{algorithm}-substeps"] = k
        integrator.destroy()
# F-bar: mean-dilatation with neo-Hookean, explicit-lumped at the rod's load scale 3
bench = get_benchmark("rod", mesh_size=2, load_scale=3.0)
s = System(bench, "MP3", scheme="mean-dilatation")
integrator, k, _ = sub_stepped("explicit-lumped", s, 1 / 30, "auto", model="neo-hookean")
run = simulate(integrator, 30, bench.extent, "explicit-lumped+neo-hookean")
assert run.status == "ok", run.reason
out["f-bar-explicit-lumped-tip"] = probe(s.V, run.u[-1], bench.probe).tolist()
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(out))
