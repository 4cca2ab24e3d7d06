"""The paper report's section on the needle in 3D (SPEC 13, results/README.md): the 3D Hertz
record (`tissuebench hertz --dim 3`, contact/hertz3d.json) and the leaderboard's cylinder boards
(leaderboard.json: every simulator with its own 3D contact and ours, graded against the
axisymmetric truth), from the files in the results folder, where they are. What a simulator
loses, and what to pick at real-time cost, are read off the boards' rows, not written by hand.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

REAL_TIME = 1.0  # s of computing per simulated s: at most this runs in real time


def fmt(x: object) -> str:
    """A number in 3 significant digits ("n/a" for None or NaN)."""
    if not isinstance(x, (int, float)) or not math.isfinite(x):
        return "n/a"
    return f"{x:.3g}"


def _hertz(path: Path) -> list[str]:
    """The Hertz paragraph from hertz3d.json (its half-space values, judged, and the cylinder's
    own)."""
    r = json.loads(path.read_text())
    errors, tolerance = r.get("errors", {}), r.get("tolerance", {})
    said = ", ".join(
        f"{name} {100 * errors[key]:+.2f} % (tolerance {100 * tolerance[key]:g} %)"
        for key, name in (
            ("P_sneddon", "P against Sneddon's exact sphere"),
            ("P_hertz", "P against Hertz"),
            ("a", "a"),
            ("p0", "p0"),
        )
        if key in errors and key in tolerance
    )
    cylinder = r.get("cylinder") or {}
    own = cylinder.get("errors") or {}
    line = (
        f"The 3D Hertz check ([contact/hertz3d.json](contact/hertz3d.json), `tissuebench hertz "
        f"--dim 3`): the capsule pushed {1e3 * r['depth']:g} mm statically into the linear "
        f"{r['material']} cylinder, solved as the axisymmetric truth is. Against the half-space "
        f"laws, on the half-space value (the cylinder scaled by s, fitted in 1/s): {said}; "
        f"{'every law holds' if r.get('holds') else 'not every law holds'}."
    )
    if "P_sneddon" in own:
        line += (
            f" On the benchmark's own cylinder P is {100 * own['P_sneddon']:+.2f} % from "
            "Sneddon's: the finite body (free side, fixed bottom) lowers it, more than SPEC 13's "
            "0.1 % ([contact/hertz3d.png](contact/hertz3d.png))."
        )
    return [line, ""]


def _in_3d(benchmark: object) -> bool:
    """Whether a benchmark poses a rigid tool in 3D (its entry's tool: SPEC 13's capsule)."""
    from tissuebench.meshes import BENCHMARKS

    entry = BENCHMARKS.get(benchmark) if isinstance(benchmark, str) else None
    return entry is not None and entry.tool is not None and entry.tool().dim == 3


def _cases(record: Path) -> list[dict]:
    """The leaderboard's boards that pose a rigid tool in 3D (SPEC 13's cylinder)."""
    cases = json.loads(record.read_text()).get("cases", [])
    return [c for c in cases if _in_3d((c.get("board") or {}).get("benchmark"))]


def _cost(row: dict) -> float | None:
    """A row's cost, s of computing per simulated s (None: not timed)."""
    wall, end = row.get("wall_time_s"), row.get("end_time")
    if not isinstance(wall, (int, float)) or not isinstance(end, (int, float)) or end <= 0:
        return None
    return float(wall) / float(end)


def _truth_max(row: dict) -> float | None:
    value = (row.get("truth") or {}).get("interior_error_max")
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) else None


def _contact(row: dict) -> tuple[str, str]:
    """A row's force error and its interpenetration in mm, as shown."""
    contact = row.get("contact") or {}
    depth = contact.get("interpenetration_max")
    return fmt(contact.get("force_error")), fmt(None if depth is None else 1e3 * depth)


