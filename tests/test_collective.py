"""output.collective: rank 0 runs the action, every rank gets its result or raises its error,
and under mpiexec the other ranks wait asleep meanwhile (core/waiting.py). Before, they
waited in a blocking broadcast, in which MPICH polls at full speed: a core per waiting rank for
as long as rank 0 drew figures or wrote reports, taken from the other jobs on the machine."""

import time

from mpi4py import MPI

import pytest

from tissuebench.workflows.io.output import collective

pytestmark = pytest.mark.parallel  # about the ranks: make test runs it under mpiexec -n 2 too

ACTION_SECONDS = 0.5  # rank 0's action: a sleep


def rank0_action() -> int:
    time.sleep(ACTION_SECONDS)
    return MPI.COMM_WORLD.rank


def test_every_rank_gets_rank0s_result_and_the_others_sleep_meanwhile():
    comm = MPI.COMM_WORLD
    comm.Barrier()
    wall, cpu = time.perf_counter(), time.process_time()
    result = collective(comm, rank0_action)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert result == 0  # rank 0's, on every rank
    assert wall >= 0.9 * ACTION_SECONDS  # every rank waited for it
    if comm.rank != 0:  # asleep: polling would have taken about the wall time in CPU
        assert cpu < 0.25 * wall, (cpu, wall)


def test_rank0s_error_is_raised_on_every_rank():
    def fails():
        raise ValueError("rank 0's action failed")

    with pytest.raises(ValueError, match="rank 0's action failed"):
        collective(MPI.COMM_WORLD, fails)


def test_grading_against_the_truth_the_other_ranks_sleep(monkeypatch):
    """grade_truth grades on rank 0 (metrics/truth.py), the other ranks asleep meanwhile."""
    from tissuebench.metrics import truth

    monkeypatch.setattr(truth, "_grade", lambda *args: rank0_action())
    comm = MPI.COMM_WORLD
    comm.Barrier()
    wall, cpu = time.perf_counter(), time.process_time()
    result = truth.grade_truth(object(), object(), comm)  # type: ignore[arg-type]
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert result == 0 and wall >= 0.9 * ACTION_SECONDS  # rank 0's grading, on every rank
    if comm.rank != 0:
        assert cpu < 0.25 * wall, (cpu, wall)
