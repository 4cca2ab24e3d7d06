"""The leaderboard's cases (`BOARDS`): each a benchmark posed once (material, model, options,
mesh size, h, T), the models of ours it runs, the outside simulators and their variants, and
its truth (SPEC 10). workflows/leaderboard/rows.py reads and ranks them; a case is one entry
here, and a benchmark defined elsewhere (a test's) adds its own with register(board)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, cast

from tissuebench.solvers import MODELS
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.fallbacks import FALLBACKS
from tissuebench.workflows.simulators import SIMULATORS


@dataclass
class Board:
    """One leaderboard case: a benchmark posed once (material, model, options at the
    benchmark's default mesh, h and T), our algorithms with `models`, and the simulators."""

    name: str
    benchmark: str
    material: str
    model: str  # the reference's model (and the model the simulators are given, by default)
    models: tuple[str, ...] = ("linear",)  # ours
    options: dict = field(default_factory=dict)
    simulators: tuple[str, ...] = tuple(SIMULATORS)
    description: str = ""
    mesh_size: int | None = None  # None: the benchmark's default
    end_time: float | None = None  # s; None: the benchmark's default
    truth: str | None = None  # its SPEC 10 truth case (None: it has none, truth_note says why)
    truth_note: str = ""  # one line on the truth in the case's header (why none, not computed)
    truth_band: float | None = None  # the truth's own E_i max (m^gdim), once it is loaded
    # simulator -> the variants run on this case (a simulator not named: every variant), with
    # `skip_note` saying why the others are not
    variants: dict[str, tuple[str, ...]] = field(default_factory=dict)
    skip_note: str = ""
    sizes: str | None = None  # the series of mesh sizes it belongs to (size_table), if any
    session: str = ""  # when its runs were timed ("" : the session writing the leaderboard)
    machine: str = ""  # where (machine(); "": this machine)
    # the machine's one-minute load average when its timing began and ended ((), not measured)
    load: tuple[float, ...] = ()
    # the model the simulators are given (None: `model`), when none of them has the reference's
    simulator_model: str | None = None


# --- the cases -------------------------------------------------------------------------------

# At n = 12 (12,675 dofs) each simulator runs the variants that a user would run at that size
# and that the closing note of issue 27 asks for (Drake linear, MuJoCo, Kratos tetrahedra and
# hexahedra); the explicit ones are unstable at h = 1/30 s on that mesh
N12_VARIANTS = {
    "calculix": (),
    "sfepy": ("newmark",),
    "newton": (),
    "mujoco": ("discrete",),
    "kratos": ("hex8-newmark", "tet4-newmark"),
    "drake": ("linear",),
}
N12_NOTE = (
    "at n = 12 only the variants above run: the explicit ones are unstable at h = 1/30 s on "
    "this mesh, and the others cost too much for one timing session here (measured, 30 steps "
    "on this machine under load, per simulated second): CalculiX C3D8 53 s and C3D8I 120 s "
    "(ccx factorises at every increment), Newton VBD 88 s; the Kratos and Drake rows above "
    "factorise their matrix at every step too (Eigen's SparseLU; Drake's own solver)"
)

# SPEC 10: the largest load scale of the sweep (2, 1.75, 1.5, 1.25) whose truth rod-nhb-sL meets
# the target; measured (results/truth.md): each folds on its graded finest level, so the large
# rod is graded against the same load's truth on uniform levels (solvers/truth/fallbacks.py),
# which do not resolve the fold at the lower edges: the largest of them that meets it
ROD_LARGE_SCALE = 2.0
ROD_LARGE_TRUTH = f"rod-nhb-s{ROD_LARGE_SCALE:g}-uniform"
LARGE_MODELS = {6: ("linear", "neo-hookean-barrier"), 12: ("linear", "neo-hookean-barrier")}
# at n = 12 the simulators' nonlinear variants that cost minutes, not hours, here (measured on
# n = 6, per run of 10 s under load: CalculiX C3D8 33 s to C3D20R 292 s, SfePy 37 to 116 s,
# Kratos hex8 49 to 57 s, Newton VBD 53 s; n = 12 has 6.6 times the dofs)
LARGE_N12_VARIANTS = {
    "calculix": (),
    "sfepy": (),
    "newton": ("vbd-1", "semi-implicit"),
    "mujoco": ("discrete",),
    "kratos": ("tet4-newmark",),
    "drake": ("neo-hookean",),
}
LARGE_N12_NOTE = (
    "at n = 12 only the variants above run: the others cost too much for one timing session "
    "here (measured on n = 6, one run of 10 s under load: CalculiX C3D8 33 s to C3D20R 292 s, "
    "SfePy 37 to 116 s, Kratos hex8 49 to 57 s, Newton VBD 53 s; n = 12 has 6.6 times the dofs)"
)
ROD_LARGE_WORDS = {
    3: ("6 x 3 x 3", "336"),
    6: ("12 x 6 x 6", "1,911"),
    12: ("24 x 12 x 12", "12,675"),
}


def rod_large(n: int) -> Board:
    """The large rod's board on n (SPEC 10: load scale L below the fold, its truth):
    ours with every model on n = 3 and the reference's (neo-hookean-barrier) and linear on the
    finer ones, the simulators with their neo-Hookean laws (their own, each row says how it was
    mapped: none has the barrier)."""
    s = ROD_LARGE_SCALE
    words, dofs = ROD_LARGE_WORDS[n]
    name = f"rod-MP3-s{s:g}" + ("" if n == 3 else f"-n{n}")
    return Board(
        name,
        "rod",
        "MP3",
        "neo-hookean-barrier",
        models=tuple(MODELS) if n == 3 else LARGE_MODELS[n],
        options={"load_scale": s},
        description=f"Bending rod, MP3, load scale s = {s:g} (SPEC 10's sweep below the fold), "
        f"n = {n}: {words} hexahedra ({dofs} dofs), h = 1/30 s, T = 10 s: large deformation, "
        f"graded against its truth {ROD_LARGE_TRUTH} (the largest load of the sweep whose "
        "truth meets SPEC 10's target: on uniform levels, as the graded ones fold at every load; "
        "results/truth.md) and on the same mesh against implicit+neo-hookean-barrier; ours with "
        + ("every model" if n == 3 else " and ".join(LARGE_MODELS[n]))
        + ", the simulators with their own neo-Hookean laws (none has the barrier), each row "
        "saying how the SPEC's law was mapped onto it.",
        mesh_size=None if n == 3 else n,
        truth=ROD_LARGE_TRUTH,
        sizes=f"rod-MP3-s{s:g}",
        **cast(
            dict[str, Any],
            {"variants": LARGE_N12_VARIANTS, "skip_note": LARGE_N12_NOTE} if n == 12 else {},
        ),
        simulator_model="neo-hookean",
    )


# The cases: the paper's block and rod (linear), and SPEC 8's rod at three times its load
# (neo-hookean-barrier reference, every model of ours; the simulators with neo-hookean, the
# law theirs approximate: none has the barrier), at each benchmark's default mesh, h and T.
BOARDS = [
    Board(
        "block-MP1",
        "block",
        "MP1",
        "linear",
        description="Block and needle (SPEC 4), MP1, 20 x 20 quadrilaterals, plane strain, "
        "h = 1/30 s, T = 10 s, linear model.",
        truth_note="none: the needle is a point (w = 0), and refinement converges to no "
        "solution (SPEC 10); the block's truth is posed with a needle of width 0.2 m "
        "(block-MP1-w0.2: the mesh-sensitivity-block-MP1 case below).",
    ),
    Board(
        "rod-MP3",
        "rod",
        "MP3",
        "linear",
        description="Bending rod (SPEC 5), MP3, 6 x 3 x 3 hexahedra, h = 1/30 s, T = 10 s, "
        "linear model.",
        truth="rod",
        sizes="rod-MP3",
    ),
    Board(
        "rod-MP3-s3",
        "rod",
        "MP3",
        "neo-hookean-barrier",
        models=tuple(MODELS),
        options={"load_scale": 3.0},
        description="Bending rod, MP3, load scale s = 3 (SPEC 8): large deformation, against "
        "implicit+neo-hookean-barrier; ours with every model, the simulators with their "
        "neo-Hookean laws (none has the barrier: CalculiX's NEO HOOKE is neo-hookean), graded "
        "on the same mesh against implicit+neo-hookean-barrier. It has no truth: the rod creases "
        "at this load (SPEC 10); the large rod's truth is taken below the fold, at s = "
        f"{ROD_LARGE_SCALE:g} (rod-MP3-s{ROD_LARGE_SCALE:g}, graded against {ROD_LARGE_TRUTH}; "
        "results/truth.md).",
        truth="rod-nhb-s3",
        simulator_model="neo-hookean",
    ),
    # SPEC 10: the large rod below the fold, graded against its truth rod-nhb-sL at three sizes
    *(rod_large(n) for n in (3, 6, 12)),
    # the linear rod at two finer meshes (issue 27): how each run's cost grows with its dofs
    # and where its accuracy against the truth stops improving
    Board(
        "rod-MP3-n6",
        "rod",
        "MP3",
        "linear",
        description="Bending rod (SPEC 5), MP3, n = 6: 12 x 6 x 6 hexahedra (1,911 dofs), "
        "h = 1/30 s, T = 10 s, linear model; as rod-MP3 on a mesh twice as fine.",
        mesh_size=6,
        truth="rod",
        sizes="rod-MP3",
    ),
    Board(
        "rod-MP3-n12",
        "rod",
        "MP3",
        "linear",
        description="Bending rod (SPEC 5), MP3, n = 12: 24 x 12 x 12 hexahedra (12,675 dofs), "
        "h = 1/30 s, T = 10 s, linear model; as rod-MP3 on a mesh four times as fine.",
        mesh_size=12,
        truth="rod",
        sizes="rod-MP3",
        variants=N12_VARIANTS,
        skip_note=N12_NOTE,
    ),
    # the linear rod in the prostate-like MP2 (nu = 0.495, SPEC 10/11, issue 32) at the three
    # sizes, each simulator posed as on the MP3 rod: where nearly incompressible tissue loses
    *(
        Board(
            "rod-MP2" if n == 3 else f"rod-MP2-n{n}",
            "rod",
            "MP2",
            "linear",
            description=f"Bending rod (SPEC 5), MP2 (E = 60 kPa, nu = 0.495: nearly "
            f"incompressible, SPEC 11), n = {n}: {words} hexahedra ({dofs} dofs), h = 1/30 s, "
            f"T = 10 s, linear model; as rod-MP3{suffix} in the prostate's material.",
            mesh_size=None if n == 3 else n,
            truth="rod-MP2",
            sizes="rod-MP2",
            **cast(
                dict[str, Any],
                {"variants": N12_VARIANTS, "skip_note": f"as on rod-MP3-n12, {N12_NOTE}"}
                if n == 12
                else {},
            ),
        )
        for n, words, dofs, suffix in (
            (3, "6 x 3 x 3", "336", ""),
            (6, "12 x 6 x 6", "1,911", "-n6"),
            (12, "24 x 12 x 12", "12,675", "-n12"),
        )
    ),
]


# --- the needle as contact (SPEC 12) -----------------------------------------------------------

CONTACT_KAPPA = 10.0  # SPEC 12's default penalty
CONTACT_SIZES = (10, 20, 40)  # N
CONTACT_MAIN = 20  # the benchmark's default N: the main board
CONTACT_NEWTON_NOTE = (
    "at N = 40 Newton's VBD is not run: its contact variant took 148 s for the 10 simulated s "
    "at N = 20 on this machine (a load of 5 to 8 on 2 cores), its cost growing with the "
    "particles about fourfold at N = 40"
)
# the contact cases graded on the leaderboard: contact-MP2 at s = 1 has no truth (its levels do
# not converge, results/truth.md), so SPEC 12's fallback at s = 0.5 is graded in its place
CONTACT_CASES = ("contact-MP1", "contact-MP1-nhb", "contact-MP2-s0.5")
CONTACT_WORDS = (
    "Block and rigid needle in frictionless contact (SPEC 12): the half-stadium R = 0.1 m "
    "pushed {depth:.2g} m into the free right edge (s = {s:g}), N x N quadrilaterals, plane "
    "strain, h = 1/30 s, T = 10 s, our penalty kappa = 10 (explicit ones with the sub-steps "
    "their critical step needs, the penalty counted)"
)
CONTACT_COLUMNS = (
    "force error: max over the steps of |F - F_ref| / max |F_ref|, F the needle force per unit "
    "thickness; interpenetration: the largest -g_n over the deformed right edge and the steps"
)


def contact_board(case: str, n: int) -> Board:
    """A contact truth case's board on N = n (its material, model and load scale from CASES):
    contact-MP1, contact-MP1-nhb (every model of ours, the simulators with neo-hookean) or
    contact-MP2-s0.5 (SPEC 12's fallback for contact-MP2)."""
    _, material, model, scale, _ = CASES[case]
    nhb = model == "neo-hookean-barrier"
    how = (
        f"{material}, neo-hookean-barrier reference; ours with every model, the simulators "
        "with their neo-Hookean laws (none has the barrier)"
        if nhb
        else f"{material}, linear model"
    )
    if case in FALLBACKS:
        how += f"; SPEC 12's fallback for {FALLBACKS[case][0]}, whose truth does not converge"
    models = ("linear",)
    if nhb:  # every model of ours on the main board, the reference's elsewhere (their cost)
        models = tuple(MODELS) if n == CONTACT_MAIN else (model,)
        how += "" if n == CONTACT_MAIN else "; ours with neo-hookean-barrier only at this size"
    variants: dict[str, tuple[str, ...]] = {}
    skip = ""
    if n > CONTACT_MAIN:
        variants, skip = {"newton": ()}, CONTACT_NEWTON_NOTE
    words = CONTACT_WORDS.format(depth=0.16 * scale, s=scale)
    return Board(
        case if n == CONTACT_MAIN else f"{case}-n{n}",
        "contact",
        material,
        model,
        models=models,
        options={"kappa": CONTACT_KAPPA, "load_scale": scale},
        variants=variants,
        skip_note=skip,
        description=f"{words}, {how}; N = {n}: {n} x {n} cells "
        f"({2 * (n + 1) ** 2:,} dofs). {CONTACT_COLUMNS}.",
        mesh_size=None if n == CONTACT_MAIN else n,
        truth=case,
        sizes=case,
        simulator_model="neo-hookean" if nhb else None,
    )


BOARDS += [contact_board(case, n) for case in CONTACT_CASES for n in CONTACT_SIZES]


# --- the needle in 3D (SPEC 13) ----------------------------------------------------------------

CYLINDER_SIZES = (3, 4, 6)  # n, cells along the radius
CYLINDER_MAIN = 6  # the benchmark's default n: the main board
# the cylinder cases graded on the leaderboard: at s = 1 cylinder-MP1 has no truth (its levels
# do not converge, solvers/truth/fallbacks.py), so SPEC 13's fallback at s = 0.5 is graded;
# cylinder-MP2 meets SPEC 10's target at neither s = 0.5 nor 0.25 (fallbacks.py), so it has no
# board
CYLINDER_CASES = ("cylinder-MP1-s0.5",)
CYLINDER_WORDS = (
    "Tissue cylinder and rigid capsule in frictionless contact (SPEC 13): R_B = 0.5 m, H = 1 m, "
    "bottom fixed, the capsule R = 0.1 m pushed {depth:.2g} m into the top face's centre "
    "(s = {s:g}), an O-grid of hexahedra, h = 1/30 s, T = 10 s, our penalty kappa = 10 over the "
    "top face (explicit ones with the sub-steps their critical step needs, the penalty counted); "
    "each simulator with its own 3D contact, its parameters in its row"
)
CYLINDER_NOTE = (
    "not run: CalculiX (its 2D contact adapter poses a rigid half-stadium surface; a capsule's "
    "rigid surface is not written yet), Kratos (no contact adapter, as in 2D) and Genesis "
    "(re-meshes its input, so that its nodes are not the export's, and its contact-force "
    "query returned 0 on the probe)"
)
# at n = 6 MuJoCo and Drake are not run: measured here, MuJoCo's discrete-10 took 638 s for the
# 10 simulated s at n = 6 (its discrete-30-stiff took 4.2 times its discrete-10 at n = 4), too
# long for the session that posed them, which then had no time left for Drake's three
CYLINDER_MAIN_VARIANTS: dict[str, tuple[str, ...]] = {"mujoco": (), "drake": ()}
CYLINDER_MAIN_NOTE = (
    "at n = 6 MuJoCo and Drake are not run: MuJoCo's discrete-10 took 638 s for the 10 "
    "simulated s here (its stiff variant 4.2 times that at n = 4), and Drake's variants were "
    "not timed at this size; they are graded at n = 3 and 4"
)
CYLINDER_COLUMNS = (
    "force error: max over the steps of |F_z - F_z,ref| / max |F_z,ref|, F the force on the "
    "capsule in N; interpenetration: the largest -g_n over the deformed top face and the steps"
)


def cylinder_board(case: str, n: int) -> Board:
    """A cylinder truth case's board on n cells along the radius (its material, model and
    load scale from CASES)."""
    _, material, model, scale, _ = CASES[case]
    how = f"{material}, {model} model"
    if case in FALLBACKS:
        how += f"; SPEC 13's fallback for {FALLBACKS[case][0]}, whose truth does not converge"
    words = CYLINDER_WORDS.format(depth=0.16 * scale, s=scale)
    return Board(
        case if n == CYLINDER_MAIN else f"{case}-n{n}",
        "cylinder",
        material,
        model,
        options={"kappa": CONTACT_KAPPA, "load_scale": scale},
        simulators=("sfepy", "newton", "mujoco", "drake"),
        variants=dict(CYLINDER_MAIN_VARIANTS) if n == CYLINDER_MAIN else {},
        skip_note=CYLINDER_NOTE + ("; " + CYLINDER_MAIN_NOTE if n == CYLINDER_MAIN else ""),
        description=f"{words}; {how}; n = {n} cells along the radius. {CYLINDER_COLUMNS}.",
        mesh_size=None if n == CYLINDER_MAIN else n,
        truth=case,
        sizes=case,
    )


BOARDS += [cylinder_board(case, n) for case in CYLINDER_CASES for n in CYLINDER_SIZES]


def register(board: Board) -> None:
    """Add `board` to BOARDS (the same list, wherever it was imported); ValueError if a case
    has its name."""
    if any(b.name == board.name for b in BOARDS):
        raise ValueError(f"the leaderboard already has a case {board.name!r}")
    BOARDS.append(board)


def unregister(name: str) -> None:
    """Take case `name`, which register added, out of BOARDS."""
    BOARDS[:] = [b for b in BOARDS if b.name != name]


def is_contact(board: Board) -> bool:
    """Whether a board poses the needle as contact (SPEC 12: its benchmark's entry has a rigid
    tool): its rows carry the force error and the interpenetration."""
    from tissuebench.meshes import in_contact

    return in_contact(board.benchmark)
