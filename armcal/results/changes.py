"""Parameter changes between two calibrations of one robot, in units of their combined uncertainty.

Each parameter's change d = new - old is put in units of its combined standard uncertainty
u = sqrt(u_old^2 + u_new^2) (the two calibrations independent: separate campaigns), z = d / u,
and flagged significant where |z| > Z_SIGNIFICANT (two-sided 1 %). A parameter one side holds
(no uncertainty) is compared by its change alone. Used by ``armcal compare`` and the
certificate's history.
"""

from __future__ import annotations

import math

from armcal.errors import UserError

Z_SIGNIFICANT = 2.576  # two-sided 1 % of the normal distribution


def check_same_robot(earlier: dict, later: dict, shown: str, other: str) -> None:
    """A UserError naming ``shown`` when two results are of different serials."""
    if earlier["robot"]["serial"] != later["robot"]["serial"]:
        raise UserError(f"{shown}: serial {earlier['robot']['serial']} is not {later['robot']['serial']} of {other}: the calibrations compared must be of one robot")


def parameter_changes(old: dict, new: dict) -> list[dict]:
    """Each parameter of ``new`` that either results identified: name, unit, old, new, change, z (None without uncertainty)
    and significant."""
    before = {p["name"]: p for p in old["parameters"]}
    changes = []
    for p in new["parameters"]:
        q = before.get(p["name"])
        if q is None or not (p["free"] or q["free"]):
            continue
        change = p["value"] - q["value"]
        spread = math.hypot(p["std"] or 0.0, q["std"] or 0.0)
        z = change / spread if spread > 0 else None
        changes.append({"name": p["name"], "unit": p["unit"], "old": q["value"], "new": p["value"], "change": change, "z": z,
                        "significant": z is not None and abs(z) > Z_SIGNIFICANT})
    return changes
