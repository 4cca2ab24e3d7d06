"""The Python API, `import tissuebench` (the package's __init__, workflows/package/, re-exports
these names): the command line's export and compare, called with arrays instead of files.

- `export_case(benchmark, out, ...)`: `tissuebench export BENCHMARK --out OUT.json` (the JSON
  and, beside it, our reference's series OUT.reference.xdmf), returning the benchmark as
  arrays: the `Exported` of workflows/io/exported.py (nodes m, cells, node_sets, motions u, v,
  a per t_i, gravity m/s^2, material, h and times s, truth case). `read_case(path)` reads an
  export's JSON back into the same `Exported`.
- `read_series(path)`: a displacement series file (.xdmf, .pvd, .frd, .dat) as arrays
  (metrics.series.Series: points m, cells, cell_type, times s, displacements m).
- `grade(reference, points, cells, cell_type, times, displacements, out=...)`: writes the
  arrays as an XDMF series (`series`, default OUT.xdmf beside the folder OUT) and grades that
  file with `tissuebench compare REFERENCE SERIES --out OUT` (workflows/grading.compare, the
  command's own path): the same compare folder, so that OUT under
  results/leaderboard/CASE/user/ is a user's row of the leaderboard. Returns the numbers
  compare wrote (`Graded`). Compare computes no error budget: the leaderboard does, when it
  grades the row against the truth with our implicit on the row's mesh.

Every function is collective over `comm` (rank 0 writes) and raises a UserError (one line)
for bad input.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from mpi4py import MPI

import numpy as np
from numpy.typing import ArrayLike

from tissuebench.core.errors import UserError
from tissuebench.metrics.series import Series, series_of
from tissuebench.workflows.io.exported import Exported, ExportError, read_json
from tissuebench.workflows.io.series import read_series as _read_series

FIELD = "displacement"  # the point field of the series grade() writes


def read_case(path: str | Path) -> Exported:
    """The benchmark an export's JSON poses (`tissuebench export ... --out PATH`), as arrays:
    nodes (N, d) m, cells (C, 4 or 8) VTK order, node_sets, motions {set: (u m, v m/s, a
    m/s^2), each (steps + 1, d)}, gravity (d,) m/s^2, h s, times (steps + 1,) s, material (Pa,
    kg/m^3, 1/s, s), model, truth. InputError (one line) for a file that is not one."""
    return read_json(path)


def export_case(
    benchmark: str,
    out: str | Path,
    *,
    material: str | None = None,
    model: str = "linear",
    mesh_size: int | None = None,
    dt: float | None = None,
    end_time: float | None = None,
    plane: str | None = None,
    reference: bool = True,
    force: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
    **options: float,
) -> Exported:
    """`tissuebench export BENCHMARK --out OUT` (OUT a .json), with its options as keywords:
    material (MP1, MP2, MP3 or a .toml file; default the benchmark's), model (one elastic
    model, default linear), mesh_size, dt (h, s; default 1/30), end_time (T, s; default 10),
    plane ("strain" or "stress", 2D only) and the benchmark's own options (load_scale,
    needle_width in m, kappa). Writes OUT and, unless `reference` is False, our implicit's
    series beside it (OUT-stem.reference.xdmf + .h5, the reference that grade() takes);
    `force` replaces files of an earlier export. Returns the case as arrays (read_case of
    OUT) on every rank. Collective."""
    from tissuebench.meshes import BENCHMARKS, get_entry
    from tissuebench.workflows.compare.posing import export
    from tissuebench.workflows.io.output import collective
    from tissuebench.workflows.run.checks import posed

    out = Path(out)
    if out.suffix.lower() != ".json":
        raise ExportError(f"export_case writes a .json, got out={str(out)!r}: name a .json file")
    known = {option for entry in BENCHMARKS.values() for option in entry.options}
    unknown = sorted(set(options) - known)
    if unknown:
        raise ExportError(
            f"export_case: unknown option {unknown[0]!r}; the benchmarks' options are "
            f"{', '.join(sorted(known))}"
        )
    takes = get_entry(benchmark).options  # MeshError (one line) for an unknown benchmark
    if set(options) - set(takes):
        raise ExportError(
            f"export_case: {benchmark} takes no option {sorted(set(options) - set(takes))[0]!r} "
            f"(its options: {', '.join(takes) or 'none'})"
        )
    text = {k: None if v is None else str(v) for k, v in (("dt", dt), ("end_time", end_time))}
    bench = posed(
        argparse.Namespace(
            benchmark=benchmark,
            material=material,
            models=model,
            mesh_size=mesh_size,
            plane=plane,
            cell=None,
            mesh=None,
            **text,
            **options,
        ),
        BENCHMARKS,
    )
    export(
        bench.benchmark,
        "json",
        out,
        mesh_size=bench.mesh_size,
        options=bench.options,
        material=bench.material,
        model=bench.model,
        h=bench.h,
        steps=bench.steps,
        plane=bench.plane,
        reference=reference,
        force=force,
        comm=comm,
    )
    return collective(comm, lambda: read_json(out))


def read_series(path: str | Path, field: str | None = None) -> Series:
    """The displacement series in a file (.xdmf with .h5, .pvd of .vtu, CalculiX .frd or .dat),
    as compare reads it: `points` (n, d) m, `cells` (VTK order), `cell_type`, `times` (steps,)
    s, `displacements` [(n, d) m per step]; `field` the point field (default: the first of
    displacement, u, U, ... the file holds). InputError (one line) for a file that cannot be
    graded. Reads on the calling rank only."""
    return _read_series(path, field)


@dataclass
class Graded:
    """What grade() wrote, read back from the compare folder `out` (rank 0's, on every rank).

    `metrics`: the run's numbers in summary.json: for each metric of SPEC 6, "<key>_max" and
    "<key>_mean" over steps 1..N (relative_error E_n and surface_error E_s dimensionless,
    interior_error E_i in m^2 in 2D and m^3 in 3D; interior_error_nodal its nodal form; None
    where nothing was graded), with a contact reference also force_error (1; None without a
    needle force) and interpenetration_max (m). `times` (s) and `curves` {key: value per
    step}: metrics.csv. `lines`: compare's one-line summaries as it prints them (the notes on
    how the series were read first). `summary`: summary.json whole. `series`: the XDMF file
    graded. `reference_diverged_step`: the step at which the reference diverged (nothing from
    it on is graded; the command's exit status 3), None when it did not."""

    out: Path
    series: Path
    label: str
    metrics: dict[str, float | None]
    times: np.ndarray
    curves: dict[str, np.ndarray]
    lines: dict[str, str] = field(default_factory=dict)
    summary: dict = field(default_factory=dict)
    reference_diverged_step: int | None = None


def grade(
    reference: str | Path,
    points: ArrayLike,
    cells: ArrayLike,
    cell_type: str,
    times: ArrayLike,
    displacements: ArrayLike,
    *,
    out: str | Path,
    label: str | None = None,
    wall_time: float | None = None,
    series: str | Path | None = None,
    needle_force: str | Path | None = None,
    force: bool = False,
    comm: MPI.Comm = MPI.COMM_WORLD,
) -> Graded:
    """Grade a simulation given as arrays, as `tissuebench compare REFERENCE SERIES --out OUT
    --label LABEL --wall-time WALL_TIME [--needle-force FILE] [--force]` does.

    `reference`: a reference series file (an export's OUT.reference.xdmf, a run's .xdmf) or
    "truth:CASE" (SPEC 10's truth, computed once and cached). The simulation: `points` (n, d)
    m, d = 2 or 3; `cells` (C, k) node indices in VTK order of `cell_type` (triangle,
    quadrilateral, tetrahedron or hexahedron, first order; its own mesh of the body or the
    export's); `times` (steps,) s, t_i = i h from t_0 = 0 (or from t_1 = h); `displacements`
    (steps, n, d) m. `label` names the run (default: the name of `out`), `wall_time` its total
    wall time in s, setup included (the leaderboard ranks by it), `needle_force` a contact
    case's force CSV (time s, force_x, force_y N/m).

    The arrays are written to `series` (.xdmf + .h5; default OUT.xdmf beside the folder OUT),
    which the compare folder names and the leaderboard grades again: keep it there. Same
    arrays again: the file is kept and compare skips the complete folder; other arrays over an
    existing file: refused unless `force`, which replaces both. Returns Graded. Collective."""
    from tissuebench.workflows.compare.grading import GradingError, check_label, check_wall_time
    from tissuebench.workflows.compare.grading import compare as compare_files
    from tissuebench.workflows.io.output import collective

    out = Path(out)
    if not out.name:
        raise GradingError(f"out={str(out)!r}: name the compare folder, for example out='mine'")
    path = Path(series) if series is not None else out.parent / f"{out.name}.xdmf"
    if path.suffix.lower() != ".xdmf":
        raise GradingError(f"series={str(path)!r}: the series is written as XDMF: name a .xdmf")
    label = out.name if label is None else label
    check_label(label)
    wall = check_wall_time(wall_time)
    # checked as compare checks a file it reads (one line naming the problem), on the arrays
    points = real_array("points", points, 2, "(n, d), m")
    cells = real_array("cells", cells, 2, "(C, k) node indices", whole=True)
    times = real_array("times", times, 1, "(steps,), s")
    values = real_array("displacements", displacements, 3, "(steps, n, d), m per node and step")
    given = series_of(path, FIELD, points, cells, cell_type, times, list(values))
    # the compare folder checked before anything is written beside it (the red team: out= a
    # user's folder of notes, a file, or the clone's results/ got the series and a manifest)
    collective(comm, lambda: check_compare_folder(out), out)
    collective(comm, lambda: place_series(given, path, force), path)
    lines = compare_files(
        reference,
        path,
        out,
        comm=comm,
        label=label,
        wall_time=wall,
        force=force,
        needle_force=needle_force,
    )
    return collective(comm, lambda: read_graded(out, path, label, lines))


def real_array(
    name: str, value: ArrayLike, ndim: int, shape: str, whole: bool = False
) -> np.ndarray:
    """`value` as a float64 array of `ndim` dimensions (its `shape` in words, for the message;
    whole numbers, as int64, for `whole`); GradingError, one line, for strings or objects,
    complex numbers, numbers beyond float64, another number of dimensions, or (whole) numbers
    with a fraction."""
    from tissuebench.workflows.compare.grading import GradingError

    try:
        array = np.asarray(value)
    except (TypeError, ValueError, OverflowError) as err:
        raise GradingError(f"{name}: not an array of numbers ({err})") from None
    if array.dtype.kind not in "biuf":
        kind = {"c": "complex numbers", "O": "objects (or integers beyond float64)"}.get(
            array.dtype.kind, f"{array.dtype} values"
        )
        raise GradingError(f"{name}: {kind}, not real numbers")
    if array.ndim != ndim:
        raise GradingError(f"{name} of shape {array.shape}: expected {shape}")
    array = array.astype(np.float64)
    if not np.isfinite(array).all() and (whole or name != "displacements"):
        raise GradingError(f"{name}: a value is not finite")
    if whole:
        if (array != np.round(array)).any():
            raise GradingError(f"{name}: a node index is not a whole number")
        return array.astype(np.int64)
    return array


def check_compare_folder(out: Path) -> None:
    """Refuse (OutputError, one line) a compare folder that cannot be ours before anything is
    written: not a folder, or one that holds anything but a compare folder of ours (a user's
    notes, a run's or the study's outputs such as results/). Rank 0."""
    from tissuebench.workflows.io.output import OutputError, check_foreign, resolve
    from tissuebench.workflows.io.summary import kind_of, read_summary

    path = resolve(out)
    if not path.is_dir() or not any(path.iterdir()):
        return  # new or empty: compare makes it
    summary = read_summary(path)
    if summary is None or kind_of(summary) != "compare":
        raise OutputError(
            f"{out}: holds files that are not a compare folder of ours; name a new or empty "
            "folder for out="
        )
    check_foreign(path)


def place_series(given: Series, path: Path, force: bool) -> None:
    """Write the checked series to path (.xdmf + .h5) as a run's series is written
    (io/xdmf.write_series), listed in its folder's manifest; kept when the files hold it
    already. Rank 0. GradingError for other files there without force; OutputError for files
    that tissuebench did not write."""
    from tissuebench.workflows.compare.grading import GradingError
    from tissuebench.workflows.io.output import PREFIX, write_set
    from tissuebench.workflows.io.xdmf import write_series

    pad = 3 - given.dim
    points = np.pad(given.points, ((0, 0), (0, pad)))
    values = np.pad(np.asarray(given.displacements), ((0, 0), (0, 0), (0, pad)))
    files = [path, path.with_suffix(".h5")]
    path.parent.mkdir(parents=True, exist_ok=True)
    staging = path.parent / f"{PREFIX}series-{path.name}"
    staging.mkdir(exist_ok=True)
    try:
        staged = staging / path.name
        write_series(staged, ((points, given.cells, given.cell_type), {FIELD: values}), given.times)
        new = [staged, staged.with_suffix(".h5")]
        if all(f.is_file() for f in files) and all(
            f.read_bytes() == s.read_bytes() for f, s in zip(files, new, strict=True)
        ):
            return  # the same series: kept, so that compare finds its inputs unchanged
        if any(f.exists() for f in files) and not force:
            raise GradingError(
                f"{path} holds another series: force=True replaces it (and regrades the "
                "compare folder), or name another with series=..."
            )
        write_set({f: moved(s) for f, s in zip(files, new, strict=True)})
    finally:
        for f in staging.iterdir():
            f.unlink()
        staging.rmdir()


def moved(staged: Path) -> Callable[[Path], object]:
    """write_set's writer of a file staged already: moves it to the temporary name given."""
    return lambda tmp: staged.replace(tmp)


def read_graded(out: Path, series: Path, label: str, lines: dict[str, str]) -> Graded:
    """The Graded of the compare folder `out` (summary.json and metrics.csv). Rank 0."""
    from tissuebench.metrics.table import METRICS
    from tissuebench.workflows.io.tables import read_curves

    summary = json.loads((out / "summary.json").read_text())
    run = summary["runs"][label]
    keys = [f"{m}_{k}" for m in METRICS for k in ("max", "mean")]
    keys += [k for k in ("force_error", "interpenetration_max") if k in run]
    times, curves = read_curves(out / "metrics.csv")
    return Graded(
        out=out,
        series=series,
        label=label,
        metrics={k: run[k] for k in keys},
        times=times,
        curves={m: curves[label][m] for m in METRICS},
        lines=dict(lines),
        summary=summary,
        reference_diverged_step=summary.get("reference_diverged_step"),
    )


__all__ = ["Exported", "Graded", "UserError", "export_case", "grade", "read_case", "read_series"]
