"""``armcal plan``: N calibration poses chosen from M readable candidates, with their predicted accuracy.

Writes POSES.csv (a header row, one pose a row: q1..qN in the spec's units; a ball-bar's plan also names the
bar of each pose: pivot, sphere, extension) and POSES.json beside it (the same name, .json: the criterion, the
candidates and why some were dropped, the predicted 1-sigma uncertainty of every base parameter, the
condition number and the predicted held-out accuracy against random poses), each file whole, after
everything is computed. The CSV serves as a spec's ``procedure: {type: poses, file: POSES.csv}``.
docs/plan.md describes the method (procedures/pose_selection.py, evaluate/plan_accuracy.py).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal import __version__
from armcal.dataio.columns import joint_columns
from armcal.dataio.reader import read_pose_file
from armcal.devices.registry import INSTRUMENTS, instruments_where
from armcal.support.errors import UserError, either, with_article
from armcal.evaluate.montecarlo import robot_seeds
from armcal.evaluate.plan_accuracy import PlanStudy, accuracy_label
from armcal.evaluate.working_region import REGIONS, working_region
from armcal.support.fileio import csv_text, refuse_replacing
from armcal.procedures import pose_selection as ps
from armcal.procedures.poses import keyed_plan
from armcal.report.render import write_files
from armcal.spec import load_spec
from armcal.support.units import from_internal

MAX_POSES = 100_000
MAX_CANDIDATES = 200_000
MAX_RUNS = 10_000  # simulated robots predicting the held-out accuracy: 50 give it to a few per cent
DEFAULT_CANDIDATES = 2000
DEFAULT_RUNS = 50
ORIENTATIONS = ("task", "any")
CRITERIA = {
    "D": "D-optimal: maximum log det of the information matrix M = J^T J on the base parameters (J weighted by 1/sigma)",
    "I": "I-optimal: minimum trace(W M^-1), the linearised mean squared held-out position error (M = J^T J on the base parameters)",
}


@dataclass(frozen=True)
class PosePlan:
    csv: str
    summary: dict
    text: str


def side_file(out: Path) -> Path:
    """POSES.json beside POSES.csv."""
    return Path(out).with_suffix(".json")


def plan_command(spec_path: Path, poses: int, candidates: int, extend: Path | None, out: Path, force: bool,
                 runs: int, seed: int | None, criterion: str | None = None, progress: Callable[[int, int], None] | None = None,
                 say: Callable[[str], None] = lambda line: None, region: str | None = None,
                 orientation: str = "task") -> tuple[PosePlan, list[Path]]:
    """Plan, predict and write POSES.csv and POSES.json; a user error for anything the user can fix.

    ``region`` (iso_cube, grid; evaluate/working_region.py): the accuracy that counts is in the robot's working region,
    its poses at the task's ``orientation`` or at any; the criterion defaults to I then (W over the region)."""
    criterion = criterion or ("I" if region else "D")
    if not 1 <= poses <= MAX_POSES:
        raise UserError(f"--poses {poses}: give a number of poses from 1 to {MAX_POSES}")
    if not 1 <= candidates <= MAX_CANDIDATES:
        raise UserError(f"--candidates {candidates}: give a number of candidates from 1 to {MAX_CANDIDATES}")
    if candidates < poses:
        raise UserError(f"--candidates {candidates} is fewer than --poses {poses}: the poses are chosen among the candidates")
    if criterion not in CRITERIA:
        raise UserError(f"--criterion {criterion}: choose D (the default) or I")
    if region is not None and region not in REGIONS:
        raise UserError(f"--region {region}: choose one of {', '.join(REGIONS)}")
    if orientation not in ORIENTATIONS:
        raise UserError(f"--orientation {orientation}: choose task (the default) or any")
    if not 0 <= runs <= MAX_RUNS:
        raise UserError(f"--runs {runs}: give 0 (no Monte Carlo) to {MAX_RUNS} simulated robots")
    refuse_replacing([out, side_file(out)], [spec_path, *([extend] if extend else [])], force)
    loaded = load_spec(spec_path)
    spec = loaded.spec
    if "poses" not in spec.device.procedures:
        takers = instruments_where(lambda section: "poses" in section.procedures)
        raise UserError(f"{spec_path}: armcal plan chooses poses for {with_article(either(takers))}, not a {spec.device.type}")
    model = INSTRUMENTS[spec.device.type]
    keyed = model.keyed_poses
    if region is not None and keyed:
        raise UserError(f"--region {region}: a {spec.device.type} reads each pose on its own {' and '.join(model.key_columns)}, "
                        "not target positions in a working region; plan without --region")
    seed = (spec.simulate.seed if spec.simulate else 0) if seed is None else seed
    say(f"candidates: {candidates} random poses{' on the shells (inverse kinematics)' if keyed else ''} ...")
    existing_q, existing_keys, existing = _existing(spec, extend)
    where = None
    if region is not None:
        from armcal.kinematics.compiler import compile_robot

        say(f"working region: {region}, poses at {'the task' if orientation == 'task' else 'any'} orientation ...")
        where = working_region(spec, compile_robot(spec.robot.chain()), region, orientation == "task")
    study = PlanStudy(spec, loaded.path.parent, candidates, seed, existing, criterion, where)
    if study.pool < poses:
        raise UserError(f"only {study.pool} of {candidates} candidates are readable ({_dropped(study.fresh_dropped)}); "
                        f"ask for more --candidates or fewer --poses")
    say(f"selecting {poses} of {study.pool} candidates ({CRITERIA[criterion].split(':')[0]}) ...")
    selection = study.planned(poses)
    covariance = selection.covariance()
    info = study.information
    readings = int(np.count_nonzero(np.abs(info.blocks[selection.rows]).sum(axis=2)))
    if not np.isfinite(covariance).all():
        raise UserError(f"{poses} poses{f' and the {len(existing_q)} of {extend}' if extend else ''} give {readings} readings, which "
                        f"cannot determine the {len(info.base)} base parameters; plan more poses")
    accuracy = _monte_carlo(study, selection.rows, poses, runs, progress)
    new_rows = selection.rows[study.existing:]
    summary = _summary(loaded, study, selection, covariance, readings, accuracy, poses, candidates, extend, len(existing_q), seed)
    plan = PosePlan(_csv(spec, (existing_q, existing_keys), study.candidates, new_rows), summary, _text(summary))
    files = {Path(out).name: plan.csv, side_file(out).name: json.dumps(summary, indent=1) + "\n"}
    return plan, write_files(Path(out).parent, files)


