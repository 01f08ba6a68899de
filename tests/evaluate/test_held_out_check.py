"""A calibration that fits its own data but predicts held-out readings poorly says why (evaluate/held_out_check.py).

Oracles: simulated campaigns whose truth is known (armcal's simulator draws the robot, the model under test only
fits it): with a complete model the held-out residuals are noise plus the parameters' propagated uncertainty
(consistent), and the held-out RMS in noise sigmas is the validation RMS over the declared sigma; the same data
with the held-out readings shifted by 1.6 sigma (as if the tracker had moved) exceed that prediction; a ball-bar
fixture whose calibration poses leave a flat direction predicts the held-out error it then shows.
"""

import csv

import numpy as np
import pytest
from conftest import armcal_cli, copy_example

from armcal.evaluate.held_out_check import NOISE_MULTIPLE, _chi2
from armcal.identify.precision import WEAK
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.commands.run import run
from armcal.commands.terminal import held_out_lines

NOISE_MM = 0.025  # examples/hidden_harmonic: device.noise 0.0025 cm


def _shift_x(path, by_cm: float) -> None:
    rows = list(csv.DictReader(path.open()))
    for row in rows:
        row["x"] = f"{float(row['x']) + by_cm:.10g}"
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_a_complete_model_is_consistent_and_a_moved_instrument_is_not(tmp_path):
    copy_example("hidden_harmonic", tmp_path)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    check = results.held_out_check
    assert check.verdict == "consistent" and check.p_value > 0.01
    assert check.rms_over_noise == pytest.approx(results.residuals.validation.after.rms / NOISE_MM, rel=1e-6)
    assert check.parameter_share < 0.5 and not held_out_lines(results)

    _shift_x(tmp_path / "validation.csv", 0.004)  # 0.04 mm = 1.6 sigma on every x
    moved = run(tmp_path / "spec.yaml", tmp_path / "out2", pdf=False).results
    assert moved.held_out_check.verdict == "beyond_prediction" and moved.held_out_check.p_value < 1e-6
    assert moved.residuals.calibration.after.rms == pytest.approx(results.residuals.calibration.after.rms, rel=1e-9)
    text = "\n".join(held_out_lines(moved))
    assert "more than the calibrated model explains" in text and "data.instrument_moved" in text


# Goswami's shells (Fig. 2), every chuck with every sphere, and the same shells with an extension rod held out: on the
# shells' fixed axis (halfway between down and the chuck) a sphere's offset along it is nearly flat (docs/devices/ballbar.md)
PAIRINGS = "".join(f"\n    - {{pivot: chuck{p}, sphere: sphere{q}}}" for p in (1, 2, 3) for q in (1, 2, 3))
SHELLS = f"  type: shells\n  pairings:{PAIRINGS}\n  latitudes: [20, 35, 50, 65, 80]\n  longitudes: 23\n"


def _on_fixed_shells(spec) -> None:
    """`armcal new`'s ball-bar spec read on Goswami's fixed shells instead of its random points on them."""
    text = spec.read_text()
    head, rest = text.split("procedure:", 1)
    tail = rest[rest.index("# The stand-ins above"):]
    head = head.replace("  travel:", "  extension_rods: {rod: 170}\n  travel:", 1)
    spec.write_text(f"{head}procedure:\n{SHELLS}validation:\n{SHELLS}  extension: rod\n{tail}")


