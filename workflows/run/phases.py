"""The wall time of a command's phases (mesh, forms, each run's loop, output, figures, ...):
where a user's wait goes. Each rank times its own; rank 0's are the ones said and written."""

import time
from collections.abc import Iterator
from contextlib import contextmanager


class Phases:
    """Wall times (s) by phase name, in the order the phases first ran; a phase timed again
    adds to its time (the output of each run adds to "output")."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {}

    @contextmanager
    def timed(self, name: str) -> Iterator[None]:
        """Add the wall time (s) of the block to phase `name`, also when it raises."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.times[name] = self.times.get(name, 0.0) + time.perf_counter() - start


def phase_lines(name: str, times: dict[str, float]) -> list[str]:
    """One line per phase, `NAME: PHASE  T s`, and the phases' sum (wall s)."""
    width = max((len(phase) for phase in times), default=0)
    lines = [f"{name}: {phase:<{width}} {t:7.2f} s" for phase, t in times.items()]
    return lines + [f"{name}: {'all phases':<{width}} {sum(times.values()):7.2f} s"]
