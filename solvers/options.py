"""A user's PETSc options (`--petsc`): parsed, put in PETSc's database, and checked before
anything runs, against the options prefixes of every integrator in the registry (so this
module sits above the registry, not in linear.py, which the integrators import).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING

from petsc4py import PETSc

from tissuebench.solvers import ALGORITHMS
from tissuebench.solvers.linear import (
    MASS_SOLVER,
    SOLVERS,
    OptionsError,
    petsc_defaults,
    petsc_message,
)
from tissuebench.solvers.nonlinear import NEWTON

if TYPE_CHECKING:
    from mpi4py import MPI


def parse_petsc_options(text: str) -> list[tuple[str, str]]:
    """The (name without its dash, value) pairs of options such as "-implicit_ksp_type cg
    -implicit_ksp_monitor" ("" for an option without a value); OptionsError if malformed."""
    words = text.split()
    pairs = []
    i = 0
    while i < len(words):
        if not words[i].startswith("-") or words[i].strip("-") == "":
            raise OptionsError(
                f"PETSc options: expected -name [value], got {words[i]!r} in {text!r}"
            )
        key = words[i].lstrip("-")
        if i + 1 < len(words) and not words[i + 1].startswith("-"):
            pairs.append((key, words[i + 1]))
            i += 2
        else:
            pairs.append((key, ""))
            i += 1
    return pairs


def set_petsc_options(text: str) -> None:
    """Put options such as "-implicit_ksp_type cg -implicit_pc_type gamg" in PETSc's database."""
    opts = PETSc.Options()
    for key, value in parse_petsc_options(text):
        opts[key] = value  # type: ignore[index]  # petsc4py's stubs lack Options.__setitem__


def prefixes() -> list[str]:
    """The options prefixes of tissuebench's solvers: one per integrator (`implicit_`,
    `implicit_lumped_`, ...; its step solve and, for a nonlinear model, its Newton solver),
    and that prefix followed by `mass_` for the initial acceleration."""
    steps = [name.replace("-", "_") + "_" for name in ALGORITHMS]
    return steps + [p + "mass_" for p in steps]


def prefix_of(key: str) -> str | None:
    """The longest of prefixes() that the option name `key` starts with, or None."""
    found = [p for p in prefixes() if key.startswith(p) and len(key) > len(p)]
    return max(found, key=len) if found else None


@contextmanager
def silent_stdout() -> Iterator[None]:
    """Standard output (file descriptor 1, and Python's sys.stdout, which petsc4py may route
    PETSc's printing to: monitors, views) is dropped while the block runs; C's buffers are
    flushed on either side."""
    import ctypes
    import io
    import os
    import sys
    from contextlib import redirect_stdout

    libc = ctypes.CDLL(None)
    sys.stdout.flush()
    libc.fflush(None)
    saved = os.dup(1)
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        with redirect_stdout(io.StringIO()):
            yield
    finally:
        libc.fflush(None)
        os.dup2(saved, 1)
        os.close(saved)
        os.close(null)


def _try_prefix(prefix: str, solver: str, keys: list[str], comm) -> None:
    """Set up and run a KSP under `prefix` on a small SPD matrix (tridiagonal, 4 rows per
    rank), with the defaults that the run's solver takes there, and a Newton solver (SNES)
    if `keys` hold SNES options: PETSc reads and checks the options as in a run."""
    if prefix.endswith("mass_"):
        defaults = MASS_SOLVER
    else:  # K alone (quasi-static) takes gamg where the others take cg (step_operator)
        chosen = "gamg" if solver == "cg" and prefix == "quasi_static_" else solver
        defaults = SOLVERS[chosen]
    n = 4
    A = PETSc.Mat().createAIJ(((n, None), (n, None)), nnz=(3, 1), comm=comm)  # type: ignore[arg-type]  # petsc4py's stubs: None (PETSC_DECIDE) is a size
    start, end = A.getOwnershipRange()
    size = A.getSize()[0]
    for i in range(start, end):
        A.setValue(i, i, 4.0)
        for j in (i - 1, i + 1):
            if 0 <= j < size:
                A.setValue(i, j, -1.0)
    A.assemble()
    A.setOption(PETSc.Mat.Option.SPD, True)  # type: ignore[arg-type]  # petsc4py's stubs: its enum constants are ints
    b, x = A.createVecs()  # type: ignore[misc]  # petsc4py's stubs: both without a side
    b.set(1.0)
    objects = [A, b, x]
    try:
        with petsc_defaults(prefix, defaults), silent_stdout():  # no monitor of this dry run
            ksp = PETSc.KSP().create(comm)
            objects.append(ksp)
            ksp.setOptionsPrefix(prefix)
            ksp.setOperators(A)
            ksp.setFromOptions()
            ksp.setUp()
            ksp.solve(b, x)
        if any(key[len(prefix) :].startswith("snes_") for key in keys):
            with petsc_defaults(prefix, NEWTON):
                snes = PETSc.SNES().create(comm)
                objects.append(snes)
                snes.setOptionsPrefix(prefix)
                snes.setFromOptions()
    finally:
        for obj in objects:
            obj.destroy()


def check_petsc_options(text: str, solver: str, comm: MPI.Comm | None = None) -> None:
    """Put the --petsc options in PETSc's database and check them before anything runs
    (collective; the same OptionsError, one line, on every rank): each must be under one of
    prefixes() (global options such as -log_view and -help are not taken: tissuebench passes
    solver options only); PETSc must accept each value (a type it has, a number where it
    wants one) and find each solver package (-..._pc_factor_mat_solver_type pastix where
    PETSc was built without it); and each must be read by a solver set up as the run sets
    it up with `solver` (an option that nothing reads, a misspelt name or a tolerance of a
    direct solve, would be ignored)."""
    from mpi4py import MPI

    comm = comm or MPI.COMM_WORLD
    pairs = parse_petsc_options(text)
    outside = [f"-{key}" for key, _ in pairs if prefix_of(key) is None]
    if outside:
        steps = [p for p in prefixes() if not p.endswith("mass_")]
        raise OptionsError(
            f"PETSc option(s) {', '.join(outside)}: not under a solver's prefix "
            f"({', '.join(steps)}, each optionally followed by mass_); --petsc takes solver "
            "options only, not global ones such as -log_view or -help"
        )
    set_petsc_options(text)
    groups: dict[str, list[str]] = {}
    for key, _ in pairs:
        found = prefix_of(key)
        assert found is not None  # every key is under a prefix: checked above
        groups.setdefault(found, []).append(key)
    error = None
    for prefix, keys in groups.items():
        try:
            _try_prefix(prefix, solver, keys, comm)
        except OptionsError as err:
            error = str(err)
        except PETSc.Error as err:
            error = f"PETSc options for prefix {prefix!r}: {petsc_message(err)}"
        if error:
            break
    error = next((e for e in comm.allgather(error) if e), None)
    unread = [f"-{key}" for key, _ in pairs if not PETSc.Options().used(key)]
    if unread and not error:
        error = (
            f"PETSc option(s) {', '.join(unread)}: read by no solver with --solver {solver} "
            "(a misspelt name, or an option of another solver type); PETSc would ignore them"
        )
    if error:
        for key, _ in pairs:  # out of the database: PETSc would list them as unused at exit
            PETSc.Options().delValue(key)
        raise OptionsError(error)
