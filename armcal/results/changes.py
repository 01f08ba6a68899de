"""Parameter changes between two calibrations of one robot, in units of their combined uncertainty.

A parameter is compared only where both calibrations identified it (in the base set, with an uncertainty): one
that either side held (in the spec, or as redundant with another: two campaigns of one robot may carry a redundant
pair's sum on different members) or does not have is "not comparable", with the side and the reason, and is never
given a z: its value there is a convention, not a measurement. For each compared parameter the change
d = new - old is put in units of its combined standard uncertainty u = sqrt(u_old^2 + u_new^2) (the two
calibrations independent: separate campaigns), z = d / u, with its two-sided p-value; the changes are flagged
significant by Holm's step-down test (Holm 1979, "A simple sequentially rejective multiple test procedure") at a
family-wise ALPHA over every parameter compared, so that among forty unchanged parameters none is flagged by chance
more often than ALPHA of the time. Values given in other units (mm and m, deg and rad) are converted to the later
calibration's. Used by ``armcal compare`` and the certificate's history.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from scipy.stats import norm

from armcal.errors import UserError
from armcal.evaluate.multiple_testing import ALPHA, holm
from armcal.units import ANGLE_UNITS, LENGTH_UNITS


def check_same_robot(serial: str, other_serial: str, shown: str, other: str) -> None:
    """A UserError naming ``shown`` when two calibrations are of different serials."""
    if serial != other_serial:
        raise UserError(f"{shown}: serial {serial} is not {other_serial} of {other}: the calibrations compared must be of one robot")


@dataclass(frozen=True)
class Change:
    name: str
    unit: str
    old: float | None  # None: absent on that side
    new: float | None
    z: float | None  # None where the parameter is not comparable
    significant: bool = False
    not_comparable: str | None = None  # which side did not identify it, and why


def _unidentified(row: dict | None, reasons: dict[str, str]) -> str | None:
    """Why one side's row is not an identified value with an uncertainty (None when it is)."""
    if row is None:
        return "absent"
    if not row["free"]:
        return reasons.get(row["name"], "held")
    return None if row["std"] is not None else "not identified (no std)"


def _in_unit(row: dict, unit: str) -> dict:
    """A parameter row's value and std in ``unit`` (the later calibration's: a spec may have changed its units)."""
    if row["unit"] == unit:
        return row
    scales = next((table for table in (LENGTH_UNITS, ANGLE_UNITS) if row["unit"] in table and unit in table), None)
    if scales is None:
        raise UserError(f"{row['name']}: one calibration gives it in {row['unit']}, the other in {unit}; they cannot be compared")
    scale = scales[row["unit"]] / scales[unit]
    return {**row, "unit": unit, "value": row["value"] * scale, "std": None if row["std"] is None else row["std"] * scale}


def held_reasons(results: dict) -> dict[str, str]:
    """Why a results.json held each parameter it held, by name (identifiability.fixed)."""
    return {f["name"]: f["reason"] for f in results["identifiability"]["fixed"]}


def changes(old: list[dict], new: list[dict], old_reasons: dict[str, str] | None = None,
            new_reasons: dict[str, str] | None = None) -> list[Change]:
    """Every parameter either calibration identified: with its change in combined standard uncertainties where both
    did, the significant ones flagged by Holm's test at family-wise ALPHA; else "not comparable" and why (the sides'
    ``reasons``, by name, say why a parameter was held: held_reasons)."""
    before, after = {p["name"]: p for p in old}, {p["name"]: p for p in new}
    rows = []
    for name in [*after, *(n for n in before if n not in after)]:
        p, q = after.get(name), before.get(name)
        if not any(row is not None and row["free"] for row in (p, q)):
            continue
        unit = (p or q)["unit"]
        q = q and _in_unit(q, unit)
        why = [f"{side}: {reason}" for side, reason in (("old", _unidentified(q, old_reasons or {})), ("new", _unidentified(p, new_reasons or {}))) if reason]
        spread = 0.0 if why else math.hypot(p["std"], q["std"])
        if not why and spread == 0:
            why = ["no uncertainty on either side"]
        rows.append(Change(name, unit, q and q["value"], p and p["value"], None if why else (p["value"] - q["value"]) / spread,
                           not_comparable="; ".join(why) or None))
    tested = [i for i, c in enumerate(rows) if c.z is not None]
    for i, rejected in zip(tested, holm([2.0 * norm.sf(abs(rows[i].z)) for i in tested])):
        rows[i] = replace(rows[i], significant=rejected)
    return rows
