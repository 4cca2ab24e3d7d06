"""Rigid tools in contact with a benchmark's body (SPEC 12 and 13): one file a tool, one line
in TOOLS. A benchmark's entry builds its tool (meshes/benchmark.py's Entry.tool); every reader
of a tool asks it (tool.py's Tool), and nothing else knows its shape."""

import numpy as np

from tissuebench.meshes.tools.capsule import Capsule
from tissuebench.meshes.tools.half_stadium import HalfStadium
from tissuebench.meshes.tools.tool import Tool

TOOLS: dict[str, type[Tool]] = {
    "half-stadium": HalfStadium,
    "capsule": Capsule,
}


def from_shape(shape: dict) -> Tool:
    """A tool at rest from the export's `contact.shape` block (its kind and radius, m): for a
    reader of an export that measures distances to it at centres it is given."""
    kind = shape.get("kind")
    if kind not in TOOLS:
        raise ValueError(f"unknown tool shape {kind!r}: use one of {', '.join(TOOLS)}")
    dim = TOOLS[kind].dim
    at_rest = np.zeros(dim)
    return TOOLS[kind](
        radius=float(shape["radius"]), c0=(0.0,) * dim, motion=lambda t: (at_rest, at_rest)
    )


__all__ = ["TOOLS", "Capsule", "HalfStadium", "Tool", "from_shape"]
