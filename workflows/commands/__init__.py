"""Each command of the command line (workflows/cli.py), in the order of its help, with its help
line: the one registry line of a command, whose module is workflows/commands/NAME.py. The
top-level help lists them from here, importing no command (DOLFINx, matplotlib, PETSc: 1.5 s)."""

HELP = {
    "run": "run one benchmark with the chosen algorithms",
    "paper": "the paper's study, its figures and report",
    "compare": "the three metrics of two displacement series, on one mesh or two",
    "mesh": "save a benchmark's mesh as a gmsh .msh file",
    "export": "write a benchmark for another simulator (JSON, CalculiX .inp, .vtu, .msh)",
    "external": "run a benchmark in an outside simulator (CalculiX, SfePy, ...) and grade it",
    "leaderboard": "accuracy against cost of our algorithms, outside simulators and users' runs",
    "sensitivity": "mesh-sensitivity study: every algorithm on coarser and other-shaped meshes",
    "stability": "critical time step of every scheme (eigenvalues + amplification matrix)",
    "convergence": "observed orders of the errors in time and in space",
    "bench": "speed against a scikit-fem + SciPy peer, the bandwidth limit and 2 ranks",
    "truth": "the converged reference of SPEC 10: compute (once, cached) and summarise",
    "frontier": "the real-time frontier: every scheme against the truth, at its cost (SPEC 11)",
    "hertz": (
        "the needle pushed statically into the block, against Hertz's law (SPEC 12; --dim 3: "
        "the capsule into the cylinder, SPEC 13)"
    ),
    "contact": "our algorithms with the needle as contact, graded against its truth (SPEC 12)",
}
