"""The one exception type for bad input, from every layer.

A mesh, a material, a file to compare, PETSc options, an output folder or a size that cannot
be taken raises UserError (or a subclass that names its layer: MeshError, MaterialError,
InputError, OptionsError, OutputError, LimitError). `tissuebench` turns it into one line on
stderr and exit status 2, in one place (workflows/cli.py). This module imports nothing, so
that every layer can raise it.
"""


class UserError(ValueError):
    """Input that tissuebench cannot take; the message is one line saying what and why."""
