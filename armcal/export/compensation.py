"""Compensated joint commands for Cartesian targets (program filtering): what to command so that the calibrated
robot, its joint-side effects included, reaches each target.

For a target frame T* (position and orientation, in the chain's world frame) the joints that put the calibrated
chain there, q*, come from Newton-Raphson inverse kinematics (Stone 5.4, kinematics/ik.py), from the row's seed or,
without one, from the solution of the row before (the branch carries over along a path: the wrist does not flip),
and from the branch nearest the middle of the joint limits for the first row or where that start leads to no solution
within the limits. The robot's joints then sit at
q + Delta(q) when commanded q (encoder scale, gear harmonics, compliance, coupling: effects/measurement.py), so the
command solves q + Delta(q) = q*, by the fixed point q <- q* - Delta(q) (Delta is small and slowly varying:
each step shrinks the error by about |dDelta/dq|). The corrected Cartesian target is the pose the nominal model
reaches at that command: a controller that keeps its nominal model, given it, commands the same joints.
"""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np

from armcal.dataio.columns import Layout, joint_columns
from armcal.dataio.reader import MAX_ISSUES, read_table
from armcal.effects.library import from_spec
from armcal.effects.measurement import EffectSet, extras_size
from armcal.support.errors import Issue, SpecError, shown_text
from armcal.support.fileio import csv_text
from armcal.support.compiled import compiled
from armcal.kinematics import ik
from armcal.kinematics.compiler import KinematicModel, compile_robot
from armcal.kinematics.mapped import Mapped
from armcal.kinematics.transforms import pose_from_matrix, xyz_zyx_stacked
from armcal.results.schema import Results
from armcal.spec import LoadedSpec
from armcal.spec.learned import BASE
from armcal.diagnose.residual_model import ResidualModel, stored_model
from armcal.export import learned_model
from armcal.export.parameters import learned_section
from armcal.kinematics.params import joint_kind
from armcal.support.units import factor, to_internal

POSE = ("x", "y", "z", "rx", "ry", "rz")
POSE_KINDS = dict(zip(POSE, ("length",) * 3 + ("angle",) * 3))  # the spec's length and angle units
FIXED_POINT_STEPS = 50
TOOL_AT_TARGET = 1e-6  # mm: the tool frame's origin is at a target
FIXED_POINT_TOLERANCE = 1e-13  # rad or mm
REACHED = 1e-4  # mm (and the axis columns' difference): a target the calibrated robot reaches
FARTHEST = 1e6  # mm: a target's x, y and z at most (a kilometre)
ERROR_DECIMALS = 9  # position_error_mm to the picometre, far below REACHED and ik's 1e-6 mm: no rounding noise printed


def _targets(text: str, name: str, spec) -> tuple[list[str], np.ndarray, np.ndarray]:
    """(labels, goals (N, 12) internal, seeds (N, n), NaN where none) of a targets CSV, read as strictly as measured
    data (dataio.reader.read_table): x, y, z, rx, ry, rz, optional name, and either no joint column or every one of
    q1..qN filled in every row, within the joint limits (a seed elsewhere is a located mistake, not ignored)."""
    joints = joint_columns(spec)

    def layout(header: list[str]) -> Layout:
        seeded = any(column in joints for column in header)
        return Layout((), {**POSE_KINDS, **(joints if seeded else {})}, {"name": "text", **({} if seeded else joints)})

    values, text_columns, count = read_table(Path(name), text, spec, layout, verbatim=("name",))  # written back as given
    names = text_columns.get("name", [""] * count)
    labels = [names[r] or str(r + 1) for r in range(count)]
    _unique(labels, Path(name))
    _near(values, Path(name), spec.robot.units.length)
    x, y, z, rx, ry, rz = (values[c] for c in POSE)
    goals = ik.pose_goals(xyz_zyx_stacked(x, y, z, rz, ry, rx))
    seeds = np.stack([values.get(c, np.full(count, np.nan)) for c in joints], axis=1)
    return labels, goals, seeds


def _unique(labels: list[str], path: Path) -> None:
    """Each target's label (its name, or its row number where it has none) names one row of the commands."""
    first: dict[str, int] = {}
    repeated = []
    for r, label in enumerate(labels):
        if label in first:
            repeated.append(Issue(path, r + 2, None, "name", f"the name repeats line {first[label]}'s: each target names one command"))
        first.setdefault(label, r + 2)
    if repeated:
        raise SpecError(repeated[:MAX_ISSUES])