def _existing(spec, extend: Path | None) -> tuple[np.ndarray, tuple | None, ps.Candidates | None]:
    """The poses of the plan being extended (all of its rows, a ball-bar's keys), and those the instrument
    reads, as candidates."""
    if extend is None:
        return np.zeros((0, spec.robot.dof)), None, None
    from armcal.devices import device_model
    from armcal.kinematics.compiler import compile_robot

    Q, keys = read_pose_file(extend, spec)
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    if device.keyed_poses:
        if keys is None:
            raise UserError(f"{extend}: a {device.type} plan needs its {' and '.join(device.key_columns)} columns")
        return Q, keys, ps.keyed_plan_candidates(keyed_plan(Q, keys, kinematics, device))
    return Q, None, ps.keyed_candidates(Q, kinematics, device)


def _dropped(dropped: dict[str, int]) -> str:
    return "; ".join(f"{count} {why}" for why, count in dropped.items()) or "none dropped"


def _monte_carlo(study: PlanStudy, rows: np.ndarray, poses: int, runs: int, progress) -> dict | None:
    """Held-out accuracy (mm) of the plan and of random poses of the same number on the same robots."""
    if runs == 0:
        return None
    planned, random, in_region = np.full(runs, np.nan), np.full(runs, np.nan), np.full(runs, np.nan)
    for r, seed in enumerate(robot_seeds(study.seed, runs)):
        planned[r] = study.accuracy(rows, seed)
        random[r] = study.accuracy(study.random(poses, r), seed)
        if study.region is not None:
            in_region[r] = study.accuracy(study.random_in_region(poses, r), seed)
        if progress is not None:
            progress(r + 1, runs)
    return {"planned": planned, "random": random, "random_in_region": in_region if study.region is not None else None,
            "linearised_planned": study.linearised(rows),
            "linearised_random": float(np.median([study.linearised(study.random(poses, r)) for r in range(runs)]))}


def _csv(spec, existing: tuple[np.ndarray, tuple | None], candidates: ps.Candidates, rows: np.ndarray) -> str:
    """q1..qN in the spec's units (and a ball-bar's pivot, sphere, extension): the existing poses, then the new."""
    kinds = list(joint_columns(spec).values())
    model = INSTRUMENTS[spec.device.type]
    key_columns = model.key_columns + model.optional_key_columns if model.keyed_poses else ()
    header = [f"q{i}" for i in range(1, spec.robot.dof + 1)] + list(key_columns)
    Q = [*existing[0], *candidates.q[rows]]
    keys = [*(existing[1] or [None] * len(existing[0])), *(candidates.keys[r][0] for r in rows)]
    rows = [header]
    for q, key in zip(Q, keys):
        fields = [f"{from_internal(v, k, getattr(spec.robot.units, k)):.10g}" for v, k in zip(q, kinds)]
        rows.append(fields + [key[i] or "" for i in range(len(key_columns))])
    return csv_text(rows)


