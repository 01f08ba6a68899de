"""``armcal montecarlo``: Stone's study (7.2-7.4) of a spec, on a process pool or a Dask cluster.

Writes montecarlo.json (statistics of the 34 grid indices at every point, the
trends of a sweep), montecarlo.csv (every robot's indices) and SVG plots, each
file whole or not at all, once everything is computed. With ``poses`` it also
predicts the held-out accuracy against the number of calibration poses, planned
(D-optimal, ``armcal plan``) and random (N and 3N), on the study's robots
(evaluate/plan_accuracy.py), and plots it; a number of poses whose readings cannot determine the base
parameters is refused before the study starts (no design of it could be identified: nothing to compare).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from armcal import __version__
from armcal.support.errors import UserError
from armcal.support.fileio import csv_text, output_folder
from armcal.support.output_set import output_set, run_id
from armcal.evaluate.grid import ORIENTATION, grid_indices, grid_placement, index_kind, unobserved_orientation
from armcal.evaluate.montecarlo import ChunkResult, check_points, chunks, run_chunk
from armcal.evaluate.plan_accuracy import PlanStudy, accuracy_curve, accuracy_label
from armcal.evaluate.study_statistics import index_statistics, trend
from armcal.evaluate.sweeps import VARIABLES, Sweep, parse_sweep, variant
from armcal.identify.threads import processors
from armcal.commands.plan import DEFAULT_CANDIDATES
from armcal.procedures.tasks import grid_task
from armcal.report.study_plots import study_plots
from armcal.spec import load_spec
from armcal.support.units import from_internal
from armcal.commands.workers import check_workers, run_tasks

INDEX_NAMES = list(grid_indices(grid_task(), grid_task()))
STUDY_FILES = ("montecarlo.json", "montecarlo.csv")  # with the SVG plots: what a study's folder holds


@dataclass(frozen=True)
class Study:
    summary: dict  # what montecarlo.json holds
    out_dir: Path
    files: list[Path]


def _unobserved(spec, stands) -> dict | None:
    """The indices the study's data or task cannot calibrate and why (montecarlo.json's ``unobserved``): all orientation
    indices where the grid is judged on position (a robot of fewer axes, procedures/placement.py), else the absolute
    ones where the instrument does not see the tool centre point's orientation (evaluate/grid.unobserved_orientation)."""
    if stands.goal != 12:
        return {"indices": [name for name in INDEX_NAMES if "orientation" in name],
                "reason": (f"the grid is {stands.how.rsplit('; ', 1)[-1]}: neither control commands the turn about the tool's axis, "
                           "so the orientation indices do not measure the calibration")}
    why = unobserved_orientation(spec)
    return {"indices": list(ORIENTATION), "reason": why} if why else None


def montecarlo(
    spec_path: Path,
    runs: int,
    sweeps: list[str] = (),
    seed: int | None = None,
    out_dir: Path | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: Callable[[int, int], None] | None = None,
    poses: list[int] = (),
    force: bool = False,
) -> Study:
    """Run ``runs`` simulated robots at every point of the (at most one) sweep; write the study's files.

    ``poses``: numbers of calibration poses at which to compare planned and random poses' held-out accuracy.
    ``force``: replace an earlier study in ``out_dir`` (never a folder holding anything else)."""
    if runs < 2:
        raise UserError(f"--runs {runs}: a study needs at least 2 robots for a standard deviation")
    check_workers(workers)
    if len(sweeps) > 1:
        raise UserError("give at most one --sweep: Stone varies one input at a time")
    started = time.perf_counter()
    loaded = load_spec(spec_path)
    spec, folder = loaded.spec, loaded.path.parent.resolve()  # absolute: workers may run elsewhere
    out_dir = output_folder(out_dir if out_dir is not None else folder / "out" / loaded.path.stem / "montecarlo")
    with output_set(out_dir, [loaded.path], force, STUDY_FILES, "the earlier study (its whole folder)", STUDY_FILES[0]) as publish:
        summary, files = _study(loaded, runs, sweeps, seed, workers, scheduler, progress, list(poses), started)
        written = publish(files, run_id([loaded.path]))
    return Study(summary, Path(out_dir), written)


