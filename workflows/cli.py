"""The `tissuebench` command line.

Every subcommand is one module in workflows/ with `add_parser(subparsers)`, which registers its
arguments and sets `func(args)`; it is listed once, with its help line, in
workflows/commands/__init__.py's HELP (which the top-level help reads without importing any
command).

Exit status: 0 done; 2 bad input (UserError, core/errors.py; one line on stderr); 1 the
environment failed (disk full, file system read-only, permission lost; one line); 130
interrupted (SIGINT) and 143 terminated (SIGTERM), one line each, at any moment from start-up
on (core/interrupt.py). In every case the partial output is removed and nothing else is
touched; what a command had still to write is named in the line.
"""

import os
import signal
import sys
from pathlib import Path


def _record(signum, frame):
    """The command line's first handler, before the heavy imports: records a signal, which
    main() raises once MPI is up (core/interrupt.py), instead of a traceback (SIGINT) or
    a silent death (SIGTERM). In force again from the end of the command on, while the
    process ends (`end`): once `finished` is set (command_line's `finally`), a command that
    did not end with a signal's status ends at once with this one's (rank 0's, under
    mpiexec) and one line, which says whether its output is complete."""
    if _record.finished is not None:
        command, rank0, complete = _record.finished
        if not rank0:  # rank 0 says it and sets the status; the others end as they were
            return
        said = "interrupted (SIGINT)" if signum == signal.SIGINT else "terminated (SIGTERM)"
        done = "; its output is complete" if complete else ""
        print(f"{command}: {said} as it ended{done}", file=sys.stderr)
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130 if signum == signal.SIGINT else 143)
    _record.received = _record.received or signum


# function attributes, which mypy does not model: set by name
setattr(_record, "received", 0)
setattr(_record, "finished", None)
if __name__ == "__main__" or Path(sys.argv[0]).name == "tissuebench":  # not when imported
    if not hasattr(signal.getsignal(signal.SIGINT), "received"):  # python -m: once
        signal.signal(signal.SIGINT, _record)
        signal.signal(signal.SIGTERM, _record)

import argparse  # noqa: E402 (after the handlers above)
import errno  # noqa: E402
import gc  # noqa: E402
import importlib  # noqa: E402
import traceback  # noqa: E402
from typing import NoReturn  # noqa: E402

from tissuebench.workflows.commands import HELP  # noqa: E402 (a dict: imports nothing)

# the commands, in the order of the help: one module each, workflows/commands/NAME.py
COMMANDS = [f"tissuebench.workflows.commands.{name}" for name in HELP]

# the launchers' rank variables (MPICH's hydra, Open MPI, PMIx): set under mpiexec
LAUNCHED = ("PMI_RANK", "OMPI_COMM_WORLD_RANK", "PMIX_RANK")


class Parser(argparse.ArgumentParser):
    """argparse with the command line's style of bad input: one line on stderr, from rank 0
    under mpiexec, `tissuebench COMMAND: error: ...`, exit status 2; the usage is on -h. The
    subcommands' parsers are of this class too (add_subparsers takes the parent's)."""

    def error(self, message: str) -> NoReturn:
        mpi = sys.modules.get("mpi4py.MPI")
        if mpi is None or mpi.COMM_WORLD.rank == 0:
            text = " ".join(str(message).split())
            print(f"{self.prog}: error: {text} (usage: {self.prog} -h)", file=sys.stderr)
        sys.exit(2)


def parser(command: str | None = None) -> Parser:
    """The command line's parser: every command's, or only `command`'s when it names one (its
    module alone is imported: the others' imports, matplotlib's among them, took 0.8 s of
    every command's start)."""
    p, sub = top()
    names = [name for name in COMMANDS if name.rsplit(".", 1)[1] == command] or COMMANDS
    for name in names:
        importlib.import_module(name).add_parser(sub)
    return p


def top() -> tuple[Parser, argparse._SubParsersAction]:
    """The top-level parser and its (empty) subparsers."""
    p = Parser(
        prog="tissuebench",
        description="Benchmarks, algorithms and accuracy metrics for fast soft-tissue simulation.",
    )
    return p, p.add_subparsers(dest="command", required=True, metavar="COMMAND")


def listing() -> Parser:
    """The top-level parser with the commands listed from HELP, none of their modules
    imported: its help and its errors are parser()'s, word for word; it parses no command."""
    p, sub = top()
    for name in HELP:
        sub.add_parser(name, help=HELP[name])
    return p


def listed_only(argv: list[str] | None) -> bool:
    """Whether the command line names no command (`tissuebench`, `tissuebench --help`): the
    listing answers it, before MPI and PETSc are loaded. Not under mpiexec, where only rank 0
    says an error (Parser.error, which asks MPI)."""
    words = sys.argv[1:] if argv is None else argv
    commands = {name.rsplit(".", 1)[1] for name in COMMANDS}
    launched = any(name in os.environ for name in LAUNCHED)
    return not launched and not commands.intersection(words)


def named(argv: list[str] | None) -> str | None:
    """The command that the command line names first (sys.argv without argv), or None."""
    words = sys.argv[1:] if argv is None else argv
    return words[0] if words and not words[0].startswith("-") else None


def fault(err: OSError) -> str:
    """One line for an OSError: the file and what failed."""
    if err.errno == errno.ENOSPC:
        reason = "no space left on the device"
    elif err.errno:
        reason = os.strerror(err.errno)
    else:
        reason = (err.strerror or str(err) or type(err).__name__).splitlines()[0][:200]
    where = err.filename if err.filename is not None else None
    return f"{where}: {reason}" if where else reason


