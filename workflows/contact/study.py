"""The contact study (SPEC 12): how much realism our algorithms lose when the needle is a rigid
tool in contact, graded against the contact cases' truth.

For each contact case whose truth is computed: our five algorithms with the case's model on the
paper's N = 20 grid with the default penalty kappa = 10 (explicit ones with the sub-steps their
critical step needs, the penalty counted), then `implicit` alone with kappa = 1, 100 and 1000
(the penalty's share of the loss) and on N = 10 and 40 (the mesh's). Each run is graded against
the truth: E_i (max and time-mean, m^2), the needle force's error (the largest |F - F_truth| over
the steps over the largest |F_truth|), the largest interpenetration (m), and the cost (the run's
wall time, set-up included, per simulated second).

The truth's needle force is the trapezoidal rule's impulse per step averaged over two steps,
F_i = (F_(i-1) + 2 F_i + F_(i+1)) / 4: a stiff penalty makes the rule's contact force alternate
from step to step about its mean (an undamped mode at the step's own frequency; measured on
contact-MP1, N = 16: +-5 N/m about 19 N/m), which this average removes exactly, while it leaves
a smooth force unchanged to second order in h.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

import numpy as np

from tissuebench.metrics.compare import summarize
from tissuebench.metrics.contact import force_error  # SPEC 12's force error (re-exported)
from tissuebench.solvers.truth.cases import CASES
from tissuebench.solvers.truth.samples import TruthSamples
from tissuebench.workflows.io.series import read_on_rank0
from tissuebench.workflows.io.tables import read_rows
from tissuebench.workflows.run.case import Case, run_case

BENCHMARK = "contact"  # the benchmark of SPEC 12's cases
ALGORITHMS = ("implicit", "implicit-lumped", "explicit", "explicit-lumped", "quasi-static")
SIZE = 20  # the paper's grid
KAPPA = 10.0  # SPEC 12's default penalty
KAPPAS = (1.0, 100.0, 1000.0)  # implicit's penalty sweep, beside KAPPA
SIZES = (10, 40)  # implicit's mesh sweep, beside SIZE


def contact_cases() -> list[str]:
    """The truth cases of a benchmark with the needle as contact (SPEC 12)."""
    from tissuebench.meshes import in_contact

    return [case for case, spec in CASES.items() if in_contact(spec[0])]


def label_of(algorithm: str, model: str) -> str:
    """A run's name: its algorithm, `ALGORITHM+MODEL` for a nonlinear model."""
    return algorithm if model == "linear" else f"{algorithm}+{model}"


# --quick: a check of the workflow on small grids to T = 1 s, against the quick truth
QUICK_SIZE, QUICK_KAPPAS, QUICK_SIZES, QUICK_END_TIME = 8, (100.0,), (16,), 1.0


def study_cases(truth_case: str, quick: bool = False) -> list[Case]:
    """The runs of one contact case, as study Cases (workflows/run/case.py); `quick`: the QUICK_
    sizes, penalties and end time."""
    _, material, model, scale, _ = CASES[truth_case]
    implicit = label_of("implicit", model)
    size = QUICK_SIZE if quick else SIZE
    kappas = QUICK_KAPPAS if quick else KAPPAS
    sizes = QUICK_SIZES if quick else SIZES

    def case(size: int, kappa: float, algorithms: tuple[str, ...]) -> Case:
        runs = [(label_of(a, model), a, material, model) for a in algorithms]
        return Case(
            f"{truth_case}-N{size}-kappa{kappa:g}",
            BENCHMARK,
            runs,
            implicit,
            mesh_size=size,
            options={"load_scale": scale, "kappa": kappa},
            substeps="auto",
            description=f"SPEC 12: {truth_case}, N = {size}, kappa = {kappa:g}",
            end_time=QUICK_END_TIME if quick else None,
        )

    cases = [case(size, KAPPA, ALGORITHMS)]
    cases += [case(size, kappa, ("implicit",)) for kappa in kappas]
    cases += [case(n, KAPPA, ("implicit",)) for n in sizes]
    return cases


