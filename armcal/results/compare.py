"""``armcal compare``: two calibrations of one robot, parameter by parameter (results/changes.py)."""

from __future__ import annotations

from pathlib import Path

from armcal.report.render import read_results, results_file
from armcal.results.changes import Z_SIGNIFICANT, check_same_robot, parameter_changes


def compare(old_path: Path, new_path: Path) -> tuple[str, int]:
    """A plain-text table of the parameters of two results (a results.json or a run's folder) and the number of
    significant changes."""
    old, new = read_results(results_file(old_path)), read_results(results_file(new_path))
    check_same_robot(new, old, str(new_path), str(old_path))
    lines = [
        f"{new['robot']['name']} ({new['robot']['serial']}): {old['created'][:10]} (run {old.get('run_id')}) -> {new['created'][:10]} (run {new.get('run_id')})",
        f"{'parameter':32} {'old':>14} {'new':>14} {'change':>12} {'unit':8} {'z':>7}",
    ]
    changes = parameter_changes(old, new)
    for c in changes:
        shown_z = f"{c['z']:7.2f}" if c["z"] is not None else "      -"
        lines.append(f"{c['name']:32} {c['old']:14.6g} {c['new']:14.6g} {c['change']:12.4g} {c['unit']:8} {shown_z}" + ("  significant" if c["significant"] else ""))
    significant = sum(c["significant"] for c in changes)
    lines.append(f"{significant} significant change(s) (|z| > {Z_SIGNIFICANT}: two-sided 1 %, z = change / sqrt(u_old^2 + u_new^2))")
    return "\n".join(lines) + "\n", significant
