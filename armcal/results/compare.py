"""Recalibration over time: two calibrations of one robot, parameter by parameter.

A calibration is a run's results.json (or its folder), a calibrated spec (a run's calibrated.yaml,
whose identified values carry their ``std``), or such a spec at a git revision, ``PATH@REV``
(armcal/support/gitrepo.py reads the repository as files). Each parameter both identified has its change d = new - old put
in units of its combined standard uncertainty and flagged by Holm's test; one that either side held or lacks is "not
comparable" (results/changes.py). Two runs are also compared on what does not depend on which parameters carry a
redundancy: their predicted tool and target positions at common poses (evaluate/position_changes.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal.support.errors import UserError, shown_text
from armcal.evaluate.position_changes import POSES, common_box, position_changes, run_model
from armcal.support.fileio import INPUT_LIMITS
from armcal.support.gitrepo import file_at_revision
from armcal.kinematics.params import parameter_set
from armcal.results.reader import read_results, results_file
from armcal.evaluate.multiple_testing import ALPHA
from armcal.results.changes import NO_BASIS, Basis, Row, basis, changes, check_same_robot
from armcal.results.schema import Results
from armcal.spec.locations import yaml_path
from armcal.spec import LoadedSpec, load_spec
from armcal.spec.loader import spec_from_bytes
from armcal.support.units import from_internal

_CALIBRATED_BY = re.compile(r"Calibrated by armcal \S+ on (?P<created>\S+) .*?, run (?P<run>\w+)")


@dataclass(frozen=True)
class SpecParameter:
    """A calibrated spec's parameter as compared (results/changes.py Row), in the spec's units."""

    name: str
    unit: str
    value: float
    std: float | None
    free: bool


@dataclass(frozen=True)
class Calibration:
    """What a comparison needs of one calibration: whose, when, and its parameters as results.json rows."""

    label: str
    name: str
    serial: str
    chain: tuple[str, int]  # convention, number of joints
    created: str | None
    run_id: str | None
    parameters: list[Row]  # values in the spec's units
    basis: Basis  # a run's base set: why it held what it held, what moves together
    run: tuple[Path, Results] | None = None  # a run's folder (with its calibrated.yaml) and results.json


def calibration(argument: str) -> Calibration:
    """The calibration an argument names: a results.json or a run's folder, a calibrated spec, or ``SPEC@REV``."""
    path = Path(argument)
    try:
        exists, folder = path.exists(), path.is_dir()
    except OSError:  # a name no file can have (too long): a revision, or nothing
        exists = folder = False
    if folder or path.suffix == ".json":
        file = results_file(path)
        results = read_results(file)
        robot = results.robot
        run = (file.parent, results) if (file.parent / "calibrated.yaml").is_file() else None
        return Calibration(argument, robot.name, robot.serial, (robot.convention, robot.dof), results.created,
                           results.run_id, results.parameters, basis(results), run)
    if not exists and "@" in argument:
        file, _, revision = argument.rpartition("@")
        raw = file_at_revision(Path(file), revision)
        if len(raw) > INPUT_LIMITS["spec"]:
            raise UserError(f"{argument}: larger than a spec may be ({INPUT_LIMITS['spec'] // 1024} KiB)")
        return _from_spec(spec_from_bytes(raw, Path(argument)), argument)
    return _from_spec(load_spec(path), argument)


def _from_spec(loaded: LoadedSpec, label: str) -> Calibration:
    """A spec's chain parameters (values and ``std`` as written), dated by calibrated.yaml's header if it has one."""
    spec = loaded.spec
    rows = []
    for entry in parameter_set(spec.robot.chain()).entries:
        node = spec
        for key in yaml_path(entry.name, spec):
            node = node[key] if isinstance(key, int) or isinstance(node, dict) else getattr(node, key, None)
            if node is None:
                break
        unit = spec.robot.units.of(entry.kind)
        std = getattr(node, "std", None)
        rows.append(SpecParameter(entry.name, unit, from_internal(entry.nominal, entry.kind, unit),
                                  None if std is None else from_internal(std, entry.kind, unit), entry.free))
    header = _CALIBRATED_BY.search(loaded.text)
    created, run = (header["created"], header["run"]) if header else (None, None)
    return Calibration(label, spec.robot.name, spec.robot.serial, (spec.robot.convention, spec.robot.dof), created, run, rows, NO_BASIS)


def _check_same_model(old: Calibration, new: Calibration) -> None:
    """A UserError when two calibrations of one serial are of different robots or chains (a placeholder serial)."""
    if (new.name, new.chain) != (old.name, old.chain):
        raise UserError(f"{new.label}: {shown_text(new.name, 'a name')}, a {shown_text(new.chain[0])} chain of {new.chain[1]} joints, is not "
                        f"{shown_text(old.name, 'a name')}, a {shown_text(old.chain[0])} chain of {old.chain[1]} joints, of {old.label}: the calibrations compared must be of one "
                        "robot and one model of it")