def impulse_average(force: np.ndarray) -> np.ndarray:
    """The force (steps, 2), N/m, averaged over two steps (F_(i-1) + 2 F_i + F_(i+1)) / 4, the
    first step kept and the last averaged with the one before it."""
    force = np.asarray(force, dtype=float)
    out = force.copy()
    if len(force) > 2:
        out[1:-1] = (force[:-2] + 2 * force[1:-1] + force[2:]) / 4
    if len(force) > 1:
        out[-1] = (force[-2] + force[-1]) / 2
    return out


@dataclass
class TruthForce:
    """A contact truth's needle force (N/m; (steps, 2), averaged: impulse_average) and its own
    relative error, the largest of its differences from the next coarser level, the half step
    and the ten times stiffer penalty (each as force_error) where the truth holds them (a
    truth computed before its half step's force was kept at every half step has no time part:
    sampled at the steps of h, the alternation of that force aliases)."""

    force: np.ndarray
    own_error: float
    parts: dict[str, float]


def truth_force(truth: TruthSamples) -> TruthForce:
    """The needle force of a contact truth, from its hierarchy."""
    info = truth.hierarchy
    levels = [impulse_average(np.asarray(f)) for f in info["force_levels"]]
    finest = levels[-1]
    parts = {"space": force_error(levels[-2], finest)}
    if "half_force_all" in info:  # at every half step: averaged there, then sampled at h
        every = 2 * int(truth.inputs.get("step_divisor", 1))
        half = impulse_average(np.asarray(info["half_force_all"]))
        parts["time"] = force_error(half[::every], finest)
    if "penalty_force_all" in info:  # the 10 k run at the half step, at every half step
        every = 2 * int(truth.inputs.get("step_divisor", 1))
        stiff = impulse_average(np.asarray(info["penalty_force_all"]))[::every]
        half = impulse_average(np.asarray(info["half_force_all"]))[::every]
        parts["penalty"] = force_error(stiff, half)
    elif "penalty_force" in info:  # a truth whose 10 k run was at the step h (before)
        parts["penalty"] = force_error(impulse_average(np.asarray(info["penalty_force"])), finest)
    return TruthForce(finest, max(parts.values()), parts)


def grade(
    truth: TruthSamples | None, folder: Path, force: TruthForce | None, comm: MPI.Comm
) -> list[dict]:
    """One row per run of the case folder: its case, label, kappa, N, E_i max and mean against
    the truth (m^2), force error, interpenetration (m) and cost (s per simulated s). Rows on
    rank 0, [] elsewhere. Collective."""
    from tissuebench.metrics.truth import grade_truth
    from tissuebench.workflows.io.summary import read_case_summary

    summary = read_case_summary(folder) if comm.rank == 0 else None
    summary = comm.bcast(summary, root=0)
    assert summary is not None  # run_case wrote it
    rows = []
    contact = read_rows(folder / "contact.csv") if comm.rank == 0 else []
    for label, run in summary.runs.items():
        (series,) = read_on_rank0(comm, (folder / f"{label}.xdmf", "displacement"))
        curves = grade_truth(truth, series, comm, label=label, surface=False).curves
        if comm.rank != 0:
            continue
        peak, mean = summarize(curves["interior_error"])
        mine = np.array(
            [[float(r["force_x"]), float(r["force_y"])] for r in contact if r["algorithm"] == label]
        )
        assert force is not None and run.contact is not None  # rank 0's, a contact run
        rows.append(
            {
                "case": summary.case,
                "run": label,
                "N": summary.mesh_size,
                "kappa": summary.options["kappa"],
                "status": run.status,
                "substeps": run.substeps,
                "interior_error_max": peak,
                "interior_error_mean": mean,
                "force_error": force_error(mine, force.force) if run.ok else float("nan"),
                "interpenetration_max": run.contact["interpenetration_max"],
                "cost": (run.wall_time_s + run.setup_time_s) / summary.end_time,
            }
        )
    return rows


def run_study(
    truth_case: str, out: Path, comm: MPI.Comm = MPI.COMM_WORLD, log=print, quick: bool = False
) -> list[Path]:
    """Run (or keep, when complete for the same inputs) every case folder of one contact case
    under out/truth_case/. Returns the folders. Collective."""
    folders = []
    for case in study_cases(truth_case, quick):
        folder = out / truth_case / case.name
        run_case(case, folder, comm, log=log)
        folders.append(folder)
    return folders
