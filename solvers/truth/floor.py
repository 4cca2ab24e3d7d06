"""A truth whose Newton may stop at the residual's round-off floor (the large rod's sweep).

The truth's Newton (solver.py) stops when the residual has fallen by 1e-10 (or below 1e-13 N).
Measured on rod-nhb-s1.5 on the uniform n = 8 grid: at t = 8.2 s a step's residual falls
1.27e-2, 5.1e-6, 1.0e-7, 4.9e-10, 7.7e-12, 1.6e-12 and then stays at 1.31e-12 to 1.34e-12 N
for 25 more iterations, the round-off of its assembly, while the target is 1.27e-12 N: modified
and full Newton both stop there (no decrease left for the line search), so the run raised.

FloorTruth takes such a step where its residual has fallen by FLOOR_RTOL (1e-9: the iterate is
then the converged one to about 1e-9 of the step's correction, far below the 0.2 % that SPEC 10
asks of a truth) and records each step so taken: its time and how far its residual fell. A
step that has not fallen that far raises, as before (a fold does). Every step that converges
in solver.py's Newton is the same, bit for bit: the floor is looked at only where it raised.

Only the cases in FLOOR_CASES take it (solvers/truth/fallbacks.py adds them); their cache key
holds FLOOR_RTOL and this file's code (store.inputs), the other truths' keys are unchanged.
"""

from __future__ import annotations

import dolfinx.fem.petsc

from tissuebench.solvers.truth.solver import Truth

FLOOR_RTOL = 1e-9  # a step stopped by its Newton is taken if its residual fell by this much
FLOOR_CASES: set[str] = set()  # the truth cases that take FloorTruth (fallbacks.py)


class FloorTruth(Truth):
    """Truth whose neo-Hookean step is taken at the residual's round-off floor (above).
    `floor_steps` lists (t in s, residual / its first value) of every step so taken."""

    def __init__(self, *args, **kwargs) -> None:  # Truth's: (problem: Problem)
        super().__init__(*args, **kwargs)
        self.floor_steps: list[tuple[float, float]] = []

    def _newton_solver(self, full: bool) -> dolfinx.fem.petsc.NonlinearProblem:
        problem = super()._newton_solver(full)
        problem.solver.setConvergenceHistory(reset=True)  # the step's first residual norm
        return problem

    def _newton(self) -> None:
        try:
            super()._newton()
        except RuntimeError:
            # solver.py raises after its full Newton alone: the one that failed last
            snes = self._full_newton.solver  # type: ignore[union-attr]
            first = snes.getConvergenceHistory()[0][0]
            x = snes.getSolution()
            f = snes.getFunction()[0]  # type: ignore[index]  # petsc4py: (Vec, function)
            snes.computeFunction(x, f)  # the residual where it stopped; U takes x (solver.py)
            ratio = f.norm() / first
            if not ratio <= FLOOR_RTOL:
                raise
            self.floor_steps.append((float(self.t.value), float(ratio)))