def _near(values: dict[str, np.ndarray], path: Path, unit: str) -> None:
    """Each target's position within FARTHEST of the world origin: beyond, no robot reaches it, and its arithmetic
    (inverse kinematics' squared errors) would overflow."""
    far = sorted((int(r), c) for c in POSE[:3] for r in np.flatnonzero(np.abs(values[c]) > FARTHEST))
    if far:
        scale = factor("length", unit)
        raise SpecError([Issue(path, r + 2, None, c, f"farther than any robot reaches (more than {FARTHEST / scale:g} {unit}, a kilometre, "
                                                      "from the world origin)") for r, c in far[:MAX_ISSUES]])


def _deviation(function: ca.Function, kinematics: KinematicModel, effects: EffectSet):
    """Q (N, n) -> Delta(Q) of the joint-side effects; ``function``: their joint_deviation_function."""
    mapped = Mapped(function, shared=(1, 2, 3))
    x, p, pe = np.zeros(extras_size(kinematics.dof)), kinematics.parameters.nominal, effects.values()
    return lambda Q: mapped(Q, x, p, pe)[0][:, 0]


def _poses(fk: ca.Function):
    """(Q (N, n), p) -> tool poses (N, 4, 4); ``fk``: the chain's (KinematicModel.fk)."""
    mapped = Mapped(fk, shared=(1,))
    return lambda Q, p: mapped(Q, p)[0].transpose(0, 2, 1)


def compensate(loaded: LoadedSpec, results: Results | None, targets_text: str, targets_name: str) -> tuple[str, list[str], list[str], str | None]:
    """(CSV text of the commands, the targets not reached with why, the effects not compensated, what to say of the
    learned residual model: None where there is none)."""
    spec = loaded.spec
    kinematics = compile_robot(spec.robot.chain())
    joints = list(zip([f"q{i}" for i in range(1, kinematics.dof + 1)], kinematics.joint_types))
    labels, goals, seeds = _targets(targets_text, targets_name, spec)
    effects = [from_spec(e) for e in spec.effects]
    left_out = sorted({e.id for e in effects if not e.kind.compensated})
    compensated = EffectSet(tuple(e for e in effects if e.kind.compensated))
    error_function, fk, deviation_function = compiled([ik.error_function(kinematics), kinematics.fk, compensated.joint_deviation_function(kinematics)])
    deviation, poses = _deviation(deviation_function, kinematics, compensated), _poses(fk)
    reached, found = _solutions(kinematics, goals, seeds, error_function)
    command = _through_joint_effects(reached, deviation)
    section = learned_section(loaded, results)
    stored = stored_model(section) if section is not None else None
    target = _tool_target(kinematics, stored) if stored is not None else None
    model = stored if target is not None else None
    solved = found.copy()  # without the learned correction
    if model is not None:
        command, shift, trusted, spread = _with_learned_point(kinematics, model, target, goals, reached, found, command, deviation, error_function)
    inside = ik.within_limits(kinematics, command)
    error = np.full(len(goals), np.nan)
    actual = poses(command + deviation(command), kinematics.parameters.nominal)[:, :3, 3]
    if model is not None:
        actual = actual + shift
    error[found] = np.linalg.norm(actual[found] - goals[found, :3], axis=1)
    nominal = _nominal(kinematics, results)
    corrected = poses(command, nominal) if nominal is not None else None
    units = spec.robot.units
    header = ["name", "status", *(j for j, _ in joints), "position_error_mm"] + ([f"corrected_{c}" for c in POSE] if corrected is not None else [])
    header += ["learned_shift_mm", "learned_std_mm", "learned_correction"] if model is not None else []
    rows, unreached = [header], []
    joint_units = [factor(joint_kind(kind), units.of(joint_kind(kind))) for _, kind in joints]
    for i, label in enumerate(labels):
        status = "ok" if found[i] and inside[i] and error[i] < REACHED else (
            "unreachable: outside the joint limits" if found[i] and not inside[i] else
            "unreachable: no inverse-kinematics solution" + (" with the learned correction" if solved[i] else "") if not found[i] else f"unreachable: {error[i]:.3g} mm off")
        if status != "ok":
            unreached.append(f"{shown_text(label, f'row {i + 1}: a name')} ({status[13:]})")
        row = [label, status]
        row += [f"{command[i, j] / unit:.12g}" if found[i] else "" for j, unit in enumerate(joint_units)]
        row.append(f"{error[i]:.{ERROR_DECIMALS}f}" if found[i] else "")
        if corrected is not None and not found[i]:
            row += [""] * len(POSE)
        elif corrected is not None:
            x, y, z, rz, ry, rx = pose_from_matrix(corrected[i])
            row += [f"{v / factor('length', units.length):.12g}" for v in (x, y, z)] + [f"{v / factor('angle', units.angle):.12g}" for v in (rx, ry, rz)]
        if model is not None:
            applied_std = np.linalg.norm(np.where(trusted[i], spread[i], 0.0))
            row += [f"{np.linalg.norm(shift[i]):.{ERROR_DECIMALS}f}", f"{applied_std:.{ERROR_DECIMALS}f}", _learned_status(trusted[i])] if found[i] else ["", "", ""]
        rows.append(row)
    untrusted = int(np.sum(found & ~trusted.all(axis=1))) if model is not None else 0
    return csv_text(rows), unreached, left_out, _learned_note(loaded, results, stored, target, int(found.sum()), untrusted)