def main(argv: list[str] | None = None) -> int:
    """Run the command line `tissuebench argv...` (sys.argv without argv) and return its exit
    status. Run as the command line (not imported), the process also ends here (`end`)."""
    status = command_line(argv)
    if hasattr(signal.getsignal(signal.SIGINT), "finished"):  # _record: the command line
        end(status)
    return status


def end(status: int) -> None:
    """End the process with status now, as the interpreter would but without its teardown of
    every module, which runs in C for 0.5 to 2.5 s here and during which a signal could be
    neither raised nor said (it ended in exit 0, or 2 and 15 without a line, under mpiexec).
    PETSc and MPI are finalized first (every rank), the streams flushed; meanwhile a signal
    is said by _record and ends the process with its status."""
    import atexit
    import gc

    atexit._run_exitfuncs()
    gc.collect()
    from mpi4py import MPI
    from petsc4py import PETSc

    PETSc._finalize()
    if not MPI.Is_finalized():
        MPI.Finalize()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status)


def command_line(argv: list[str] | None = None) -> int:
    if listed_only(argv):  # the help (exit 0) or an error (2): no command is run
        listing().parse_args(argv)
    import petsc4py
    from mpi4py import MPI  # before petsc4py, which needs libmpi loaded

    petsc4py.init([sys.argv[0], "-no_signal_handler"])  # SIGINT and SIGTERM are ours (below)

    # after petsc4py.init: tissuebench.meshes imports DOLFINx, which would start PETSc with its
    # own signal handlers
    from tissuebench.core import interrupt
    from tissuebench.core.errors import UserError
    from tissuebench.workflows.io.output import WriteFailure

    signalled = (KeyboardInterrupt, interrupt.Terminated, interrupt.Interrupted)
    comm = MPI.COMM_WORLD
    restore = interrupt.install(comm)  # takes over a signal recorded by _record meanwhile
    command = "tissuebench"
    ended = False  # the command returned: its output is complete
    succeeded = False
    taken = False  # the command ends with a signal's status (and its line)

    def say(text, alone=False):
        if comm.rank == 0 or alone:
            print(f"{command}: {text}", file=sys.stderr)

    def leave(status):
        """End this rank's job at once when it fails alone (the others would wait for it in
        a collective): mpiexec then ends the others, with no line of its own."""
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(status)

    try:
        with interrupt.deferred():  # start-up: the commands' imports are not cut half-way
            interrupt.guard_jit()
            interrupt.guard_solves()
            args = parser(named(argv)).parse_args(argv)
            command = f"tissuebench {args.command}"
        interrupt.checkpoint(comm)  # a signal during start-up: every rank stops here
        with interrupt.calling_back():  # a signal in a PETSc callback: the signal, not its error
            status = args.func(args) or 0
        ended = True
        interrupt.checkpoint(comm)  # one that no step acted on: never exit 0 after a signal
        succeeded = status == 0
        return status
    except SystemExit:
        raise
    except (UserError, WriteFailure, OSError, *signalled) as caught:
        failure = caught  # an OSError while cleaning up after a failure (a read-only disk):
        while isinstance(failure, OSError) and isinstance(
            failure.__context__, (UserError, WriteFailure, OSError, *signalled)
        ):
            failure = failure.__context__  # the failure is said, not the cleaning up's
        if isinstance(failure, UserError):
            say(f"error: {failure}")
            return 2
        if isinstance(failure, WriteFailure):
            say(f"error: {failure}")
            return 1
        if isinstance(failure, OSError):  # met outside output.collective: on this rank alone?
            say(f"error: {fault(failure)}", alone=True)
            if comm.size > 1:
                leave(1)
            return 1
        signum = interrupt.signal_of(failure)  # acknowledged by restore(), below
        status = interrupt.STATUS[signum]
        taken = True
        if ended:
            say(f"{interrupt.SAID[signum]} as it ended; its output is complete")
        else:
            unwritten = interrupt.unwritten()
            said = f"; not written: {', '.join(unwritten)}" if unwritten else ""
            say(f"{interrupt.SAID[signum]}; partial output removed{said}")
        together = interrupt.raised_together() or isinstance(failure, interrupt.Interrupted)
        if comm.size > 1 and not together:
            leave(status)  # rank 0 alone (no point where all could stop came in time)
        # the signal's traceback holds the interrupted run's frames and their PETSc objects:
        # let go of it here, so that they are destroyed (finally) while PETSc is up, not at
        # exit after PetscFinalize, where one in a reference cycle crashed the process (-11)
        failure = caught = None
        return status
    except BaseException:
        if comm.size > 1:  # one rank failing alone would leave the others waiting forever
            traceback.print_exc()
            sys.stderr.flush()
            comm.Abort(1)
        raise
    finally:
        # No signal is lost from here to the process's end: one that nothing acted on (under
        # mpiexec, after the last checkpoint; raised and swallowed, in a PETSc callback or a
        # __del__; during restore()) is passed on to the handlers restore() puts back, and
        # _record acts on any that comes once `finished` is set. When the command ended with a
        # signal's status (taken), that status and its line stand.
        try:
            left = restore()
        except signalled:  # raised as restore() began, before its first line: it did not run
            left = restore()  # the signal raised and not taken
        first = signal.getsignal(signal.SIGINT)  # _record when run as the command line
        if hasattr(first, "finished") and not taken:
            setattr(first, "finished", (command, comm.rank == 0, succeeded))
            left = left or getattr(first, "received")  # recorded before `finished` was set
        if left and not taken:
            signal.raise_signal(left)  # _record: its line and status, now
        gc.collect()  # the command's objects go while PETSc is up (a signal: _record acts)


if __name__ == "__main__":  # python -m: run the imported module, not a second copy of it
    from tissuebench.workflows.cli import main as cli_main

    sys.exit(cli_main())
