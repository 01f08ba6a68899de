"""The one rule for shown numbers (report/numbers.py) against independent computations with the decimal module."""

import math
import random
import re
from decimal import ROUND_HALF_EVEN, Decimal

import pytest

from armcal.report.numbers import (AT_THE_NOISE, given, improvement, measured, median_improvement, p_value, powers_of_ten,
                                   significant, task_noise)

E_NOTATION = re.compile(r"\d[eE][-+]?\d")


def _gum(value: float, uncertainty: float) -> str:
    """GUM 7.2.6 with decimal arithmetic: round U to two significant digits, the value to the same decimal."""
    u = Decimal(repr(uncertainty))
    exponent = u.adjusted()  # position of the leading digit
    two = u.quantize(Decimal(1).scaleb(exponent - 1), rounding=ROUND_HALF_EVEN)
    last = two.adjusted() - 1  # the second significant digit of the rounded U (0.0996 -> 0.10)
    places = max(0, -last)
    shown = Decimal(repr(value)).quantize(Decimal(1).scaleb(-places), rounding=ROUND_HALF_EVEN)
    return format(abs(shown) if shown == 0 else shown, "f")


def test_a_value_is_shown_to_the_decimal_of_its_uncertainty():
    generator = random.Random(7)
    for _ in range(2000):
        u = 10 ** generator.uniform(-7, 2)
        value = generator.uniform(-1, 1) * 10 ** generator.uniform(-9, 3)
        assert measured(value, u) == _gum(value, u), (value, u)


@pytest.mark.parametrize("value, uncertainty, shown", [(-8.76e-05, 0.012, "0.000"), (66.0634, 0.018, "66.063"), (-0.0004, 0.0096, "-0.0004"), (-0.00004, 0.0096, "0.0000"),
                                                       (1.00026, 0.00025, "1.00026"), (1855.2, 14.0, "1855"), (0.123, 0.0996, "0.12")])
def test_examples_of_the_rule(value, uncertainty, shown):
    """Below the resolution a value is 0 at that decimal (never -0, never e-notation); U 0.0996 rounds to 0.10."""
    assert measured(value, uncertainty) == shown


def test_given_numbers_read_back_and_carry_no_exponent():
    generator = random.Random(3)
    for _ in range(2000):
        value = float(f"{generator.uniform(-1, 1) * 10 ** generator.uniform(-12, 12):.6g}")
        text = given(value)
        assert not E_NOTATION.search(text) and float(text) == value
    assert given(-0.0) == "0" and significant(-0.4e-9, 6) == "-0.0000000004"


def test_p_values_never_read_0():
    assert [p_value(p) for p in (0.0387, 0.2, 0.001, 0.00099, 1e-300, 0.0)] == ["p = 0.039", "p = 0.2", "p = 0.001", "p < 0.001", "p < 0.001", "p < 0.001"]


def test_factors_mean_something_or_say_why_not():
    """Within the noise before: 'at the noise'; calibrated within it: bounded by the noise; else the ratio."""
    assert improvement(0.02, 0.001, 0.025) == AT_THE_NOISE
    assert improvement(1.79, -0.0002, 0.025) == "> 71.6"  # the x8948 of a calibrated -0.0002 mm
    assert improvement(-3.1534, 0.0473, 0.025) == "66.7"
    assert median_improvement(["66.7", "> 71.6", AT_THE_NOISE, "10.0"]) == f"median improvement at least x66.7 (1 of 4 {AT_THE_NOISE}, left out)"
    assert median_improvement([AT_THE_NOISE]) == f"every index {AT_THE_NOISE}"


def test_the_noise_of_an_angle_is_what_it_subtends_at_the_task():
    noise = task_noise(0.084, "mm", "deg", [0.0, 55.0, 55.0], "cm")
    assert noise == pytest.approx(math.degrees(0.084 / math.hypot(550.0, 550.0)), rel=1e-12)
    assert task_noise(0.084, "mm", "cm", None, "cm") == pytest.approx(0.0084) and task_noise(2.0, "arcsec", "mm", None, "mm") is None


def test_solver_tolerances_become_powers_of_ten():
    assert powers_of_ten("relative cost decrease below 1e-10") == "relative cost decrease below 10\u207b\u00b9\u2070"
    assert powers_of_ten("scaled step 2.3e-07 below 1e-08") == "scaled step 2.3 \u00d7 10\u207b\u2077 below 10\u207b\u2078"
