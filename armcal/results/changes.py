"""Parameter changes between two calibrations of one robot, in units of their combined uncertainty.

Each parameter's change d = new - old is put in units of its combined standard uncertainty
u = sqrt(u_old^2 + u_new^2) (the two calibrations independent: separate campaigns), z = d / u,
with its two-sided p-value; the changes are flagged significant by Holm's step-down test at a
family-wise ALPHA over every parameter compared, so that among forty unchanged parameters none
is flagged by chance more often than ALPHA of the time. A parameter neither calibration gives an
uncertainty for is compared by its change alone; values given in other units (mm and m, deg and rad) are converted
to the later calibration's. Used by ``armcal compare`` and the certificate's
history.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from scipy.stats import norm

from armcal.errors import UserError
from armcal.units import ANGLE_UNITS, LENGTH_UNITS

ALPHA = 0.01  # family-wise probability of flagging any unchanged parameter


def check_same_robot(serial: str, other_serial: str, shown: str, other: str) -> None:
    """A UserError naming ``shown`` when two calibrations are of different serials."""
    if serial != other_serial:
        raise UserError(f"{shown}: serial {serial} is not {other_serial} of {other}: the calibrations compared must be of one robot")


@dataclass(frozen=True)
class Change:
    name: str
    unit: str
    old: float
    new: float
    z: float | None  # None where neither calibration gives an uncertainty
    significant: bool = False


def _in_unit(row: dict, unit: str) -> dict:
    """A parameter row's value and std in ``unit`` (the later calibration's: a spec may have changed its units)."""
    if row["unit"] == unit:
        return row
    scales = next((table for table in (LENGTH_UNITS, ANGLE_UNITS) if row["unit"] in table and unit in table), None)
    if scales is None:
        raise UserError(f"{row['name']}: one calibration gives it in {row['unit']}, the other in {unit}; they cannot be compared")
    scale = scales[row["unit"]] / scales[unit]
    return {**row, "unit": unit, "value": row["value"] * scale, "std": None if row["std"] is None else row["std"] * scale}


def changes(old: list[dict], new: list[dict]) -> list[Change]:
    """Every parameter either calibration left free, with its change in combined standard uncertainties, the
    significant ones flagged by Holm's step-down test at family-wise ALPHA."""
    before = {p["name"]: p for p in old}
    rows = []
    for p in new:
        q = before.get(p["name"])
        if q is None or not (p["free"] or q["free"]):
            continue
        q = _in_unit(q, p["unit"])
        spread = math.hypot(p["std"] or 0.0, q["std"] or 0.0)
        rows.append(Change(p["name"], p["unit"], q["value"], p["value"], (p["value"] - q["value"]) / spread if spread > 0 else None))
    tested = sorted((i for i, c in enumerate(rows) if c.z is not None), key=lambda i: -abs(rows[i].z))
    for rank, i in enumerate(tested):
        if 2.0 * norm.sf(abs(rows[i].z)) > ALPHA / (len(tested) - rank):
            break
        rows[i] = replace(rows[i], significant=True)
    return rows