def _study(loaded, runs: int, sweeps, seed: int | None, workers: int | None, scheduler: str | None, progress,
           poses: list[int], started: float) -> tuple[dict, dict[str, str]]:
    """The study's summary and its files (name -> text), everything computed before anything is written."""
    spec, folder = loaded.spec, loaded.path.parent.resolve()
    sweep = parse_sweep(sweeps[0], spec) if sweeps else None
    points = [variant(spec, sweep.variable, value) for value in sweep.values] if sweep else [spec]
    seed = (spec.simulate.seed if spec.simulate else 0) if seed is None else seed
    first = check_points(points, folder)  # the grid, solved where the study's robots will be sent
    plan_study = _identifying_plan_study(spec, folder, poses, seed) if poses else None  # before the robots: said at once
    grid = {**grid_placement(first.grid, spec.robot.units), **first.control.describe()}
    workers = workers or processors()
    size = max(1, min(25, math.ceil(runs * len(points) / (4 * workers))))
    total, done = runs * len(points), [0]

    def robots_done(result: ChunkResult) -> None:
        done[0] += len(result.robots)
        if progress:
            progress(done[0], total)

    results = run_tasks(run_chunk, chunks(points, folder, runs, seed, size), scheduler, workers, robots_done)
    accuracy = _accuracy_vs_poses(spec, plan_study, poses, runs, progress) if poses else None
    elapsed = time.perf_counter() - started
    design, calibrated, converged = _collect(results, len(points), runs)
    statistics = [index_statistics(INDEX_NAMES, design[k], calibrated[k], spec.robot.units) for k in range(len(points))]
    summary = {
        "armcal_version": __version__,
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "spec": {"path": str(loaded.path), "sha256": loaded.sha256},
        "method": spec.fit.method,
        "runs": runs,
        "seed": seed,
        "backend": f"dask ({scheduler})" if scheduler else f"{workers} local worker process{'es' if workers > 1 else ''}",
        "elapsed_s": round(elapsed, 3),
        "grid": grid,
        "unobserved": _unobserved(spec, first.grid),
        "sweep": _describe(sweep, spec),
        "points": [
            {"value": sweep.shown[k] if sweep else None, "converged": int(converged[k].sum()), "indices": statistics[k]}
            for k in range(len(points))
        ],
        "trend": trend(sweep, statistics) if sweep else None,
        "accuracy_vs_poses": accuracy,
    }
    files = {
        "montecarlo.json": json.dumps(summary, indent=2, allow_nan=False) + "\n",
        "montecarlo.csv": _robots_csv(sweep, design, calibrated, spec.robot.units),
        **study_plots(summary),
    }
    return summary, files


MAX_POSE_COUNT = 10_000  # poses of one study design (its 3N random poses and candidates grow with it)
MAX_POSE_COUNTS = 20  # designs of one study


def pose_counts(text: str | None) -> list[int]:
    """``--poses 15,30,60`` as numbers; a located message for anything else."""
    if not text:
        return []
    try:
        counts = [int(part) for part in text.split(",")]
    except ValueError:
        raise UserError(f"--poses {text}: give whole numbers of poses separated by commas, e.g. 15,30,60") from None
    if min(counts) < 1 or max(counts) > MAX_POSE_COUNT or len(counts) > MAX_POSE_COUNTS:
        raise UserError(f"--poses {text}: up to {MAX_POSE_COUNTS} numbers of poses, each from 1 to {MAX_POSE_COUNT}")
    return sorted(set(counts))


