"""One vocabulary for parameter counts: validate, run's terminal and the certificate show the same table.

Rows (what a parameter describes):
  robot         the chain: joints, tool (kinematics/params.py)
  instrument    the measuring set-up: targets on the robot (spheres, reflectors), pivots, stations,
                microphones, the bar's length, the instrument's scale
  registration  where the robot stands: its base pose and the instrument-to-robot transform
  effects       non-geometric effects, declared in the spec or added by the diagnosis
Columns: before data (validate) free / held by the spec; after the fit (run) identified /
not identifiable (free in the spec, but the data or the model cannot determine it: redundant,
no effect on the readings, parallel axes) / held by the spec. Free in validate = identified +
not identifiable in run, row by row, plus the effects the diagnosis added.
"""

from __future__ import annotations

ROWS = ("robot", "instrument", "registration", "effects")
SPEC_HELD = "fixed in the spec"


def row_of(name: str, role: str) -> str:
    """The row of a parameter from its name and role (chain, target, device, effect)."""
    if role == "effect":
        return "effects"
    if name.startswith(("base.", "robot_base.")):
        return "registration"
    return "instrument" if role in ("target", "device") else "robot"


def before_data(entries) -> dict[str, dict[str, int]]:
    """validate's table from ParameterInfo entries: per row, free (as the spec leaves them) and held by the spec."""
    table = {row: {"free": 0, "held_by_spec": 0} for row in ROWS}
    for e in entries:
        table[row_of(e.name, e.role)]["free" if e.free or e.reason else "held_by_spec"] += 1
    return table


def after_fit(entries, identified: set[str], reasons: dict[str, str]) -> dict[str, dict[str, int]]:
    """run's table: per row, identified, not identifiable, held by the spec (``reasons``: the fixed ones' reasons)."""
    table = {row: {"identified": 0, "not_identifiable": 0, "held_by_spec": 0} for row in ROWS}
    for e in entries:
        column = "identified" if e.name in identified else "held_by_spec" if reasons.get(e.name) == SPEC_HELD else "not_identifiable"
        table[row_of(e.name, e.role)][column] += 1
    return table


COLUMN_TITLES = {"free": "free", "identified": "identified", "not_identifiable": "not identifiable", "held_by_spec": "held by spec"}


def table_lines(table: dict[str, dict[str, int]], indent: str = "    ") -> list[str]:
    """The table as text: a header, one line per row that has parameters, and the totals."""
    columns = list(next(iter(table.values())))
    widths = [max(len(COLUMN_TITLES[c]), 5) for c in columns]
    line = lambda label, values: indent + f"{label:13s}" + "".join(f"{v:>{w + 2}}" for v, w in zip(values, widths))  # noqa: E731
    out = [line("", [COLUMN_TITLES[c] for c in columns] + []) + f"{'total':>8}"]
    totals = [0] * len(columns)
    for row, counts in table.items():
        values = [counts[c] for c in columns]
        if sum(values):
            out.append(line(row, values) + f"{sum(values):>8}")
            totals = [t + v for t, v in zip(totals, values)]
    out.append(line("total", totals) + f"{sum(totals):>8}")
    return out
