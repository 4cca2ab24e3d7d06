"""Sub-steps (SPEC 11): an explicit scheme takes k equal steps h/k inside each step h of the
benchmark, and is reported at t_i = i h like every run. Its cost is every sub-step's.

`auto` takes the smallest k with h/k at most SAFETY times the scheme's critical step on the
system, measured as the stability study measures it (solvers/stability.py: the extreme
eigenvalues of the free dofs, SLEPc)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

from tissuebench.core.errors import UserError
from tissuebench.solvers.algorithm import Integrator, State

if TYPE_CHECKING:
    from tissuebench.solvers.system import System

SAFETY = 0.9  # h/k <= SAFETY x the critical step
# sub-steps of one run at most (k x its steps): a sub-step takes some 10 to 100 microseconds
# even on the smallest mesh (90 on the block at N = 4 here), so 1e7 of them take minutes to
# hours, and more, days
MAX_SUBSTEPS = 10**7


def auto_substeps(system: System, algorithm: str, h: float) -> tuple[int, float]:
    """(k, critical step in s) for `algorithm` on `system` with the benchmark step h (s): the
    smallest k with h/k <= SAFETY x critical step (1 for an unconditionally stable scheme)."""
    from tissuebench.solvers.stability import stability_limits

    critical = stability_limits(system, [algorithm])[algorithm].critical_dt
    if math.isinf(critical):
        return 1, critical
    return max(1, math.ceil(h / (SAFETY * critical) - 1e-12)), critical


class SubSteps:
    """An Integrator of step h built from `inner`, an integrator of step h/k: step() runs k
    sub-steps, then puts the prescribed values of t = (i + 1) h on the constrained dofs (the
    sub-steps' clock, j h/k, may miss that product by a rounding)."""

    def __init__(self, inner: Integrator, h: float, k: int):
        if not (isinstance(k, int) and k >= 1):
            raise ValueError(f"sub-steps must be a whole number >= 1, got {k!r}")
        self.inner, self.h, self.k = inner, h, k
        self.system: System = inner.system

    def start(self) -> State:
        return self.inner.start()

    def step(self, state: State) -> State:
        i = state.i
        state.i = i * self.k
        for _ in range(self.k):
            self.inner.step(state)
        state.i, state.t = i + 1, (i + 1) * self.h
        s = self.system
        uc, vc, ac = s.prescribed(state.t)
        state.u.array[s.constrained] = uc
        state.v.array[s.constrained] = vc
        state.a.array[s.constrained] = ac
        return state

    def iterations(self) -> int:
        return self.inner.iterations()

    def destroy(self) -> None:
        self.inner.destroy()


def sub_stepped(
    algorithm: str,
    system: System,
    h: float,
    substeps: int | Literal["auto"] = 1,
    solver: str = "direct",
    model: str = "linear",
) -> tuple[Integrator, int, float | None]:
    """(integrator, k, critical step in s or None): `algorithm` on `system` with step h (s),
    taking k sub-steps of h/k per step when it is explicit and `substeps` is k or "auto"
    (implicit and quasi-static schemes take none: k = 1). The critical step is given where
    `auto` measured it."""
    from tissuebench.solvers import ALGORITHMS, get_integrator

    if substeps == 1 or not ALGORITHMS[algorithm].explicit:
        return get_integrator(algorithm, system, h, solver=solver, model=model), 1, None
    critical = None
    if substeps == "auto":
        k, critical = auto_substeps(system, algorithm, h)
    else:
        k = substeps
    inner = get_integrator(algorithm, system, h / k, solver=solver, model=model)
    return (SubSteps(inner, h, k) if k != 1 else inner), k, critical


def substep_count(k: int, h: float, steps: int, runs: int = 1) -> str:
    """What a run with k sub-steps per step h (s), `steps` steps, takes, in words: the sub-step
    h/k and how many sub-steps in all over `runs` explicit runs. UserError where one run would
    take more than MAX_SUBSTEPS (it would not end in reasonable time)."""
    each = k * steps
    said = (
        f"{k} sub-steps of h/{k} = {h / k:.4g} s in each of {steps} steps of h = {h:.4g} s: "
        f"{each:,} sub-steps per explicit run"
        + (f", {each * runs:,} in all ({runs} runs)" if runs > 1 else "")
    )
    if each > MAX_SUBSTEPS:
        raise UserError(
            f"{said}: more than {MAX_SUBSTEPS:,} per run, which would take hours to days (a "
            "sub-step takes 10 to 100 microseconds even on the smallest mesh): give a smaller "
            "--substeps (auto takes as many as the critical step needs)"
        )
    return said


def parse_substeps(text: str) -> int | Literal["auto"]:
    """k (a whole number >= 1) or "auto" from the command line's --substeps (ValueError)."""
    if text.strip() == "auto":
        return "auto"
    try:
        k = int(text)
    except ValueError:
        k = 0
    if k < 1 or str(k) != text.strip():
        raise ValueError(f"--substeps takes a whole number >= 1 or auto, got {text!r}")
    return k
