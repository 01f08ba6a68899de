"""Import the public ipa-robot-accuracy laser-tracker files (Landgraf et al., CASE 2021).

Their files are ';'-separated with decimal commas: six joint readings in rad
(shoulder_pan_joint .. wrist_3_joint), the measurement temperature in degC, the
6-DOF probe's position in mm and intrinsic XYZ Euler angles in deg, all in the
tracker frame. They become tracker measurements of one target.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.errors import Issue, SpecError, UserError

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
POSITION = ("measurement_x", "measurement_y", "measurement_z")
ORIENTATION = ("measurement_rx", "measurement_ry", "measurement_rz")


def read_ipa(path: Path, target: str) -> Measurements:
    """Measurements (internal units) of ``target`` from one ipa-robot-accuracy series file."""
    path = Path(path)
    try:
        rows = list(csv.reader(path.read_text(encoding="utf-8-sig").splitlines(), delimiter=";"))
    except OSError as exc:
        raise UserError(f"{path}: cannot read ({exc.strerror or exc})") from None
    header = [h.strip() for h in rows[0]]
    missing = [c for c in (*JOINTS, "measurement_temperature", *POSITION, *ORIENTATION) if c not in header]
    if missing:
        raise SpecError([Issue(path, 1, None, "", f"not an ipa-robot-accuracy file: missing {', '.join(missing)}")])
    column = {name: header.index(name) for name in header}

    def values(names, line_rows):
        out = np.empty((len(line_rows), len(names)))
        for i, row in enumerate(line_rows):
            for j, name in enumerate(names):
                try:
                    out[i, j] = float(row[column[name]].replace(",", "."))
                except (ValueError, IndexError):
                    raise SpecError([Issue(path, i + 2, column[name] + 1, name, f"'{row[column[name]] if column[name] < len(row) else ''}' is not a number")]) from None
        return out

    data = [row for row in rows[1:] if any(field.strip() for field in row)]
    q = values(JOINTS, data)
    position = values(POSITION, data)
    orientation = np.radians(values(ORIENTATION, data))
    readings = {name: position[:, i] for i, name in enumerate("xyz")}
    readings.update({name: orientation[:, i] for i, name in enumerate(("rx", "ry", "rz"))})
    extras = {"temperature": values(("measurement_temperature",), data)[:, 0]}
    return Measurements(keys=tuple((target,) for _ in data), q=q, readings=readings, extras=extras, rows=np.arange(2, len(data) + 2), source=path)