def _through_joint_effects(reached: np.ndarray, deviation) -> np.ndarray:
    """The command q with q + Delta(q) = q* (``reached``), by the fixed point q <- q* - Delta(q) (module docstring)."""
    command = reached.copy()
    for _ in range(FIXED_POINT_STEPS):
        previous, command = command, reached - deviation(command)
        if np.max(np.abs(command - previous)) < FIXED_POINT_TOLERANCE:
            break
    return command


def _tool_target(kinematics: KinematicModel, model: ResidualModel) -> str | None:
    """The target whose learned point error is the tool's own: the model's point target at the tool frame's origin
    (within TOOL_AT_TARGET, at the calibrated parameters, at the chain's zero and at a turn of every joint); None when
    the tool is at none of them (a reflector's error is not the tool's where the flange turns)."""
    configurations = np.stack([np.zeros(kinematics.dof), np.full(kinematics.dof, 0.5)])
    tool = kinematics.tool_poses(configurations)[:, :3, 3]
    return next((t for t in model.point_targets()
                 if np.max(np.abs(kinematics.target_poses(t, configurations)[:, :3, 3] - tool)) <= TOOL_AT_TARGET), None)


def _with_learned_point(kinematics: KinematicModel, model: ResidualModel, target: str, goals: np.ndarray, reached: np.ndarray, found: np.ndarray,
                        command: np.ndarray, deviation, error: ca.Function) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(command (N, n), shift (N, 3), trusted (N, 3), std (N, 3)): the command whose calibrated pose plus the learned correction delta(command)
    is the goal's position, orientation untouched: the fixed point goal - delta(q) -> q* (inverse kinematics from
    the q* before) -> q (through the joint-side effects). delta varies slowly with q, so each step shrinks the error by
    about |d delta / dq| / |dp / dq| (a 0.1 mm change per rad against ~500 mm per rad: a few steps). ``found``: the
    goals solved without it (updated in place where the moved goal has no solution)."""
    reached = reached.copy()
    for _ in range(FIXED_POINT_STEPS if found.any() else 0):
        shift, _, _ = model.point_shift(command, target)
        moved = goals.copy()
        moved[:, :3] -= shift
        solved = ik.solve(kinematics, moved[found], reached[found], halvings=ik.SAFE_HALVINGS, error=error)
        reached[found] = _nearest_turn(kinematics, solved.q, reached[found])
        found[found] = solved.converged
        previous, command = command, _through_joint_effects(reached, deviation)
        if not found.any() or np.max(np.abs(command - previous)[found]) < FIXED_POINT_TOLERANCE:
            break
    return command, *model.point_shift(command, target)


def _learned_status(trusted: np.ndarray) -> str:
    """A row's learned_correction: applied, or the base coordinates it was not applied in (outside the calibrated region)."""
    if trusted.all():
        return "applied"
    return "not applied, outside the calibrated region: " + " ".join(name for name, ok in zip(BASE, trusted) if not ok)


