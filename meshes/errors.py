"""The old home of UserError, kept as a re-export: it lives in core/errors.py."""

from tissuebench.core.errors import UserError

__all__ = ["UserError"]
