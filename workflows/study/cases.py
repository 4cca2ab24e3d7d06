"""The paper's cases (`tissuebench paper`, SPEC sections 4, 5, 7 and 8): part 1's, `cases`
(every algorithm against implicit on one material; block-MP2-vs-MP1, the paper's Figure 11;
block-MP1-40s and rod-MP3-30s, on which the report checks claims 3 and 6), and part 2's,
`model_cases` (every algorithm with every elastic model, SPEC section 8). The paper's runs
against the truth are workflows/study/truth.py's.

A benchmark defined elsewhere (a test's) adds its own cases to either part with register(case)
and takes them out with unregister(name); they run with the paper's --solver and --petsc.
"""

from dataclasses import replace

from tissuebench.meshes import get_entry
from tissuebench.solvers import ALGORITHMS, MODELS
from tissuebench.solvers.models import REFERENCE_MODEL, run_label
from tissuebench.workflows.run.case import Case, algorithm_case, model_case

# the cases that register added: (case, whether it is part 2's)
REGISTERED: list[tuple[Case, bool]] = []


def register(case: Case, large: bool = False) -> None:
    """Add `case` to the paper's part 1 (large: to part 2, SPEC section 8); ValueError if a
    case of the paper has its name."""
    taken = [c.name for c in cases() + model_cases()]
    if case.name in taken:
        raise ValueError(f"the paper already has a case {case.name!r}")
    REGISTERED.append((case, large))


def unregister(name: str) -> None:
    """Take case `name`, which register added, out of the paper."""
    REGISTERED[:] = [(case, large) for case, large in REGISTERED if case.name != name]


def registered(large: bool, solver: str, petsc: str) -> list[Case]:
    """The cases register added to part 1 (large: part 2), with this solver and PETSc text."""
    return [replace(c, solver=solver, petsc=petsc) for c, part in REGISTERED if part == large]


def cases(solver: str = "direct", petsc: str = "") -> list[Case]:
    """Part 1: the paper's study (SPEC sections 4, 5 and 7), then the cases register added."""
    names = list(ALGORITHMS)
    vs = [
        ("implicit-MP2", "implicit", "MP2"),
        *((f"{a}-MP1", a, "MP1") for a in names),
        ("quasi-static-MP2", "quasi-static", "MP2"),
    ]
    return [
        algorithm_case(
            "block-MP1",
            "block",
            "MP1",
            names,
            solver=solver,
            petsc=petsc,
            description=(
                "Block and needle, MP1: the five algorithms against implicit MP1 (paper Figs. 5-7)"
            ),
        ),
        algorithm_case(
            "block-MP2",
            "block",
            "MP2",
            names,
            solver=solver,
            petsc=petsc,
            description=(
                "Block and needle, MP2 (human prostate): the five algorithms against implicit MP2"
            ),
        ),
        algorithm_case(
            "rod-MP3",
            "rod",
            "MP3",
            names,
            solver=solver,
            petsc=petsc,
            description=(
                "Bending rod, MP3: the five algorithms against implicit MP3 (paper Figs. 8-10)"
            ),
        ),
        Case(
            "block-MP2-vs-MP1",
            "block",
            vs,
            "implicit-MP2",
            solver=solver,
            petsc=petsc,
            description=(
                "Block: every MP1 run and quasi-static MP2 against implicit MP2 (paper Fig. 11)"
            ),
        ),
        # Beyond the paper's 10 s, on the same meshes: the checks of claims 3 and 6 (SPEC section 7)
        algorithm_case(
            "block-MP1-40s",
            "block",
            "MP1",
            names,
            end_time=40.0,
            solver=solver,
            petsc=petsc,
            description=(
                "Block and needle, MP1, as block-MP1 but run to 40 s: do all schemes settle on "
                "the quasi-static solution? (claim 3)"
            ),
        ),
        # the reference and its static deflection only: the rod's surface error costs ~10 ms a step
        algorithm_case(
            "rod-MP3-30s",
            "rod",
            "MP3",
            ["quasi-static"],
            end_time=30.0,
            solver=solver,
            petsc=petsc,
            description=(
                "Bending rod, MP3, implicit and quasi-static as in rod-MP3 but run to 30 s: the "
                "oscillation about the static shape (claim 6)"
            ),
        ),
        *registered(False, solver, petsc),
    ]


# SPEC section 8's named cases: (name, benchmark, material, load scale s, needle width w,
# the reference's model: neo-hookean at the paper's loads, neo-hookean-barrier at large ones)
LARGE_CASES = [
    ("block-MP1-s1", "block", "MP1", 1.0, 0.0, REFERENCE_MODEL),
    ("block-MP1-s2-w0.2", "block", "MP1", 2.0, 0.2, "neo-hookean-barrier"),
    ("rod-MP3-s1", "rod", "MP3", 1.0, None, REFERENCE_MODEL),
    ("rod-MP3-s3", "rod", "MP3", 3.0, None, "neo-hookean-barrier"),
]


def model_cases(solver: str = "direct", petsc: str = "") -> list[Case]:
    """Part 2 (SPEC section 8): the five algorithms times every model on each named case,
    against implicit with the case's reference model (SPEC 8's table); then the cases register
    added to part 2."""
    result = []
    for name, benchmark, material, scale, width, model in LARGE_CASES:
        reference = run_label("implicit", model)
        options = {"load_scale": scale}
        load = f"s = {scale:g}"
        if width is not None:
            options["needle_width"] = width
            load += f", needle width w = {width:g} m" if width else ", point needle (w = 0)"
        what = get_entry(benchmark).title
        result.append(
            model_case(
                name,
                benchmark,
                material,
                list(ALGORITHMS),
                list(MODELS),
                reference,
                options=options,
                solver=solver,
                petsc=petsc,
                description=f"{what}, {material}, load scale {load}: the five algorithms with the "
                f"{len(MODELS)} elastic models against {reference} (SPEC section 8)",
            )
        )
    return result + registered(True, solver, petsc)
