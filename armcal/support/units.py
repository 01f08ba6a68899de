"""Units at the boundary: spec and CSV values in their units, internally mm and rad.

A quantity in a spec is a number (in the spec's default unit for its kind) or a
string with an explicit unit such as ``"43.18 cm"``, ``"2 arcsec"`` or ``"180°"`` (the degree
sign is read as deg).
"""

from __future__ import annotations

import math
import re

from armcal.support.errors import shown_value, with_article

LENGTH_UNITS: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "um": 1e-3, "in": 25.4}
ANGLE_UNITS: dict[str, float] = {
    "rad": 1.0,
    "deg": math.pi / 180.0,
    "arcmin": math.pi / (180.0 * 60.0),
    "arcsec": math.pi / (180.0 * 3600.0),
}
UNITS_BY_KIND: dict[str, dict[str, float]] = {
    "length": LENGTH_UNITS,
    "angle": ANGLE_UNITS,
    "scale": {"1": 1.0},
    "compliance": {"rad/(N m)": 1.0},  # joint deflection per gravity torque
    "per_degC": {"1/degC": 1.0},  # thermal expansion
    "per_s": {"1/s": 1.0},  # drift with time
}
ANGLE_ALIASES = {"°": "deg"}  # 180° and 90 ° read as degrees
INTERNAL_UNIT = {kind: next(iter(table)) if kind not in ("length", "angle") else {"length": "mm", "angle": "rad"}[kind] for kind, table in UNITS_BY_KIND.items()}

NUMBER = r"[-+]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"  # ASCII digits only: no '1_0', no '١', no '１'
_NUMBER = re.compile(NUMBER)
_NOT_FINITE = re.compile(r"[-+]?(?:inf|infinity|nan)", re.IGNORECASE)
_QUANTITY = re.compile(rf"^[ \t]*({NUMBER})[ \t]*([A-Za-z]+|°)?[ \t]*$")


def parse_number(text: str) -> float:
    """The number a file's text states, by one strict rule for every reader of numbers from files (URDF, data and
    targets CSV, spec quantities): ASCII only, an optional sign, digits with an optional '.', an optional exponent;
    nothing around it. ``inf``, ``infinity`` and ``nan`` (any case, signed) read as such, for the caller to refuse as
    not finite. Python's float() would also take '1_0' (10), Arabic-Indic or full-width digits and surrounding
    Unicode spaces; a ValueError (without the text) says it is no number."""
    if _NUMBER.fullmatch(text) or _NOT_FINITE.fullmatch(text):
        return float(text)
    raise ValueError("not a number")


def is_number(text: str) -> bool:
    """Whether ``text`` is a number by parse_number's rule."""
    try:
        parse_number(text)
    except ValueError:
        return False
    return True


def factor(kind: str, unit: str) -> float:
    """Multiplier from ``unit`` to the internal unit of ``kind``."""
    table = UNITS_BY_KIND[kind]
    if kind == "angle":
        unit = ANGLE_ALIASES.get(unit, unit)
    if unit not in table:
        raise ValueError(f"{shown_value(unit)} is not {with_article(kind)} unit; use one of {', '.join(table)}")
    return table[unit]


LARGEST = 1e9  # mm or rad: a kilometre a thousand times over; beyond it squares and sums lose all precision
SMALLEST = 1e-30  # below it a weight 1 / sigma overflows to infinity
DUST = 1e-12  # mm or rad (or deg, 1): a computed value smaller than this is rounding error, written as 0


def snapped(value: float) -> float:
    """A computed value as it is written into a spec: rounding dust (below DUST) as 0, never as -0.0.

    The spec's input rules (magnitudes SMALLEST to LARGEST, or 0) are for what a user writes; a value armcal
    computed, such as a pseudo-DH offset of 3e-32 mm between parallel axes, passes through here instead.
    """
    value = float(value)
    return 0.0 if abs(value) < DUST else value


def to_internal(value: float | int | str, kind: str, default_unit: str) -> float:
    """Convert a spec quantity (number or 'number unit' string) to mm / rad / 1."""
    if isinstance(value, bool):
        raise ValueError(f"expected {with_article(kind)}, got {shown_value(value)}")
    if isinstance(value, (int, float)):
        number, unit = float(value), default_unit
    elif isinstance(value, str):
        match = _QUANTITY.match(value)
        if not match:
            raise ValueError(f"expected {with_article(kind)} such as '12.5' or '12.5 {default_unit}', got {shown_value(value)}")
        number, unit = parse_number(match.group(1)), match.group(2) or default_unit
    else:
        raise ValueError(f"expected {with_article(kind)}, got {type(value).__name__}")
    if not math.isfinite(number):
        raise ValueError(f"expected a finite {kind}, got {shown_value(value)}")
    internal = number * factor(kind, unit)
    if abs(internal) > LARGEST or 0 < abs(internal) < SMALLEST:
        raise ValueError(f"{shown_value(value)} lies outside what armcal computes with: magnitudes {SMALLEST:g} to {LARGEST:g} {INTERNAL_UNIT[kind]}, or 0")
    return internal


def from_internal(value: float, kind: str, unit: str) -> float:
    """Convert an internal value back to ``unit``."""
    return value / factor(kind, unit)