def test_a_flat_direction_explains_a_poor_held_out_prediction(tmp_path):
    """`armcal new`'s ball-bar fixture for the KR 6 (pivots and spheres free) read on Goswami's fixed shells, with a
    tolerance so wide that nothing is held as weakly identifiable: the calibration matches its noise, the held-out
    shells are about 6 sigmas off, and that is what the parameters' uncertainty along the flat direction predicts.
    With the default tolerance the poorly determined robot values are held at nominal instead (identify/precision.py):
    the held-out residuals are a fraction of that, and what is left of them names the held values first."""
    spec = tmp_path / "spec.yaml"
    result = armcal_cli("new", "--robot", "kuka_kr6_r900_sixx", "--device", "ballbar", "--out", spec)
    assert result.returncode == 0, result.stderr
    _on_fixed_shells(spec)
    result = armcal_cli("simulate", spec)
    assert result.returncode == 0, result.stderr
    text = spec.read_text()
    wide = tmp_path / "wide.yaml"
    wide.write_text(text.replace("\nrobot:\n", "\nrobot:\n  tolerance: {length: 100 mm, angle: 20 deg}\n", 1))
    assert wide.read_text() != text  # the same data, read by the wide spec
    results = run(wide, tmp_path / "out", pdf=False).results
    check = results.held_out_check
    assert results.noise_check.verdict != "residuals_too_large"
    assert check.verdict == "parameter_uncertainty"
    # a margin from every threshold the verdict takes, so that no processor's last bits can flip it
    assert check.p_value > 5 * NOISE_CHECK_LEVEL and check.rms_over_noise > 2 * NOISE_MULTIPLE and check.parameter_share > 0.9
    assert check.expected_rms_over_noise == pytest.approx(check.rms_over_noise, rel=0.5)
    lines = "\n".join(held_out_lines(results))
    flat = results.identifiability.flat_directions[0].parameters[0][0]
    assert "the parameters' own uncertainty" in lines and flat in lines and "armcal plan" in lines

    held = run(spec, tmp_path / "held", pdf=False).results
    weak = [f.name for f in held.identifiability.fixed if f.reason.startswith(WEAK)]
    assert weak and held.held_out_check.verdict != "parameter_uncertainty"
    assert held.held_out_check.rms_over_noise < check.rms_over_noise / 2
    if held.held_out_check.verdict == "beyond_prediction":
        assert f"as {WEAK} differs from the robot's: {', '.join(weak)}" in held_out_lines(held)[1]


def test_the_held_out_chi2_is_the_quadratic_form_of_the_full_covariance_and_chi2_distributed():
    """_chi2 against a dense r' S^-1 r (S = I + A C A'), and over draws from that model a mean of n and a
    variance of 2n: one flat direction shared by every reading counts once, not once per reading."""
    rng = np.random.default_rng(3)
    n, p = 60, 5
    A = rng.normal(size=(n, p))
    root = rng.normal(size=(p, p)) * np.array([1e-3, 0.1, 1.0, 3.0, 30.0])  # one direction far flatter than the rest
    C = root @ root.T
    S = np.eye(n) + A @ C @ A.T
    r = rng.normal(size=n)
    assert _chi2(r, A, C) == pytest.approx(r @ np.linalg.solve(S, r), rel=1e-9)
    draws = np.array([_chi2(A @ (root @ rng.normal(size=p)) + rng.normal(size=n), A, C) for _ in range(4000)])
    assert draws.mean() == pytest.approx(n, abs=4 * np.sqrt(2 * n / 4000))
    assert draws.var() == pytest.approx(2 * n, rel=0.15)


def test_a_declared_noise_too_small_is_named_first_when_the_held_out_data_exceed_the_prediction():
    """The noise term is the declared noise, so residuals too large for it on the calibration data exceed the held-out
    prediction too: the terminal then names the declared noise before the other causes."""
    from types import SimpleNamespace

    check = SimpleNamespace(verdict="beyond_prediction", rms_over_noise=3.1, expected_rms_over_noise=1.2, chi2=900.0, dof=100,
                            p_value=1e-30, held_out_only=[], parameter_share=0.1)
    for verdict, first in (("residuals_too_large", "the declared noise is too small"), ("consistent", "the instrument moved")):
        r = SimpleNamespace(held_out_check=check, noise_check=SimpleNamespace(verdict=verdict, chi2=950.0, dof=100),
                            identifiability=SimpleNamespace(fixed=[]))
        causes = held_out_lines(r)[1].split("likely causes: ")[1]
        assert causes.startswith(first), causes