def _identifying_plan_study(spec, folder: Path, counts: list[int], seed: int) -> PlanStudy:
    """The plan study of ``--poses``, after checking that each number of poses gives at least as many readings as
    there are base parameters (fewer cannot identify the model in any design: a user error, before the study)."""
    study = PlanStudy(spec, folder, max(DEFAULT_CANDIDATES, 3 * max(counts)), seed)
    blocks = study.information.blocks
    per_pose = int(np.count_nonzero(np.abs(blocks).sum(axis=2), axis=1).max()) if blocks.size else 0
    base = len(study.information.base)
    least = math.ceil(base / per_pose) if per_pose else None
    short = [c for c in counts if least is None or c < least]
    if short:
        need = f"give at least {least} poses" if least else "the instrument reads none of the candidate poses"
        raise UserError(f"--poses {','.join(map(str, counts))}: {short[0]} poses give at most {short[0] * per_pose} readings "
                        f"({per_pose} a pose), which cannot determine the {base} base parameters in any design; {need}")
    return study


def _accuracy_vs_poses(spec, study: PlanStudy, counts: list[int], runs: int, progress) -> dict:
    """Held-out accuracy of N planned vs N and 3N random calibration poses, mean over the study's robots; a design
    no robot could be identified from has None, and ``not_identified`` says which and why."""
    curve = accuracy_curve(study, counts, runs, factors=(1, 3), progress=progress)
    definition, unit, scale = accuracy_label(spec, study)
    values = curve.values()
    scaled = lambda means: [None if v is None else v * scale for v in means]  # noqa: E731
    missing = [f"{name} {count}" for name, series in (("planned", values["planned"]["D"]), *((f"random {f}x", m) for f, m in values["random"].items()))
               for count, v in zip(values["counts"], series) if v is None]
    return {
        "definition": definition,
        "unit": unit,
        "robots": runs,
        "candidates": study.pool,
        "criterion": "D",
        "counts": values["counts"],
        "planned": {c: scaled(m) for c, m in values["planned"].items()},
        "random": {f: scaled(m) for f, m in values["random"].items()},
        "not_identified": {"designs": missing, "reason": "the design's readings left base parameters undetermined on some "
                           "robot (or, for 3N random poses, the candidates are fewer than 3N)"} if missing else None,
    }


def _collect(results: list[ChunkResult], count: int, runs: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Arrays (points, runs, 34) of both controllers' indices, and (points, runs) convergence."""
    design = np.full((count, runs, len(INDEX_NAMES)), np.nan)
    calibrated = np.full_like(design, np.nan)
    converged = np.zeros((count, runs), dtype=bool)
    for result in results:
        robots = list(result.robots)
        design[result.point, robots] = result.design
        calibrated[result.point, robots] = result.calibrated
        converged[result.point, robots] = result.converged
    return design, calibrated, converged


def _describe(sweep: Sweep | None, spec) -> dict | None:
    if sweep is None:
        return None
    variable = VARIABLES[sweep.variable]
    unit = spec.robot.units.of(variable.kind)
    return {"variable": sweep.variable, "meaning": variable.meaning, "unit": unit, "values": list(sweep.shown), "source": variable.source}


def _robots_csv(sweep: Sweep | None, design: np.ndarray, calibrated: np.ndarray, units) -> str:
    """One row per robot, point and controller; indices in the spec's units."""
    rows = [["variable", "value", "robot", "controller", *INDEX_NAMES]]
    factors = [from_internal(1.0, index_kind(n), units.of(index_kind(n))) for n in INDEX_NAMES]
    for k in range(design.shape[0]):
        for robot in range(design.shape[1]):
            for controller, values in (("design", design), ("calibrated", calibrated)):
                row = [f"{v * f:.6g}" for v, f in zip(values[k, robot], factors)]
                rows.append([sweep.variable if sweep else "", f"{sweep.shown[k]:g}" if sweep else "", robot, controller, *row])
    return csv_text(rows)