def _unit(spec, kind: str) -> str:
    return getattr(spec.robot.units, kind) if kind in ("length", "angle") else "1"


def _summary(loaded, study: PlanStudy, selection, covariance, readings, accuracy, poses, candidates, extend, kept, seed) -> dict:
    spec, info = loaded.spec, study.information
    std = np.sqrt(np.diag(covariance))
    parameters = [{"name": name, "unit": _unit(spec, kind), "std": from_internal(s, kind, _unit(spec, kind)) if kind in ("length", "angle") else float(s)}
                  for name, kind, s in zip(info.base, info.kinds, std)]
    definition, unit, scale = accuracy_label(spec, study)
    summary = {
        "armcal_version": __version__,
        "spec": {"path": str(loaded.path), "sha256": loaded.sha256},
        "criterion": CRITERIA[study.criterion],
        "poses": {"planned": poses, "existing": kept, "extended": str(extend) if extend else None, "readings": readings},
        "candidates": {"drawn": candidates, "readable": study.pool, "dropped": study.fresh_dropped, "seed": seed},
        "base_parameters": len(info.base),
        "condition_number": ps.condition_number(info.blocks, selection.rows),
        "log_det_information": float(np.linalg.slogdet(selection.information)[1]),
        "parameters": parameters,
        "region": study.region.describe() if study.region is not None else None,
        "held_out_accuracy": None,
    }
    if accuracy is not None:
        summary["held_out_accuracy"] = {
            "definition": definition,
            "unit": unit,
            "robots": len(accuracy["planned"]),
            "planned": _stats(scale * accuracy["planned"]),
            "random_same_count": _stats(scale * accuracy["random"]),
            "random_in_region_same_count": _stats(scale * accuracy["random_in_region"]) if accuracy["random_in_region"] is not None else None,
            "linearised_planned": scale * accuracy["linearised_planned"],
            "linearised_random_median": scale * accuracy["linearised_random"],
        }
    return summary


def _stats(values: np.ndarray) -> dict:
    ok = values[np.isfinite(values)]
    return {"mean": float(ok.mean()) if len(ok) else None, "median": float(np.median(ok)) if len(ok) else None,
            "not_identified": int(len(values) - len(ok))}


def _region_line(region: dict) -> str:
    low, high = (", ".join(f"{v:.0f}" for v in region[k]) for k in ("low", "high"))
    return (f"  working region: {region['name']}, {region['point']} in the box ({low}) .. ({high}) mm of the robot base frame, "
            f"orientation {region['orientation']}; held-out poses and W there, candidates over the whole joint range")


def _text(summary: dict) -> str:
    c, p = summary["candidates"], summary["poses"]
    lines = [f"planned {p['planned']} poses" + (f" after the {p['existing']} of {p['extended']}" if p["extended"] else "")
             + f" from {c['drawn']} candidates: {c['readable']} readable ({_dropped(c['dropped'])})",
             f"  criterion: {summary['criterion']}",
             *([_region_line(summary["region"])] if summary["region"] else []),
             f"  {p['readings']} readings, {summary['base_parameters']} base parameters, "
             f"condition number of the column-scaled base Jacobian {summary['condition_number']:.3g}",
             "  predicted 1-sigma uncertainty of the base parameters (noise only):"]
    width = max(len(q["name"]) for q in summary["parameters"])
    lines += [f"    {q['name']:{width}s}  {q['std']:.3g} {q['unit']}" for q in summary["parameters"]]
    held = summary["held_out_accuracy"]
    if held is None:
        lines.append("  held-out accuracy: not simulated (--runs 0)")
        return "\n".join(lines)
    planned, random = held["planned"], held["random_same_count"]
    unit = held["unit"]
    fmt = lambda s: f"{s['mean']:.4g} {unit}" if s["mean"] is not None else "not identified"  # noqa: E731
    lines += [f"  predicted held-out accuracy, {held['definition']}:",
              f"    planned {p['planned']}:  {fmt(planned)} (mean over {held['robots']} simulated robots; linearised, noise only: {held['linearised_planned']:.4g} {unit})",
              f"    random {p['planned']}:   {fmt(random)} (the same robots; linearised: {held['linearised_random_median']:.4g} {unit}, median of the random designs)"]
    in_region = held.get("random_in_region_same_count")
    if in_region is not None:
        lines.append(f"    random {p['planned']} in the region (any orientation): {fmt(in_region)} (the same robots)")
    for name, s in (("planned", planned), ("random", random), ("random in the region", in_region)):
        if s is None:
            continue
        if s["not_identified"]:
            lines.append(f"    {s['not_identified']} of {held['robots']} robots could not be identified from the {name} poses")
    return "\n".join(lines)
