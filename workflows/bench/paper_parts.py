"""Where a `tissuebench paper` spends its time, from the folder it wrote: each case's phases
(its summary.json's phases_s, s of one core) summed by part of the study and by kind of phase.

The parts: part 1 (the paper's cases and those its claims are judged on, SPEC 4, 5 and 7),
the paper against the truth (SPEC 10) and part 2 (the large-deformation cases, SPEC 8, in
OUT/large-deformation/), each case the study's own (workflows/study/); the other folders of
OUT (results/ holds the leaderboard's, the frontier's, ...) are not read. The kinds: the time
loops (the phases "run ..."), the metrics, the figures, the output (XDMF) and the rest (mesh,
forms). What no case's summary holds (Python's start, the grading against the truth after the
cases, the report) is the paper's wall time less its cases' share of it: on two processes (a
warm paper shares part 2's cases with a second process beside its own) the cases' sum can
exceed the wall time.

`python -m tissuebench.workflows.bench.paper_parts OUT` prints the table of a paper's folder.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

KINDS = ("time loops", "metrics", "figures", "output", "the rest")
PART_1 = "part 1: the paper's cases and claims (SPEC 4, 5, 7)"
TRUTH = "the paper against the truth (SPEC 10)"
PART_2 = "part 2: large deformation (SPEC 8)"


def kind(phase: str) -> str:
    """The kind (one of KINDS) of a phase named as in summary.json's phases_s."""
    if phase.startswith("run "):
        return "time loops"
    return phase if phase in KINDS else "the rest"


def folders(out: Path) -> dict[str, list[Path]]:
    """{part: the folders of its cases in the paper's output `out`} (workflows/study's cases,
    in the order the paper runs them); other folders in `out` are not the paper's."""
    from tissuebench.workflows.study import truth
    from tissuebench.workflows.study.cases import cases, model_cases
    from tissuebench.workflows.study.common import LARGE_DEFORMATION

    return {
        PART_1: [out / c.name for c in cases()],
        TRUTH: [out / c.name for c in truth.cases()],
        PART_2: [out / LARGE_DEFORMATION / c.name for c in model_cases()],
    }


def paper_parts(
    out: Path, parts: dict[str, list[Path]] | None = None
) -> dict[str, dict[str, float]]:
    """{part: {"cases": n, "runs": n, KIND: s, ...}} of the cases' folders of each part
    (default: folders(out)) that hold a summary.json."""
    result: dict[str, dict[str, float]] = {}
    for name, cases in (folders(out) if parts is None else parts).items():
        row = {"cases": 0, "runs": 0, **dict.fromkeys(KINDS, 0.0)}
        for folder in cases:
            if not (folder / "summary.json").exists():
                continue
            summary = json.loads((folder / "summary.json").read_text())
            row["cases"] += 1
            row["runs"] += len(summary.get("runs") or {})
            for phase, seconds in (summary.get("phases_s") or {}).items():
                row[kind(phase)] += seconds
        if row["cases"]:
            result[name] = row
    return result


def table(parts: dict[str, dict[str, float]], wall_s: float | None = None) -> list[str]:
    """The parts' table (markdown lines) with their sum; with the paper's wall time `wall_s`,
    a sentence on the time no case's summary holds."""
    total = {key: sum(row[key] for row in parts.values()) for key in ("cases", "runs", *KINDS)}
    lines = [
        "| part | cases | runs | " + " | ".join(f"{k} s" for k in KINDS) + " | all s | share |",
        "|---|---:|---:|" + "---:|" * (len(KINDS) + 2),
    ]
    whole = sum(total[k] for k in KINDS)
    for name, row in [*parts.items(), ("all the cases", total)]:
        seconds = sum(row[k] for k in KINDS)
        lines.append(
            f"| {name} | {row['cases']:.0f} | {row['runs']:.0f} | "
            + " | ".join(f"{row[k]:.1f}" for k in KINDS)
            + f" | {seconds:.1f} | {seconds / whole if whole else float('nan'):.0%} |"
        )
    if wall_s is not None:
        lines += [
            "",
            f"The whole command took {wall_s:.1f} s of wall time; its cases' phases add up to "
            f"{whole:.1f} s of one core's time ({whole / wall_s:.2f} x the wall time).",
        ]
    return lines


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3):
        sys.exit("usage: python -m tissuebench.workflows.bench.paper_parts OUT [WALL_S]")
    found = paper_parts(Path(sys.argv[1]))
    if not found:
        sys.exit(f"{sys.argv[1]}: no case of the paper's study in it (no CASE/summary.json)")
    print("\n".join(table(found, float(sys.argv[2]) if len(sys.argv) == 3 else None)))
