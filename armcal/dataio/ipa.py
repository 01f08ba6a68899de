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
from armcal.dataio.reader import data_text
from armcal.support.errors import Issue, SpecError
from armcal.support.units import parse_number

JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
POSITION = ("measurement_x", "measurement_y", "measurement_z")
ORIENTATION = ("measurement_rx", "measurement_ry", "measurement_rz")


def read_ipa(path: Path, target: str, orientation: bool) -> Measurements:
    """Measurements (internal units) of ``target`` from one ipa-robot-accuracy series file
    (with the probe's orientations when ``orientation``)."""
    path = Path(path)
    rows = list(csv.reader(data_text(path).splitlines(), delimiter=";"))
    if not rows:
        raise SpecError([Issue(path, 1, None, "", "the file is empty; an ipa-robot-accuracy header row is expected")])
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
                    out[i, j] = parse_number(row[column[name]].strip(" \t").replace(",", "."))  # its decimal mark is ','
                except (ValueError, IndexError):
                    raise SpecError([Issue(path, i + 2, column[name] + 1, name, "not a number")]) from None
        return out

    data = [row for row in rows[1:] if any(field.strip() for field in row)]
    q = values(JOINTS, data)
    position = values(POSITION, data)
    readings = {name: position[:, i] for i, name in enumerate("xyz")}
    if orientation:
        angles = np.radians(values(ORIENTATION, data))
        readings.update({name: angles[:, i] for i, name in enumerate(("rx", "ry", "rz"))})
    extras = {"temperature": values(("measurement_temperature",), data)[:, 0]}
    return Measurements(keys=tuple((target,) for _ in data), q=q, readings=readings, extras=extras, rows=np.arange(2, len(data) + 2), source=path)
