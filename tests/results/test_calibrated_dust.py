"""Values armcal computes are written as numbers the spec's input rules accept (issue 28, class 4): a rounding
residue far below SMALLEST (a pseudo-DH offset of 3e-32 mm between parallel axes, a fitted 1e-40) is written as 0,
and calibrated.yaml loads again; values above DUST are written to their 15 digits."""

from pathlib import Path

import pytest

from armcal.results.calibrated import calibrated_yaml
from armcal.spec.loader import load_spec, spec_from_bytes
from armcal.support.units import DUST, snapped

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("value", [3.1e-32, -1e-40, 1e-300, -0.0, 0.5 * DUST])
def test_rounding_dust_is_written_as_a_plain_zero(value):
    assert snapped(value) == 0.0 and str(snapped(value)) == "0.0"


def test_a_computed_value_below_the_input_rules_is_written_as_zero_and_the_spec_loads(tmp_path):
    source = ROOT / "specs" / "puma560_dh.yaml"
    loaded = load_spec(source)
    identified = {"j2.d": (3.1e-32, "length", False, None), "j3.d": (149.09 + 2 * DUST, "length", False, None),
                  "j4.d": (2 * DUST, "length", False, None)}
    text = calibrated_yaml(loaded.text, loaded.spec, identified, source, tmp_path, "# test")
    again = spec_from_bytes(text.encode(), tmp_path / "calibrated.yaml").spec
    assert again.robot.joints[1].d.value == 0.0
    assert again.robot.joints[2].d.value == pytest.approx(149.09 + 2 * DUST, abs=1e-13)
    assert again.robot.joints[3].d.value == pytest.approx(2 * DUST, rel=1e-12)  # above the dust: written as computed
