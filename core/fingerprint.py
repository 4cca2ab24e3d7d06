"""The fingerprint of a set of inputs: the SHA-256 of their canonical JSON. Every folder's
summary.json carries one (workflows/io/output.py decides from it whether results are those of the
same inputs), the truth cache is keyed by one (solvers/truth/store.py), and compare records
the truth's. Computed here only."""

import hashlib
import json


def fingerprint(inputs: dict) -> str:
    """The SHA-256 of the inputs as canonical JSON (keys sorted, no spaces; NaN allowed), as
    hex."""
    text = json.dumps(inputs, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()