def _table(case: dict) -> list[str]:
    """One board's rows: E_i max against the truth, force error, interpenetration, cost; ranked
    by E_i max, a run that did not finish last."""
    lines = [
        "| run | mesh, dofs | status | E_i max vs truth (m^3) | force error | "
        "interpenetration (mm) | cost (s/s) |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    rows = sorted(  # the finished first, by E_i max; then those that did not finish
        case["rows"],
        key=lambda r: (
            r["status"] != "ok",
            _truth_max(r) is None,
            _truth_max(r) or 0.0,
            r["label"],
        ),
    )
    for r in rows:
        force, depth = _contact(r)
        lines.append(
            f"| {r['label']} | {r['dofs']:,} dofs | {r['status']} | {fmt(_truth_max(r))} | "
            f"{force} | {depth} | {fmt(_cost(r))} |"
        )
    return lines


def _losses(case: dict) -> list[str]:
    """Per outside simulator, its best row (E_i max against the truth) in words, and the row
    to pick at real-time cost."""
    by: dict[str, dict] = {}
    for r in case["rows"]:
        name = r["label"].split(":")[0] if ":" in r["label"] else None
        if name is None or r["status"] != "ok" or _truth_max(r) is None:
            continue
        if name not in by or _truth_max(r) < _truth_max(by[name]):  # type: ignore[operator]
            by[name] = r
    lines = []
    for name, r in sorted(by.items(), key=lambda kv: _truth_max(kv[1]) or 0.0):
        force, depth = _contact(r)
        lines.append(
            f"- {name} (best: {r['label']}): E_i max {fmt(_truth_max(r))} m^3 against the "
            f"truth, force error {force}, the tool {depth} mm inside the tissue at most, "
            f"{fmt(_cost(r))} s per simulated s."
        )
    fast = [r for r in case["rows"] if r["status"] == "ok" and _truth_max(r) is not None]
    fast = [r for r in fast if (_cost(r) or math.inf) <= REAL_TIME]
    if fast:
        best = min(fast, key=lambda r: (_truth_max(r), r["label"]))
        lines += [
            "",
            f"At real-time cost (at most {REAL_TIME:g} s of computing per simulated s, on this "
            f"board's mesh) the smallest E_i max against the truth is {best['label']}'s "
            f"({fmt(_truth_max(best))} m^3, {fmt(_cost(best))} s/s).",
        ]
    return lines


def paper_section(results: Path) -> list[str]:
    """The section "The needle in 3D (SPEC 13)" of results/README.md, from
    results/contact/hertz3d.json and the cylinder boards of results/leaderboard.json; [] when
    neither is there."""
    hertz = results / "contact" / "hertz3d.json"
    record = results / "leaderboard.json"
    cases = _cases(record) if record.is_file() else []
    if not hertz.is_file() and not cases:
        return []
    lines = ["## The needle in 3D (SPEC 13)", ""]
    if hertz.is_file():
        lines += _hertz(hertz)
    if not cases:
        return lines

    def simulators(case: dict) -> int:  # outside simulators with a finished, graded row
        return len({r["label"].split(":")[0] for r in case["rows"] if ":" in r["label"]
                    and r["status"] == "ok" and _truth_max(r) is not None})  # fmt: skip

    # the board that grades the most simulators (on a tie the finest: the main one is the
    # default size, mesh_size None)
    main = max(cases, key=lambda c: (simulators(c), c["board"].get("mesh_size") or math.inf))
    board = main["board"]
    skipped = str(board.get("skip_note") or "")
    lines += [
        f"The capsule pressed into the tissue cylinder, {board['truth']}: every 3D simulator "
        "that poses a rigid tool with its own contact, and ours with the penalty, graded against "
        f"the axisymmetric truth revolved on 32 azimuths (its own E_i max "
        f"{fmt(board.get('truth_band'))} m^3). The force each hands against the truth's: "
        f"[leaderboard/{board['name']}-force.png](leaderboard/{board['name']}-force.png); "
        f"the boards at every mesh size: [leaderboard.md](leaderboard.md)."
        + (f" {skipped[:1].upper()}{skipped[1:]}." if skipped else ""),
        "",
        f"On the board's mesh ({board['name']}), ranked by E_i max against the truth:",
        "",
        *_table(main),
        "",
        "What each simulator loses in 3D contact (its best variant here):",
        "",
        *_losses(main),
        "",
    ]
    return lines
