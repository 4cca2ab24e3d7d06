"""The top-level help is fast (issue 59, item 7a): `tissuebench --help` (and `tissuebench` with
no command) took 1.5-3 s, parser() importing every command's module (DOLFINx, matplotlib,
PETSc) to list the commands. Now the list comes from commands.HELP, no command imported, and says
word for word what the modules' own parsers say; a command's help and run are as before."""

import argparse
import contextlib
import io
import subprocess

import pytest
from helpers import job

from tissuebench.workflows import cli

HEAVY = ("mpi4py", "petsc4py", "dolfinx", "matplotlib", *cli.COMMANDS)

# `tissuebench ARGS...` as the installed command runs it; prints the heavy modules it loaded
LOADED = """
import sys
sys.argv[0] = "tissuebench"
from tissuebench.workflows import cli
try:
    cli.main(sys.argv[1:])
finally:
    print("loaded:", sorted(m for m in {heavy!r} if m in sys.modules), flush=True)
"""


def said(p: argparse.ArgumentParser, argv: list[str]) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of parsing argv with p."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        with pytest.raises(SystemExit) as ended:
            p.parse_args(argv)
    return ended.value.code, out.getvalue(), err.getvalue()


def test_the_listing_names_every_command_with_its_modules_help_line():
    sub = next(a for a in cli.parser()._actions if isinstance(a, argparse._SubParsersAction))
    own = {action.dest: action.help for action in sub._choices_actions}
    assert own == cli.HELP
    assert list(own) == list(cli.HELP)  # in the same order


@pytest.mark.parametrize("argv", [["--help"], ["-h"], [], ["bogus"], ["-x"]])
def test_the_listing_says_what_the_full_parser_says(argv):
    assert said(cli.listing(), argv) == said(cli.parser(), argv)


@pytest.mark.serial  # drives the command line in subprocesses
@pytest.mark.parametrize("argv, status", [(["--help"], 0), ([], 2)])
def test_top_level_help_imports_no_command(argv, status):
    cmd, env = job(["-c", LOADED.format(heavy=HEAVY), *argv])
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == status, done.stderr[-2000:]
    assert done.stdout.splitlines()[-1] == "loaded: []", done.stdout[-2000:]
    if status == 0:
        assert "run one benchmark with the chosen algorithms" in done.stdout
    else:
        assert done.stderr == (
            "tissuebench: error: the following arguments are required: COMMAND "
            "(usage: tissuebench -h)\n"
        )


@pytest.mark.serial
def test_a_commands_help_is_its_own():
    """`tissuebench compare --help` still builds compare's parser: its options are listed."""
    cmd, env = job(["-c", LOADED.format(heavy=HEAVY), "compare", "--help"])
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("usage: tissuebench compare")
    assert "tissuebench.workflows.commands.compare" in done.stdout.splitlines()[-1]
