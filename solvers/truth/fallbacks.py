"""The truth cases that SPEC 10 and 12 take where a case's hierarchy does not converge.

SPEC 10: the large rod (rod-nhb-s3) creases, so its truth is taken at the largest load scale of
2, 1.75, 1.5 and 1.25 whose hierarchy meets the target (rod-nhb-sL); each is posed on the
levels graded toward the clamped face's edges (graded_rod, as rod-MP2's), at the truth's h.

SPEC 12: a contact case that does not meet SPEC 10's target is taken at s = 0.5, then 0.25.
contact-MP2 (nu = 0.495) does not converge at s = 1 (results/truth.md: its finest level's run
at h lies E_i max 3.9e-3 m^2 from the level below, its own half step and its 10 k run alike,
while the two coarser levels differ by 1.3e-4), so contact-MP2-s0.5 is posed: the same block,
grids and penalty, the needle pushed 0.08 m deep (less than R: its flanks do not touch).

SPEC 13: a cylinder case that does not meet SPEC 10's target is taken at s = 0.5, then 0.25, on
the same meridian levels (cases.MERIDIAN_LEVELS): cylinder-MP1-s0.5, cylinder-MP1-s0.25 and
likewise for cylinder-MP2 and cylinder-MP1-nhb (the capsule 0.08 and 0.04 m deep, less than R:
its shaft does not touch). cylinder-MP1 does not converge at s = 1 (measured, n = 10, 20, 40 to
T = 10 s: E_i max between levels 5.9e-4 and 3.0e-4 m^3, order 0.99, its space error alone
3.0e-4 m^3 against a target of 4.4e-6; the force at t = 10 s halves with each level, 0.477,
0.244, 0.125 N: past R the tissue wraps the ball and slides onto the shaft, and the part left
under the ball shrinks with the cells), so cylinder-MP1-s0.5 is its truth: order 1.97, own E_i
max 3.0e-6 m^3 (space 2.1e-6, time 3.1e-7, penalty 5.9e-7) against a target of 9.6e-6
(computed again on 2026-11-29 with the sources of that day: 2.97e-6 against 9.62e-6, 1,477 s).
cylinder-MP2 (nu = 0.495) meets the target at neither fallback (measured 2026-11-29, levels
n = 10, 20, 40, the finest with h and h/2): at s = 0.5 own E_i max 1.06e-5 m^3 (space 7.5e-6,
order 1.66; time 3.1e-6) against 1.0e-5, at s = 0.25 8.1e-6 (space 6.7e-6, order 1.42; time
1.5e-6) against 4.3e-6; and at both its 10 k penalty check stops (Newton with contact does not
converge at t = 0.48 s and 0.88 s), so its penalty's limit is unchecked. It has no truth that
meets SPEC 10's target: the leaderboard does not board it. cylinder-MP1-nhb at s = 1 is not
computed; at s = 0.5 (measured 2026-11-29, 920 s) its own E_i max is 6.9e-6 m^3 (space 6.2e-6,
order 1.83; time 6.4e-7) against 1.15e-5, but its 10 k penalty check stops at t = 2.48 s
(Newton with contact), so its penalty's part is unchecked.

They are registered here, apart from cases.py, whose source is part of every truth's cache key:
a case added there would make every cached truth be computed again; a case's own inputs (its
benchmark, material, model, load scale) are in its key either way (store.inputs).
"""

from tissuebench.meshes import get_entry
from tissuebench.solvers.truth.cases import (
    CASES,
    GRADED,
    MERIDIAN_LEVELS,
    STEP_DIVISOR,
    graded_contact,
    graded_rod,
    register_case,
)
from tissuebench.solvers.truth.floor import FLOOR_CASES

# case -> (the case it falls back from, its load scale s)
FALLBACKS = {"contact-MP2-s0.5": ("contact-MP2", 0.5)}
# SPEC 10's sweep below the fold, in its order of preference
ROD_SWEEP = (2.0, 1.75, 1.5, 1.25)
SWEEP_CASES: list[str] = []  # graded, in that order; then the uniform ones below
for _s in ROD_SWEEP:
    _case = f"rod-nhb-s{_s:g}"
    SWEEP_CASES.append(_case)
    FALLBACKS[_case] = ("rod-nhb-s3", _s)
    register_case(_case, "rod", "MP3", "neo-hookean-barrier", load_scale=_s)
    GRADED[_case] = lambda x: graded_rod(x, get_entry("rod").box)
# measured: every s of the sweep folds on the graded n = 8 (truth.md), so the same loads on the
# uniform levels that rod-nh-s1 and rod-nhb-s3 take, largest first (they do not meet SPEC 10's
# rule of a graded level: their edge cells are those of the graded n = 4). Their Newton may stop
# at the residual's round-off floor (floor.py: rod-nhb-s1.5-uniform's n = 8, t = 8.2 s, stayed
# at 1.05 times the 1e-10 asked, and the run raised). s = 2 meets the target (truth.md) and
# 1.75 as well, so s = 1.5 on uniform levels is not needed
UNIFORM_SWEEP = (2.0, 1.75)
for _s in UNIFORM_SWEEP:
    _case = f"rod-nhb-s{_s:g}-uniform"
    SWEEP_CASES.append(_case)
    FALLBACKS[_case] = ("rod-nhb-s3", _s)
    register_case(_case, "rod", "MP3", "neo-hookean-barrier", load_scale=_s)
    FLOOR_CASES.add(_case)

register_case("contact-MP2-s0.5", "contact", "MP2", "linear", load_scale=0.5)
GRADED["contact-MP2-s0.5"] = graded_contact
# its truth steps h/2 (sampled at the steps of h), as the linear blocks step h/4 and h/16:
# measured at h, its levels converge (order 2.07 in space) but its own E_i max, 1.54e-5 m^2, is
# 1.33 times the target (1.16e-5), two thirds of it in time (1.04e-5 against its half step)
STEP_DIVISOR["contact-MP2-s0.5"] = 2  # with it: 8.1e-6 m^2 against 1.16e-5, measured

# SPEC 13: the cylinder's cases at s = 0.5, then 0.25, on the meridian levels of their case
CYLINDER_SWEEP = (0.5, 0.25)
for _base in ("cylinder-MP1", "cylinder-MP2", "cylinder-MP1-nhb"):
    _benchmark, _material, _model, _, _ = CASES[_base]
    for _s in CYLINDER_SWEEP:
        _case = f"{_base}-s{_s:g}"
        FALLBACKS[_case] = (_base, _s)
        register_case(_case, _benchmark, _material, _model, load_scale=_s)
        MERIDIAN_LEVELS[_case] = MERIDIAN_LEVELS[_base]


def fallbacks_of(case: str) -> list[tuple[str, float]]:
    """[(fallback case, its load scale s)] taken in place of `case`, in order of preference;
    [] for a case whose levels converge (none falls back from it)."""
    return [(c, scale) for c, (source, scale) in FALLBACKS.items() if source == case]