def _learned_note(loaded: LoadedSpec, results: Results | None, model: ResidualModel | None, target: str | None, solved: int, untrusted: int) -> str | None:
    """What the terminal says of the learned residual model (None: there is none)."""
    if target is not None:
        return (f"learned correction (residual_model: the error of target {target}'s measured point, where the tool frame is, in the "
                f"robot's base frame) applied to each target's position, orientation untouched: {solved - untrusted} of {solved} "
                f"solved targets in full, {untrusted} with a coordinate outside the calibrated region (predictive std above "
                f"{model.outside_fraction():g} of the prior's; not applied there: learned_correction)")
    if model is not None and model.point_targets():
        return (f"not compensated: the learned residual model holds the error of the measured point of {', '.join(model.point_targets())}, "
                f"and the tool frame (robot.tool) is at none of them: a point's error is not the tool's where the flange turns. Give "
                f"robot.tool at that target's position for the correction to apply: none applied")
    if model is not None:
        return (f"not compensated: the learned residual model holds no point's error in the robot's base frame ({', '.join(BASE)}; it "
                f"holds {', '.join(sorted({name for name, _ in model.coordinates}))}), so it cannot correct a Cartesian target: none applied")
    asked = learned_model(loaded, results)
    return None if asked is None else f"not compensated: {asked}"


def _solutions(kinematics: KinematicModel, goals: np.ndarray, seeds: np.ndarray, error: ca.Function) -> tuple[np.ndarray, np.ndarray]:
    """(q* (N, n), found (N,)): the joints that put the calibrated chain at each goal. A seeded goal starts from its seed
    (all at once); the others, in file order, from the solution of the target before them (ik.solve_in_order: the
    branch carries over, the wrist does not flip), and from the branch nearest the middle of the joint limits where
    there is no such solution or it leads to none within the limits. ``error``: ik.error_function, compiled."""
    count = len(goals)
    reached, found = np.zeros((count, kinematics.dof)), np.zeros(count, dtype=bool)
    seeded = ~np.isnan(seeds).any(axis=1)
    if seeded.any():
        solved = ik.solve(kinematics, goals[seeded], seeds[seeded], halvings=ik.SAFE_HALVINGS, error=error)
        reached[seeded], found[seeded] = _nearest_turn(kinematics, solved.q, seeds[seeded]), solved.converged
    i = 0
    while i < count:
        if seeded[i]:
            i += 1
            continue
        if i > 0 and found[i - 1]:
            end = i + int(np.argmax(np.append(seeded[i:], True)))  # the unseeded rows from i on
            warm = ik.solve_in_order(kinematics, goals[i:end], reached[i - 1], error=error)
            reached[i : i + len(warm.q)], found[i : i + len(warm.q)] = warm.q, True
            i += len(warm.q)
            if i == end:
                continue
        reached[i], found[i] = _from_the_middle(kinematics, goals[i], error)
        i += 1
    return reached, found


def _from_the_middle(kinematics: KinematicModel, goal: np.ndarray, error: ca.Function) -> tuple[np.ndarray, bool]:
    """(q*, found) of one goal on the branch nearest the middle of the joint limits (ik.solve_from_starts)."""
    start = _nearest_turn(kinematics, ik.solve_from_starts(kinematics, goal[None], error=error), kinematics.limits.mean(axis=1)[None])
    if np.isnan(start).any():
        return np.zeros(kinematics.dof), False
    solved = ik.solve(kinematics, goal[None], start, halvings=ik.SAFE_HALVINGS, error=error)
    return _nearest_turn(kinematics, solved.q, start)[0], bool(solved.converged[0])


def _nearest_turn(kinematics: KinematicModel, Q: np.ndarray, start: np.ndarray) -> np.ndarray:
    """Revolute joint values shifted by whole turns to the ones nearest the start (the seed's branch)."""
    Q = Q.copy()
    for i, kind in enumerate(kinematics.joint_types):
        if kind == "revolute":
            Q[:, i] = start[:, i] + np.mod(Q[:, i] - start[:, i] + np.pi, 2 * np.pi) - np.pi
    return Q


def _nominal(kinematics: KinematicModel, results: Results | None) -> np.ndarray | None:
    """The robot's nominal parameter vector from a run's results.json (its parameters' nominal values), else None."""
    if results is None:
        return None
    given = {p.name: (p.nominal, p.unit) for p in results.parameters}
    out = kinematics.parameters.nominal.copy()
    for i, entry in enumerate(kinematics.parameters.entries):
        if entry.name in given:
            value, unit = given[entry.name]
            out[i] = to_internal(value, entry.kind, unit) if entry.kind in ("length", "angle") else value
    return out


