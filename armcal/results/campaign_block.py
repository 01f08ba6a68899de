"""The campaign and report blocks of results.json: what was measured, and the certificate's fields."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armcal.spec import LoadedSpec
from armcal.kinematics.params import joint_kind
from armcal.support.units import from_internal


def _procedure(procedure) -> str:
    if procedure is None:
        return None
    if procedure.type == "circle_point":
        counts = procedure.points_per_joint
        each = ", ".join(map(str, counts)) if isinstance(counts, list) else f"{counts} per joint"
        return f"circle-point sweeps of targets {', '.join(procedure.targets)} ({each}, {procedure.averaging} readings averaged)"
    if procedure.type == "shells":
        pairs = ", ".join(f"{p.pivot}-{p.sphere}" for p in procedure.pairings)
        rod = f", extension rod {procedure.extension}" if procedure.extension else ""
        return f"hemispherical shells, pairings {pairs}; {len(procedure.latitudes)} latitudes x {procedure.longitudes} longitudes{rod}"
    source = f"poses from {procedure.file}" if procedure.file else f"{procedure.count} random poses (seed {procedure.seed})"
    return source


def data_description(data, procedure, simulated: bool) -> str | None:
    """What a data file holds: its readings and poses, and how it was made when armcal simulated it.

    Measured data are described by themselves; the spec's procedure only planned them
    (and says what was simulated)."""
    if data is None:
        return None
    poses = len(np.unique(np.round(np.nan_to_num(data.q), 9), axis=0))
    text = f"{len(data)} samples at {poses} poses from {Path(str(data.source)).name}"
    return text + (f", simulated by armcal from the spec's procedure: {_procedure(procedure)}" if simulated else "")


def campaign(loaded: LoadedSpec, calibration, validation, simulated: tuple[bool, bool]) -> dict:
    """The campaign block: the instrument, and what the calibration and validation data are."""
    spec = loaded.spec
    device = spec.device
    length = spec.robot.units.length
    show = lambda v: f"{from_internal(v, 'length', length):g} {length}"  # noqa: E731
    instrument, details = device.describe(show)
    temperatures = [d.extras["temperature"] for d in (calibration, validation) if d is not None and "temperature" in d.extras]
    values = np.concatenate(temperatures) if temperatures else None
    return {
        "instrument": instrument,
        "details": details,
        "procedure": data_description(calibration, spec.procedure, simulated[0]),
        "validation_procedure": data_description(validation, spec.validation, simulated[1]),
        "calibration_samples": len(calibration),
        "validation_samples": len(validation) if validation is not None else None,
        "temperature": [float(values.min()), float(values.max())] if values is not None else None,
        "traceability": traceability(device.instrument),
        "joint_ranges": joint_ranges(loaded, calibration),
    }


def joint_ranges(loaded: LoadedSpec, calibration) -> list[list[float] | None]:
    """[lowest, highest] reading of each joint over the calibration data, in the spec's unit of the joint's kind:
    where the calibrated model was fitted, not extrapolated (None: the data never read the joint)."""
    robot = loaded.spec.robot
    ranges = []
    for i, joint in enumerate(robot.joints):
        kind = joint_kind(joint.type)
        values = calibration.q[:, i][np.isfinite(calibration.q[:, i])]
        shown = [from_internal(float(v), kind, robot.units.of(kind)) for v in (values.min(), values.max())] if len(values) else None
        ranges.append(shown)
    return ranges


def traceability(instrument) -> dict | None:
    """The instrument's identity and calibration as the spec gives them (device.instrument), or None."""
    if instrument is None:
        return None
    return {**instrument.model_dump(), "calibrated": instrument.calibrated.isoformat() if instrument.calibrated else None}


def certificate_unit(spec) -> str:
    """The one length unit of a run's certificate and plots: report.unit, else the spec's length unit."""
    return spec.report.unit or spec.robot.units.length


def report_fields(loaded: LoadedSpec, created: str) -> dict:
    report = loaded.spec.report
    number = report.certificate_number or f"ARMCAL-{loaded.spec.robot.serial}-{created[:10]}-{loaded.sha256[:6].upper()}"
    return {
        "certificate_number": number,
        "unit": certificate_unit(loaded.spec),
        "customer": report.customer,
        "operator": report.operator,
        "location": report.location,
        "notes": report.notes,
    }
