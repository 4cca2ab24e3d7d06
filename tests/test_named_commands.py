"""Every `tissuebench` command that a document of ours names is one the command line takes
(issues 43 and 44: leaderboard.md told users to run `tissuebench truth rod-nh-s3`, which the
CLI refused), and every committed leaderboard figure is the one today's code draws.

The commands are read from README.md, meshes/BENCHMARKS.md, results/ (its Markdown and the
leaderboard page): those in `code spans`, in ``` blocks and in parentheses, "(tissuebench
truth rod: about 2 min)". Each is parsed by the command line's own parser, which checks the
names it is given (truth cases, compare's truth:CASE, benchmarks, algorithms, ...), so that a
command that would be refused for a name fails here; placeholders (CASE, DIR, ...) take a
value of their kind first. The README's command block is also run (test_readme_commands.py).
"""

import re
import shlex
from pathlib import Path

import pytest

from tissuebench.workflows import cli

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [
    ROOT / "README.md",
    ROOT / "meshes" / "BENCHMARKS.md",
    *sorted((ROOT / "results").rglob("*.md")),
    ROOT / "results" / "leaderboard" / "index.html",
]
# a placeholder -> a value of its kind
PLACEHOLDERS = {
    "CASE": "rod",
    "CANDIDATE": "mine.xdmf",
    "DIR": "out",
    "OUT": "out",
    "SIMULATOR": "calculix",
    "BENCHMARK": "rod",
    "FILE.toml": "my.toml",
    "FILE.csv": "force.csv",
    "NAME": "mine",
    "S": "1.5",
    "N": "2",
    "K": "1",
}
SPANS = (
    re.compile(r"`(tissuebench [^`]+)`"),  # a code span
    re.compile(r"\((tissuebench [a-z][^():]*?)(?:\)|: )"),  # "(tissuebench truth rod)"
)
BLOCK = re.compile(r"```[a-z]*\n(.*?)```", re.S)
LINE = re.compile(r"^\s*(?:mpiexec -n \d+ )?(tissuebench [^#\n]+)", re.M)  # a line of a block


def named(text: str) -> set[str]:
    """The tissuebench command lines in a document's text (continuation lines joined)."""
    text = text.replace("\\\n", " ").replace("\\`", "`").replace("\\_", "_")  # Markdown escapes
    out = set()
    blocks = "\n".join(block.group(1) for block in BLOCK.finditer(text))
    matches = [m for span in SPANS for m in span.finditer(text)] + list(LINE.finditer(blocks))
    for match in matches:
        line = match.group(1).split("&&")[0].split(" # ")[0].strip().rstrip(".,;")
        out.add(" ".join(line.split()))
    return out


def argv_of(command: str) -> list[str]:
    """A named command's argv after `tissuebench`, placeholders and "[...]" parts replaced."""
    command = re.sub(r"\[[^\]]*\]", " ", command)
    words = shlex.split(command)[1:]
    return [PLACEHOLDERS.get(w, w.replace("truth:CASE", "truth:rod")) for w in words]


DOCUMENTS = [d for d in DOCUMENTS if d.is_file()]
COMMANDS = sorted({c for doc in DOCUMENTS for c in named(doc.read_text())})


def test_documents_name_commands():
    """The reading above finds the commands (a reader that finds none checks nothing)."""
    assert len(COMMANDS) > 30
    assert "tissuebench leaderboard --out results" in COMMANDS


@pytest.mark.serial
@pytest.mark.parametrize("command", COMMANDS)
def test_named_command_is_taken(command, capsys):
    parser = cli.parser()
    argv = argv_of(command)
    if len(argv) == 1:  # the command itself named ("`tissuebench compare` grades ...")
        assert argv[0] in parser._subparsers._group_actions[0].choices, command
        return
    try:
        parser.parse_args(argv)
    except SystemExit as stop:
        said = capsys.readouterr().err.strip()
        if "the following arguments are required" in said:
            return  # a mention of a command, its other arguments the user's (--out DIR)
        where = [
            d.relative_to(ROOT)
            for d in DOCUMENTS
            if d.is_file() and command in named(d.read_text())
        ]
        pytest.fail(
            f"{command!r} (named in {', '.join(map(str, where))}) is refused: {said} "
            f"(exit {stop.code})"
        )


@pytest.mark.serial
def test_refused_name_is_caught():
    """The check can fail: a command naming a case without a truth, and compare against one."""
    parser = cli.parser()
    for argv in (["truth", "rod-nh-s3"], ["compare", "truth:rod-nh-s3", "x.xdmf", "--out", "o"]):
        with pytest.raises(SystemExit):
            parser.parse_args(argv)
