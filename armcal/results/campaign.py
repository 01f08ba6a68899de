"""The campaign and report blocks of results.json: what was measured, and the certificate's fields."""

from __future__ import annotations

import numpy as np

from armcal.spec import LoadedSpec
from armcal.units import from_internal


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


def campaign(loaded: LoadedSpec, calibration, validation) -> dict:
    spec = loaded.spec
    device = spec.device
    length = spec.robot.units.length
    show = lambda v: f"{from_internal(v, 'length', length):g} {length}"  # noqa: E731
    if device.type == "sonic_digitizer":
        instrument = "sonic digitizer (slant ranges)"
        details = [f"microphones {', '.join(device.microphones)}", f"{len(device.calibration_rods)} calibration rods"]
    elif device.type == "ballbar":
        instrument = f"telescopic ball-bar, {show(device.length.value)} at mid-travel, travel {show(device.travel)}"
        details = [f"pivots {', '.join(device.pivots)}", f"spheres {', '.join(device.spheres)}"]
    elif device.type == "theodolite":
        instrument = "theodolite network" + (" with scale bar" if device.scale_bar else "")
        details = [f"stations {', '.join(device.stations)}", f"targets {', '.join(device.targets)}"]
    else:
        instrument = "laser tracker" + (" (position and orientation)" if device.orientation else "")
        details = [f"targets {', '.join(device.targets)}"]
    temperatures = [d.extras["temperature"] for d in (calibration, validation) if d is not None and "temperature" in d.extras]
    values = np.concatenate(temperatures) if temperatures else None
    return {
        "instrument": instrument,
        "details": details,
        "procedure": _procedure(spec.procedure),
        "validation_procedure": _procedure(spec.validation),
        "calibration_samples": len(calibration),
        "validation_samples": len(validation) if validation is not None else None,
        "temperature": [float(values.min()), float(values.max())] if values is not None else None,
    }


def report_fields(loaded: LoadedSpec, created: str) -> dict:
    report = loaded.spec.report
    number = report.certificate_number or f"ARMCAL-{loaded.spec.robot.serial}-{created[:10]}-{loaded.sha256[:6].upper()}"
    return {
        "certificate_number": number,
        "customer": report.customer,
        "operator": report.operator,
        "location": report.location,
        "notes": report.notes,
    }