def _when(c: Calibration) -> str:
    return f"{c.label}, " + (f"{shown_text(c.created[:10], 'a date')} (run {shown_text(c.run_id, 'an id')})" if c.created else "not dated (no calibrated.yaml header)")


def _number(value: float | None, width: int, digits: str) -> str:
    return f"{value:{width}.{digits}}" if value is not None else f"{'-':>{width}}"


def _parameter_lines(old: Calibration, new: Calibration) -> tuple[list[str], int]:
    lines = [f"{'parameter':32} {'old':>14} {'new':>14} {'change':>12} {'unit':8} {'z':>7}"]
    found = changes(old.parameters, new.parameters, old.basis, new.basis)
    for c in found:
        change = c.new - c.old if c.z is not None else None
        lines.append(f"{shown_text(c.name, 'a name'):32} {_number(c.old, 14, '6g')} {_number(c.new, 14, '6g')} {_number(change, 12, '4g')} {c.unit:8} "
                     f"{_number(c.z, 7, '2f')}" + ("  significant" if c.significant else f"  not comparable ({c.not_comparable})" if c.not_comparable else ""))
    significant = sum(c.significant for c in found)
    tested = sum(c.z is not None for c in found)
    lines.append(
        f"{significant} significant change(s) among {tested} parameters both calibrations identified, {len(found) - tested} not comparable "
        f"(z = change / sqrt(u_old^2 + u_new^2); Holm's test, family-wise {ALPHA * 100:g} %: an unchanged robot shows one by chance in "
        f"at most 1 of {1 / ALPHA:.0f} comparisons)"
    )
    return lines, significant


def _position_lines(old: Calibration, new: Calibration) -> tuple[list[str], int]:
    if old.run is None or new.run is None:
        side = " and ".join(c.label for c in (old, new) if c.run is None)
        return [f"Predicted positions not compared: {side} is not a run's results.json beside its calibrated.yaml, so its parameters' "
                "covariance (results.json's correlation_matrix) is not known"], 0
    models = run_model(*old.run), run_model(*new.run)
    if None in models:
        side = " and ".join(c.label for c, m in zip((old, new), models) if m is None)
        return [f"Predicted positions not compared: {side} was written by an armcal that did not record the parameters' "
                "correlation matrix (results.json: correlation_matrix); run it again to compare positions"], 0
    box = common_box(*models)
    if box is None:
        return ["Predicted positions not compared: the two campaigns share no range of some joint (results.json: "
                "campaign.joint_ranges), and a model is compared only where its data determined it"], 0
    found = position_changes(*models, box)
    lines = [f"Predicted positions at {POSES} poses spread over the joint ranges both campaigns measured (Halton), robot base frame:",
             f"{'point':32} {'largest change':>14} {'its std':>10} {'unit':4} {'largest chi2':>12} {'significant':>11}"]
    for point in dict.fromkeys(c.point for c in found):
        rows = [c for c in found if c.point == point]
        largest = max(rows, key=lambda c: np.linalg.norm(c.change))
        lines.append(f"{point:32} {np.linalg.norm(largest.change):14.4g} {np.linalg.norm(largest.std):10.3g} {'mm':4} "
                     f"{max(c.chi2 for c in rows):12.2f} {sum(c.significant for c in rows):11d}")
    for c in (c for c in found if c.significant):
        lines.append(f"  {c.point} at pose {c.pose}: change ({', '.join(f'{v:.4g}' for v in c.change)}) mm, chi2 {c.chi2:.1f} on {c.dof} dof  significant")
    significant = sum(c.significant for c in found)
    lines.append(f"{significant} significant change(s) among {len(found)} predicted positions (chi2 = d' S^-1 d, S = J C J' of both runs "
                 f"propagated from their parameters' covariance; Holm's test, family-wise {ALPHA * 100:g} %)")
    return lines, significant


def compare(old_argument: str, new_argument: str) -> tuple[str, int]:
    """A plain-text table of two calibrations of one robot, parameter by parameter and by predicted positions, and the
    number of significant changes."""
    old, new = calibration(old_argument), calibration(new_argument)
    check_same_robot(new.serial, old.serial, new.label, old.label)
    _check_same_model(old, new)
    parameters, significant = _parameter_lines(old, new)
    positions, moved = _position_lines(old, new)
    lines = [f"{shown_text(new.name, 'a name')} ({shown_text(new.serial, 'a serial')}): {_when(old)} -> {_when(new)}", *parameters, "", *positions]
    return "\n".join(lines) + "\n", significant + moved
