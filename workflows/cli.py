"""The `tissuebench` command line.

Every subcommand is one module in workflows/ with `add_parser(subparsers)`, which registers its
arguments and sets `func(args)`; it is listed once in COMMANDS below. Bad input raises one of
USAGE_ERRORS and ends as one line on stderr with exit status 2.
"""

import argparse
import importlib
import sys
import traceback

COMMANDS = [
    "tissuebench.workflows.run",
    "tissuebench.workflows.paper",
    "tissuebench.workflows.compare",
    "tissuebench.workflows.mesh",
    "tissuebench.workflows.stability",
    "tissuebench.workflows.convergence",
    "tissuebench.workflows.bench",
]


class UsageError(ValueError):
    """Bad options or input: reported as one line, exit status 2."""


def usage_errors():
    """The exception types that mean 'bad input', from every layer."""
    from tissuebench.meshes.gmshio import MeshError
    from tissuebench.metrics.series import InputError
    from tissuebench.solvers.materials import MaterialError

    return (UsageError, MeshError, MaterialError, InputError)


def parser():
    p = argparse.ArgumentParser(
        prog="tissuebench",
        description="Benchmarks, algorithms and accuracy metrics for fast soft-tissue simulation.")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(name).add_parser(sub)
    return p


def main(argv=None):
    args = parser().parse_args(argv)
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    try:
        return args.func(args) or 0
    except usage_errors() as err:
        if comm.rank == 0:
            print(f"tissuebench {args.command}: error: {err}", file=sys.stderr)
        return 2
    except BaseException:
        if comm.size > 1:  # one rank failing alone would leave the others waiting forever
            traceback.print_exc()
            sys.stderr.flush()
            comm.Abort(1)
        raise


if __name__ == "__main__":  # python -m: run the imported module, so its UsageError is the one raised
    from tissuebench.workflows.cli import main as cli_main

    sys.exit(cli_main())
