"""This machine in a line, as the bench's reports state it, and the load of other processes
during a measurement (units: cores, seconds)."""

from __future__ import annotations

import math
import os
import platform
import resource
import time


def machine_description() -> str:
    """'CPU model, N cores, M GiB' of this machine."""
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return f"{cpu}, {os.cpu_count()} cores, {mem:.0f} GiB"


# The machine is shared: a measurement during which other processes kept more than this many
# cores busy on average (beside the worker's own) is noisy; measure.py reruns its size once,
# and the report says so in the rows that stay noisy.
LOAD_LIMIT = 0.25  # cores


def busy_seconds() -> float:
    """CPU seconds that all cores have spent busy (not idle or waiting for I/O) since boot,
    from /proc/stat; nan where it cannot be read."""
    try:
        with open("/proc/stat") as f:
            fields = [int(x) for x in f.readline().split()[1:]]
    except (OSError, ValueError):
        return math.nan
    idle = sum(fields[3:5])  # idle, iowait
    return (sum(fields[:8]) - idle) / os.sysconf("SC_CLK_TCK")  # up to steal: no guests


def children_seconds() -> float:
    """CPU seconds (user + system) of this process's finished and waited-for descendants."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


class LoadMeter:
    """The load of other processes during a measurement that runs in child processes (waited
    for before stop()): the cores they kept busy on average, (all cores' busy time - the
    children's CPU time) / wall time, and the 1-minute load average at its end."""

    def __init__(self) -> None:
        self._busy, self._children = busy_seconds(), children_seconds()
        self._start = time.perf_counter()

    def stop(self) -> dict[str, float]:
        """{"others_cores": cores busy with other processes (nan where /proc/stat cannot be
        read), "loadavg_1min", "wall_s"} since construction."""
        wall = time.perf_counter() - self._start
        busy = busy_seconds() - self._busy
        own = children_seconds() - self._children
        others = max(0.0, busy - own) / wall if wall > 0 else math.nan
        return {"others_cores": others, "loadavg_1min": os.getloadavg()[0], "wall_s": wall}


def noisy(load: dict | None) -> bool:
    """Whether a measurement's load (LoadMeter.stop()) exceeded LOAD_LIMIT."""
    return load is not None and load.get("others_cores", 0.0) > LOAD_LIMIT
