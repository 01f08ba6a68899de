"""How the certificate and the terminal show a number: one rule for every table.

A measured value is shown to the decimal of its uncertainty, the uncertainty to two significant digits (GUM, JCGM
100:2008 7.2.6); a value without one (a residual statistic, a task index) to the decimal of the instrument's noise
per reading, taken the same way. A value below that decimal reads 0 at that decimal, never in e-notation beside
fixed decimals, and never -0. A value the spec gave (a held parameter) is shown as given: the shortest decimal that
reads back as the same number. Improvement factors are shown only where they mean something (``improvement``).
"""

from __future__ import annotations

import math
import re
import statistics

import numpy as np

from armcal.support.units import ANGLE_UNITS, LENGTH_UNITS, factor

SIGNIFICANT = 2  # significant digits of an uncertainty (GUM 7.2.6)
MAX_DECIMALS = 12  # a decimal finer than any instrument's resolution in mm, deg or a ratio
SMALLEST_P = 0.001  # p-values below are shown as "p < 0.001"
AT_THE_NOISE = "at the noise"


def decimals(uncertainty: float | None, default: int = 4) -> int:
    """Decimals that show ``uncertainty`` to two significant digits (none at 10 or more); ``default`` without one."""
    if uncertainty is None or not math.isfinite(uncertainty) or uncertainty <= 0:
        return default
    rounded = float(f"{uncertainty:.{SIGNIFICANT - 1}e}")  # 0.0996 -> 0.10: two digits of the rounded value
    return int(min(MAX_DECIMALS, max(0, SIGNIFICANT - 1 - math.floor(math.log10(rounded)))))


def fixed(value: float | None, places: int) -> str:
    """``value`` at ``places`` decimals in positional notation; '-' for no value; 0 for what rounds to zero."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    text = f"{value:.{places}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def measured(value: float | None, uncertainty: float | None, default: int = 4) -> str:
    """A value to the decimal of its uncertainty (GUM 7.2.6)."""
    return fixed(value, decimals(uncertainty, default))


def given(value: float) -> str:
    """A number as the spec gave it: the shortest decimal that reads back as ``value``, no exponent."""
    text = np.format_float_positional(value, trim="-")
    return "0" if float(text) == 0 else text


def significant(value: float, digits: int = 6) -> str:
    """``value`` to ``digits`` significant digits, positional (a value with no uncertainty or resolution of its own)."""
    return given(float(f"{value:.{digits}g}"))


E_NOTATION = re.compile(r"(?<![\w.])([-+]?\d+(?:\.\d+)?)[eE]([-+]?\d+)(?![\w.])")
SUPERSCRIPT = str.maketrans("-+0123456789", "\u207b\u207a\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def powers_of_ten(text: str) -> str:
    """A message's numbers in e-notation (a solver's tolerance, '1e-10') written as powers of ten ('10\u207b\u00b9\u2070')."""
    def written(match: re.Match) -> str:
        mantissa, exponent = match.group(1), str(int(match.group(2))).translate(SUPERSCRIPT)
        return f"10{exponent}" if float(mantissa) == 1 else f"{mantissa} \u00d7 10{exponent}"

    return E_NOTATION.sub(written, text)


def p_value(p: float) -> str:
    """'p = 0.039' with two significant digits, 'p < 0.001' below (where it may underflow to 0)."""
    if p < SMALLEST_P:
        return f"p < {SMALLEST_P:g}"
    return f"p = {float(f'{p:.2g}'):g}"


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """'1 iteration', '6 iterations'."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def ratio(before: float | None, after: float | None, noise: float | None) -> str:
    """How many times the calibration reduced a figure (magnitudes): before / after; 'at the noise' where the figure
    was within the noise before."""
    if before is None or after is None:
        return "-"
    if noise is not None and abs(before) <= noise:
        return AT_THE_NOISE
    return f"{abs(before) / abs(after):.1f}" if after else "-"


def improvement(before: float | None, after: float | None, noise: float | None) -> str:
    """``ratio`` of a task index, bounded by what the instrument resolves: where the calibrated figure is within the
    noise, before / after would divide by noise, and the factor reads '> N' with N = before / noise."""
    shown = ratio(before, after, noise)
    if shown in ("-", AT_THE_NOISE) or noise is None or abs(after) > noise:
        return shown
    return f"> {abs(before) / noise:.1f}"


def task_noise(noise: float | None, noise_unit: str, unit: str, centre: list[float] | None, centre_unit: str) -> float | None:
    """What an instrument of per-reading noise ``noise`` (in ``noise_unit``) resolves of a task index in ``unit``: the
    noise itself for a length; for an angle, the angle it subtends at the task's distance from the robot base
    (``centre`` in ``centre_unit``). None where the noise is unknown or not a length."""
    if noise is None or noise_unit not in LENGTH_UNITS:
        return None
    in_mm = noise * factor("length", noise_unit)
    if unit in LENGTH_UNITS:
        return in_mm / factor("length", unit)
    distance = math.dist(centre or (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)) * factor("length", centre_unit)
    return in_mm / distance / factor("angle", unit) if unit in ANGLE_UNITS and distance > 0 else None


def median_improvement(factors: list[str]) -> str:
    """The median of task factors (``improvement`` texts), lines at the noise left out; 'at least' where bounds count."""
    values = [factor_value(f) for f in factors]
    kept = [v for v in values if v is not None]
    if not kept:
        return f"every index {AT_THE_NOISE}" if factors else "no index"
    bound = any(f.startswith("> ") for f in factors)
    left = len(factors) - len(kept)
    return (f"median improvement {'at least ' if bound else ''}x{statistics.median(kept):.3g}"
            + (f" ({left} of {len(factors)} {AT_THE_NOISE}, left out)" if left else ""))


def factor_value(shown: str) -> float | None:
    """The number an ``improvement`` text states (the bound for '> N'), None for 'at the noise' or '-'."""
    text = shown.removeprefix("> ")
    try:
        return float(text)
    except ValueError:
        return None
