"""Write measurements as a contract CSV in the spec's units (deterministic text, atomic write)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from armcal.dataio.columns import layout
from armcal.dataio.measurements import Measurements
from armcal.devices import device_model
from armcal.support.fileio import csv_text, write_text_atomic
from armcal.spec.document import Spec
from armcal.support.units import factor


def _format(value: float, kind: str, spec: Spec) -> str:
    if np.isnan(value):
        return ""
    if kind in ("length", "angle"):
        value = value / factor(kind, getattr(spec.robot.units, kind))
    if kind == "direction":
        return f"{int(value):+d}"
    return f"{value:.10g}"


def measurements_csv(measurements: Measurements, spec: Spec) -> str:
    """The CSV text: sample, key columns, q1..qN, readings, then the optional columns present."""
    channels = list(measurements.readings)
    cols = layout(spec, channels, device_model(spec))
    n = spec.robot.dof
    extra = [c for c in measurements.extras if c != "dir"]
    width = len(cols.key_columns)
    used = [i for i in range(len(cols.optional_keys)) if any(len(k) > width + i and k[width + i] for k in measurements.keys)]
    present = cols.optional_keys[: max(used) + 1 if used else 0]  # up to the last optional key column any sample fills
    header = ["sample", *cols.key_columns, *present]
    header += [f"q{i}" for i in range(1, n + 1)] + channels + extra
    if "dir" in measurements.extras:
        header += [f"dir{i}" for i in range(1, n + 1)]
    rows = [header]
    kinds = cols.known
    for r, key in enumerate(measurements.keys):
        sample = measurements.sample[r] if measurements.sample else str(r + 1)
        fields = [sample, *((key[i] if i < len(key) else None) or "" for i in range(width + len(present)))]
        fields += [_format(v, kinds[f"q{i + 1}"], spec) for i, v in enumerate(measurements.q[r])]
        fields += [_format(measurements.readings[c][r], kinds[c], spec) for c in channels]
        fields += [_format(measurements.extras[c][r], kinds.get(c, "number"), spec) for c in extra]
        if "dir" in measurements.extras:
            fields += [_format(v, "direction", spec) for v in measurements.extras["dir"][r]]
        rows.append(fields)
    return csv_text(rows)


def write_measurements(path: Path, measurements: Measurements, spec: Spec) -> None:
    """Write the CSV whole, or leave any earlier file untouched."""
    write_text_atomic(path, measurements_csv(measurements, spec))
