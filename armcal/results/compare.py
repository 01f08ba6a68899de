"""Recalibration over time: two calibrations of one robot, parameter by parameter.

Each parameter's change d = new - old is put in units of its combined standard uncertainty
u = sqrt(u_old^2 + u_new^2) (the two calibrations independent: separate campaigns), z = d / u,
and flagged significant where |z| > Z_SIGNIFICANT (two-sided 1 %). A parameter one side holds
(no uncertainty) is compared by its change alone.
"""

from __future__ import annotations

import math
from pathlib import Path

from armcal.errors import UserError
from armcal.report.render import read_results, results_file

Z_SIGNIFICANT = 2.576  # two-sided 1 % of the normal distribution


def compare(old_path: Path, new_path: Path) -> tuple[str, int]:
    """A plain-text table of the parameters of two results (a results.json or a run's folder) and the number of
    significant changes."""
    old, new = read_results(results_file(old_path)), read_results(results_file(new_path))
    if old["robot"]["serial"] != new["robot"]["serial"]:
        raise UserError(f"{new_path}: serial {new['robot']['serial']} is not {old['robot']['serial']} of {old_path}: compare calibrations of one robot")
    before = {p["name"]: p for p in old["parameters"]}
    lines = [
        f"{new['robot']['name']} ({new['robot']['serial']}): {old['created'][:10]} (run {old.get('run_id')}) -> {new['created'][:10]} (run {new.get('run_id')})",
        f"{'parameter':32} {'old':>14} {'new':>14} {'change':>12} {'unit':8} {'z':>7}",
    ]
    significant = 0
    for p in new["parameters"]:
        q = before.get(p["name"])
        if q is None or not (p["free"] or q["free"]):
            continue
        change = p["value"] - q["value"]
        spread = math.hypot(p["std"] or 0.0, q["std"] or 0.0)
        z = change / spread if spread > 0 else None
        flag = z is not None and abs(z) > Z_SIGNIFICANT
        significant += flag
        shown_z = f"{z:7.2f}" if z is not None else "      -"
        lines.append(f"{p['name']:32} {q['value']:14.6g} {p['value']:14.6g} {change:12.4g} {p['unit']:8} {shown_z}" + ("  significant" if flag else ""))
    lines.append(f"{significant} significant change(s) (|z| > {Z_SIGNIFICANT}: two-sided 1 %, z = change / sqrt(u_old^2 + u_new^2))")
    return "\n".join(lines) + "\n", significant
