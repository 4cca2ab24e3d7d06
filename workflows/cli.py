"""The `tissuebench` command line.

Every subcommand is one module in workflows/ with `add_parser(subparsers)`, which registers its
arguments and sets `func(args)`; it is listed once in COMMANDS below.

Exit status: 0 done; 2 bad input (UserError, workflows/errors.py; one line on stderr); 1 the
environment failed while writing (disk full, permission lost; one line); 130 interrupted
(SIGINT) and 143 terminated (SIGTERM), one line each. In every case the partial output is
removed and nothing else is touched.
"""

import argparse
import importlib
import sys
import time
import traceback

from tissuebench.workflows.errors import UserError

COMMANDS = [
    "tissuebench.workflows.run",
    "tissuebench.workflows.paper",
    "tissuebench.workflows.compare",
    "tissuebench.workflows.mesh",
    "tissuebench.workflows.export",
    "tissuebench.workflows.external",
    "tissuebench.workflows.leaderboard",
    "tissuebench.workflows.sensitivity",
    "tissuebench.workflows.stability",
    "tissuebench.workflows.convergence",
    "tissuebench.workflows.bench",
]


class Parser(argparse.ArgumentParser):
    """argparse with the command line's style of bad input: one line on stderr, from rank 0
    under mpiexec, `tissuebench COMMAND: error: ...`, exit status 2; the usage is on -h. The
    subcommands' parsers are of this class too (add_subparsers takes the parent's)."""

    def error(self, message):
        mpi = sys.modules.get("mpi4py.MPI")
        if mpi is None or mpi.COMM_WORLD.rank == 0:
            text = " ".join(str(message).split())
            print(f"{self.prog}: error: {text} (usage: {self.prog} -h)", file=sys.stderr)
        sys.exit(2)


def parser():
    p = Parser(
        prog="tissuebench",
        description="Benchmarks, algorithms and accuracy metrics for fast soft-tissue simulation.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(name).add_parser(sub)
    return p


def main(argv=None):
    from mpi4py import MPI  # before petsc4py, which needs libmpi loaded
    import petsc4py

    petsc4py.init([sys.argv[0], "-no_signal_handler"])  # SIGINT and SIGTERM are ours (below)
    args = parser().parse_args(argv)

    from tissuebench.solvers import interrupt
    from tissuebench.workflows.output import WriteFailure

    comm = MPI.COMM_WORLD
    restore = interrupt.install(comm)  # SIGINT and SIGTERM: see solvers/interrupt.py

    def say(text):
        if comm.rank == 0:
            print(f"tissuebench {args.command}: {text}", file=sys.stderr)

    try:
        return args.func(args) or 0
    except UserError as err:
        say(f"error: {err}")
        return 2
    except WriteFailure as err:
        say(f"error: {err}")
        return 1
    except (KeyboardInterrupt, interrupt.Terminated) as signalled:
        status = 130 if isinstance(signalled, KeyboardInterrupt) else 143
        name = "interrupted (SIGINT)" if status == 130 else "terminated (SIGTERM)"
        say(f"{name}; partial output removed")
        if comm.size > 1 and not interrupt.raised_together():
            # rank 0 alone (no step came in time): the others wait in a collective for it.
            # MPI_Abort ends them all; the pause lets mpiexec pass the line above on first.
            sys.stderr.flush()
            time.sleep(1.0)
            comm.Abort(status)
        return status
    except BaseException:
        if comm.size > 1:  # one rank failing alone would leave the others waiting forever
            traceback.print_exc()
            sys.stderr.flush()
            comm.Abort(1)
        raise
    finally:
        restore()


if __name__ == "__main__":  # python -m: run the imported module, not a second copy of it
    from tissuebench.workflows.cli import main as cli_main

    sys.exit(cli_main())
