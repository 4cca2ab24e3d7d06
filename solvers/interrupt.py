"""The old home of the signal handling, kept as an alias: it lives in core/interrupt.py (this
name is that very module, its state shared)."""

import sys

from tissuebench.core import interrupt

sys.modules[__name__] = interrupt
