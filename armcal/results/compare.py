"""Recalibration over time: two calibrations of one robot, parameter by parameter.

A calibration is a run's results.json (or its folder), a calibrated spec (a run's calibrated.yaml,
whose identified values carry their ``std``), or such a spec at a git revision, ``PATH@REV``
(armcal/gitrepo.py reads the repository as files). Each parameter's change d = new - old is put in
units of its combined standard uncertainty and flagged by Holm's test (results/changes.py).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from armcal.errors import UserError
from armcal.fileio import INPUT_LIMITS
from armcal.gitrepo import file_at_revision
from armcal.kinematics.params import parameter_set
from armcal.report.render import read_results, results_file
from armcal.results.changes import ALPHA, changes, check_same_robot
from armcal.spec.locations import yaml_path
from armcal.spec import LoadedSpec, load_spec
from armcal.spec.loader import spec_from_bytes
from armcal.units import from_internal

_CALIBRATED_BY = re.compile(r"Calibrated by armcal \S+ on (?P<created>\S+) .*?, run (?P<run>\w+)")


@dataclass(frozen=True)
class Calibration:
    """What a comparison needs of one calibration: whose, when, and its parameters as results.json rows."""

    label: str
    name: str
    serial: str
    chain: tuple[str, int]  # convention, number of joints
    created: str | None
    run_id: str | None
    parameters: list[dict]  # {name, unit, value, std, free}, values in the spec's units


def calibration(argument: str) -> Calibration:
    """The calibration an argument names: a results.json or a run's folder, a calibrated spec, or ``SPEC@REV``."""
    path = Path(argument)
    try:
        exists, folder = path.exists(), path.is_dir()
    except OSError:  # a name no file can have (too long): a revision, or nothing
        exists = folder = False
    if folder or path.suffix == ".json":
        results = read_results(results_file(path))
        robot = results["robot"]
        return Calibration(argument, robot["name"], robot["serial"], (robot["convention"], robot["dof"]), results["created"],
                           results.get("run_id"), results["parameters"])
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
    for entry in parameter_set(spec.robot).entries:
        node = spec
        for key in yaml_path(entry.name, spec):
            node = node[key] if isinstance(key, int) or isinstance(node, dict) else getattr(node, key, None)
            if node is None:
                break
        unit = spec.robot.units.of(entry.kind)
        std = getattr(node, "std", None)
        rows.append({
            "name": entry.name,
            "unit": unit,
            "value": from_internal(entry.nominal, entry.kind, unit),
            "std": None if std is None else from_internal(std, entry.kind, unit),
            "free": entry.free,
        })
    header = _CALIBRATED_BY.search(loaded.text)
    created, run = (header["created"], header["run"]) if header else (None, None)
    return Calibration(label, spec.robot.name, spec.robot.serial, (spec.robot.convention, spec.robot.dof), created, run, rows)


def _check_same_model(old: Calibration, new: Calibration) -> None:
    """A UserError when two calibrations of one serial are of different robots or chains (a placeholder serial)."""
    if (new.name, new.chain) != (old.name, old.chain):
        raise UserError(f"{new.label}: {new.name}, a {new.chain[0]} chain of {new.chain[1]} joints, is not {old.name}, a "
                        f"{old.chain[0]} chain of {old.chain[1]} joints, of {old.label}: the calibrations compared must be of one "
                        "robot and one model of it")


def _when(c: Calibration) -> str:
    return f"{c.label}, " + (f"{c.created[:10]} (run {c.run_id})" if c.created else "not dated (no calibrated.yaml header)")


def compare(old_argument: str, new_argument: str) -> tuple[str, int]:
    """A plain-text table of the parameters of two calibrations of one robot and the number of significant changes."""
    old, new = calibration(old_argument), calibration(new_argument)
    check_same_robot(new.serial, old.serial, new.label, old.label)
    _check_same_model(old, new)
    lines = [
        f"{new.name} ({new.serial}): {_when(old)} -> {_when(new)}",
        f"{'parameter':32} {'old':>14} {'new':>14} {'change':>12} {'unit':8} {'z':>7}",
    ]
    found = changes(old.parameters, new.parameters)
    for c in found:
        shown_z = f"{c.z:7.2f}" if c.z is not None else "      -"
        lines.append(f"{c.name:32} {c.old:14.6g} {c.new:14.6g} {c.new - c.old:12.4g} {c.unit:8} {shown_z}" + ("  significant" if c.significant else ""))
    significant = sum(c.significant for c in found)
    tested = sum(c.z is not None for c in found)
    lines.append(
        f"{significant} significant change(s) among {tested} parameters with uncertainties (z = change / sqrt(u_old^2 + u_new^2); "
        f"Holm's test, family-wise {ALPHA * 100:g} %: an unchanged robot shows one by chance in at most 1 of {1 / ALPHA:.0f} comparisons)"
    )
    return "\n".join(lines) + "\n", significant
