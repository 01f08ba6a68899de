"""Noise from the data: Foerstner's variance component estimation per group of readings (identify/variance.py).

The campaigns are the fitted model at a known truth (its base parameters moved, identify_helpers) read with
noise drawn here, group by group, at sigmas the test chooses: the truth the estimates are held to. The fitted
specs declare other sigmas (off by 10-100x in ratio) or ``auto``.
"""

import numpy as np
import pytest
from conftest import SPECS
from identify_helpers import measure, setup, truth

from armcal.dataio.measurements import Measurements
from armcal.devices import device_model
from armcal.diagnose.calibration import identify_and_diagnose
from armcal.support.errors import SpecError, UserError
from armcal.identify.problem import build_problem, reweighted
from armcal.spec import load_spec

DEG = np.pi / 180
ARCSEC = DEG / 3600
NO_DIAGNOSIS = ("armcal: 1\n", "armcal: 1\ndiagnose: {enabled: false}\n")
UR10_TWO_TARGETS = [
    NO_DIAGNOSIS,
    ("  count: 2773\n", "  count: 300\n  seed: 5\n"),
    ("  count: 632\n", "  count: 20\n"),
    ("    tmac: {link: 6,", "    side: {link: 6, x: 80.0, y: 0.0, z: 60.0}\n    tmac: {link: 6,"),
    ("  targets: [tmac]\n", "  targets: [tmac, side]\n"),
]
DECLARED = ("  noise: 0.03\n  orientation_noise: 0.002\n  estimate_noise: true\n",)  # what specs/ur10.yaml declares
AS_DECLARED = (DECLARED[0], "  noise: 0.03\n  orientation_noise: 0.002\n")  # no estimation


def _spec_text(path, changes) -> str:
    text = path.read_text()
    for old, new in changes:
        assert old in text, old
        text = text.replace(old, new, 1)
    return text


def _load(tmp_path, text: str):
    path = tmp_path / "fit.yaml"
    path.write_text(text)
    return load_spec(path).spec


def _with_noise(data: Measurements, sigma, rng) -> Measurements:
    """Readings plus Gaussian noise of sigma(key, channel) (internal units), drawn here: the truth of the test."""
    readings = {name: values.copy() for name, values in data.readings.items()}
    for i, key in enumerate(data.keys):
        for name, column in readings.items():
            if not np.isnan(column[i]):
                column[i] += rng.normal() * sigma(key, name)
    return Measurements(keys=data.keys, q=data.q, readings=readings, extras=data.extras)


def _campaign(spec_path, changes, sigma, seed):
    case = setup(spec_path, changes)
    rng = np.random.default_rng(seed)
    exact = measure(case.kinematics, case.device, case.plans[0], truth(case, rng), None)
    return case, _with_noise(exact, sigma, rng)


def _calibrate(tmp_path, spec_path, changes, data):
    spec = _load(tmp_path, _spec_text(spec_path, changes))
    device = device_model(spec)
    from armcal.kinematics.compiler import compile_robot

    return identify_and_diagnose(spec, compile_robot(spec.robot.chain()), device, data, device.prepare(data), None)


TRACKER_TRUTH = {"tmac": (0.05, 0.01 * DEG), "side": (0.2, 0.004 * DEG)}  # mm, rad: position and orientation sigma


def _tracker_sigma(key, channel):
    position, orientation = TRACKER_TRUTH[key[0]]
    return position if channel in "xyz" else orientation


@pytest.fixture(scope="module")
def tracker_campaign():
    return _campaign(SPECS / "ur10.yaml", UR10_TWO_TARGETS, _tracker_sigma, seed=3)[1]


@pytest.mark.parametrize(
    "noise",
    [
        "  noise: auto\n  orientation_noise: auto\n",  # nothing declared
        "  noise: 0.05\n  orientation_noise: 0.0001\n  estimate_noise: true\n",  # ratio 500 mm/deg declared; truth 5 and 50
        "  noise: 1.0\n  orientation_noise: 0.01\n  estimate_noise: true\n",  # ratio 100 mm/deg, every sigma off by 5-20x
    ],
    ids=["auto", "ratio_x100", "all_off"],
)
def test_tracker_sigmas_per_kind_and_target_within_ten_percent(tmp_path, tracker_campaign, noise):
    """Positions in mm and orientations in deg, two targets of different noise: four groups, each within 10 %."""
    changes = [*UR10_TWO_TARGETS, (DECLARED[0], noise + "  noise_groups: [kind, target]\n")]
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", changes, tracker_campaign)
    estimates = calibrated.noise
    assert estimates.converged and estimates.rounds <= 20
    found = {g.group: g for g in estimates.groups}
    assert set(found) == {"position, target tmac", "orientation, target tmac", "position, target side", "orientation, target side"}
    for target, (position, orientation) in TRACKER_TRUTH.items():
        for kind, true in (("position", position), ("orientation", orientation)):
            group = found[f"{kind}, target {target}"]
            assert group.kind == ("length" if kind == "position" else "angle")
            assert group.readings == 900
            assert abs(group.sigma / true - 1) < 0.10, (group.group, group.sigma, true)
            assert group.std == pytest.approx(group.sigma / np.sqrt(2 * group.redundancy))
            assert group.interval[0] < group.sigma < group.interval[1]
    redundancy = sum(g.redundancy for g in estimates.groups)
    fitted = calibrated.identified.least_squares
    assert redundancy == pytest.approx(len(calibrated.problem.residuals.sigma) - len(fitted.base), rel=1e-9)
    # the estimates are the weights: the final fit's residuals have the noise they say
    assert fitted.uncertainty.verdict == "consistent"
    assert fitted.uncertainty.chi2 / fitted.uncertainty.dof == pytest.approx(1.0, abs=0.01)


def test_declared_sigmas_are_tested_against_the_estimates(tmp_path, tracker_campaign):
    """estimate_noise: the declared orientation sigma (10x too small) is rejected, the right position sigma is not."""
    noise = "  noise: 0.05\n  orientation_noise: 0.001\n  estimate_noise: true\n  noise_groups: [target]\n"
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", [*UR10_TWO_TARGETS, (DECLARED[0], noise)], tracker_campaign)
    found = {g.group: g for g in calibrated.noise.groups}
    right = found["position, target tmac"]
    assert right.declared == pytest.approx(0.05) and right.test.verdict == "consistent" and right.test.p_value > 0.01
    too_small = found["orientation, target tmac"]
    assert too_small.test.verdict == "declared_too_small" and too_small.test.p_value < 1e-10
    assert too_small.test.statistic == pytest.approx(too_small.redundancy * (too_small.sigma / (0.001 * DEG)) ** 2)
    assert found["position, target side"].test.verdict == "declared_too_small"  # 0.05 mm declared, 0.2 true
    assert found["orientation, target side"].test.verdict == "declared_too_small"  # 0.001 deg declared, 0.004 true
    assert {g.group for g in calibrated.noise.rejected} == set(found) - {"position, target tmac"}


def test_a_declared_sigma_too_large_is_said(tmp_path, tracker_campaign):
    noise = "  noise: 0.5\n  orientation_noise: 0.01\n  estimate_noise: true\n  noise_groups: [target]\n"
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", [*UR10_TWO_TARGETS, (DECLARED[0], noise)], tracker_campaign)
    found = {g.group: g for g in calibrated.noise.groups}
    assert found["position, target tmac"].test.verdict == "declared_too_large"  # 0.5 declared, 0.05 true
    assert found["orientation, target tmac"].test.verdict == "consistent"  # 0.01 deg declared and true


def test_theodolite_sigma_per_station(tmp_path):
    """Two stations, 2 and 8 arcsec: noise: auto, noise_groups: [station]; the scale bar's length keeps its certificate."""
    truth_sigma = {"t1": 2 * ARCSEC, "t2": 8 * ARCSEC}
    changes = [NO_DIAGNOSIS, ("  count: 150\n", "  count: 300\n")]
    _, data = _campaign(SPECS / "puma560_theodolite.yaml", changes, lambda key, _: truth_sigma[key[0]], seed=4)
    fit_changes = [*changes, ("  noise: 2 arcsec\n", "  noise: auto\n  noise_groups: [station]\n")]
    calibrated = _calibrate(tmp_path, SPECS / "puma560_theodolite.yaml", fit_changes, data)
    found = {g.group: g for g in calibrated.noise.groups}
    assert set(found) == {"angle, station t1", "angle, station t2"}
    for station, true in truth_sigma.items():
        group = found[f"angle, station {station}"]
        assert group.declared is None and group.test is None
        assert abs(group.sigma / true - 1) < 0.10, (station, group.sigma / ARCSEC)
    bar = [s for s, k in zip(calibrated.problem.residuals.sigma, calibrated.problem.residuals.key) if k == ("scale_bar",)]
    assert bar == [pytest.approx(0.01)]  # mm, as the spec's scale_bar.noise declares


def test_ballbar_sigma_per_pairing(tmp_path):
    """Nine pairings of different noise: each estimate within 3.5 of its own standard deviations of the truth, and
    the standard deviations honest (the z-scores' RMS near 1)."""
    spec_path = SPECS / "goswami_puma560.yaml"
    pairings = [(p, s) for p in ("chuck1", "chuck2", "chuck3") for s in ("sphere1", "sphere2", "sphere3")]
    truth_sigma = dict(zip(pairings, np.linspace(0.04, 0.2, 9)))  # mm
    _, data = _campaign(spec_path, [NO_DIAGNOSIS], lambda key, _: truth_sigma[key[:2]], seed=6)
    fit_changes = [NO_DIAGNOSIS, ("  noise: 0.0084\n", "  noise: 0.0084\n  estimate_noise: true\n  noise_groups: [pairing]\n")]
    calibrated = _calibrate(tmp_path, spec_path, fit_changes, data)
    found = {g.group: g for g in calibrated.noise.groups}
    assert set(found) == {f"length, pairing {p}-{s}" for p, s in pairings}
    z = np.array([(found[f"length, pairing {p}-{s}"].sigma - truth_sigma[(p, s)]) / found[f"length, pairing {p}-{s}"].std for p, s in pairings])
    assert np.all(np.abs(z) < 3.5), np.round(z, 2)
    assert 0.3 < np.sqrt(np.mean(z**2)) < 2.0
    verdicts = {pairing: found[f"length, pairing {pairing[0]}-{pairing[1]}"].test.verdict for pairing in pairings}
    assert verdicts[pairings[0]] == "declared_too_large" and verdicts[pairings[-1]] == "declared_too_small"  # 0.084 mm declared


def test_specs_without_estimation_are_weighted_as_declared(tmp_path, tracker_campaign):
    spec = _load(tmp_path, _spec_text(SPECS / "ur10.yaml", [*UR10_TWO_TARGETS, AS_DECLARED]))
    device = device_model(spec)
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", [*UR10_TWO_TARGETS, AS_DECLARED], tracker_campaign)
    assert calibrated.noise is None
    residuals = calibrated.problem.residuals
    orientation = np.isin(residuals.channel, ("rx", "ry", "rz"))
    assert np.all(residuals.sigma[~orientation] == 0.03) and np.allclose(residuals.sigma[orientation], 0.002 * DEG)
    assert device.noise_scale == {} and device.spec.estimated_fields() == ()


def test_reweighting_equals_a_problem_built_with_the_new_sigmas(tmp_path, tracker_campaign):
    from armcal.kinematics.compiler import compile_robot

    spec = _load(tmp_path, _spec_text(SPECS / "ur10.yaml", [*UR10_TWO_TARGETS, (DECLARED[0], "  noise: auto\n  orientation_noise: auto\n")]))
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    scale = {"position": 0.07, "orientation": 3e-4}
    built = build_problem(kinematics, device.with_noise_scale(scale), tracker_campaign)
    unit = build_problem(kinematics, device.with_noise_scale({"position": 1.0, "orientation": 1.0}), tracker_campaign)
    moved = reweighted(unit, np.where(np.isin(unit.residuals.channel, ("rx", "ry", "rz")), 3e-4, 0.07))
    theta = built.parameters.nominal
    for a, b in zip(built.evaluate(theta), moved.evaluate(theta)):
        assert np.array_equal(a, b)
    assert np.array_equal(built.residuals.sigma, moved.residuals.sigma)


def test_an_auto_noise_has_no_value_to_simulate_with(tmp_path):
    spec = _load(tmp_path, _spec_text(SPECS / "ur10.yaml", [(DECLARED[0], "  noise: auto\n  orientation_noise: 0.002\n")]))
    device = device_model(spec)
    with pytest.raises(UserError, match="auto"):
        device.sigma(("tmac",), np.zeros((1, 6)))


@pytest.mark.parametrize(
    "replacement, field, message",
    [
        ("  noise: 0.03\n  orientation_noise: 0.002\n  noise_groups: [target]\n", "device.noise_groups", "only matters when a noise is auto"),
        ("  noise: auto\n  orientation_noise: 0.002\n  noise_groups: [station]\n", "device.noise_groups[0]", "Expected 'kind' or 'target'"),
        ("  noise: -1\n  orientation_noise: 0.002\n", "device.noise", "must be above 0 (or auto"),
        ("  noise: automatic\n  orientation_noise: 0.002\n", "device.noise", "(or write auto, to estimate it from the data)"),
    ],
)
def test_spec_errors_are_located(tmp_path, replacement, field, message):
    path = tmp_path / "bad.yaml"
    path.write_text(_spec_text(SPECS / "ur10.yaml", [(DECLARED[0], replacement)]))
    with pytest.raises(SpecError) as raised:
        load_spec(path)
    issues = raised.value.issues
    assert [i.field for i in issues] == [field] and message in issues[0].message, issues
    assert issues[0].line is not None


def test_sonic_range_noise_accepts_auto(tmp_path):
    text = (SPECS / "puma560_dh.yaml").read_text()
    old = "  noise: {a: 9.6432e-5, b: 0.003}"
    assert old in text
    spec = _load(tmp_path, text.replace(old, "  noise: auto\n  noise_groups: [microphone]"))
    assert spec.device.noise == "auto" and spec.device.estimated_fields() == ("noise",)
    path = tmp_path / "bad.yaml"
    path.write_text(text.replace(old, "  noise: {a: -1, b: 0.003}"))
    with pytest.raises(SpecError) as raised:
        load_spec(path)
    assert [i.field for i in raised.value.issues] == ["device.noise.a"]


UR10_ONE_TARGET = [("  count: 2773\n", "  count: 300\n  seed: 8\n"), ("  count: 632\n", "  count: 20\n")]
ONE_TARGET_TRUTH = (0.05, 0.01 * DEG)  # mm, rad: 5 mm/deg, where specs/ur10.yaml declares 15 mm/deg


@pytest.fixture(scope="module")
def one_target_campaign():
    sigma = lambda key, channel: ONE_TARGET_TRUTH[0] if channel in "xyz" else ONE_TARGET_TRUTH[1]  # noqa: E731
    return _campaign(SPECS / "ur10.yaml", [NO_DIAGNOSIS, *UR10_ONE_TARGET], sigma, seed=9)[1]


@pytest.mark.parametrize(
    "noise",
    ["  noise: 0.05\n  orientation_noise: 0.0005\n  estimate_noise: true\n", "  noise: 0.5\n  orientation_noise: 0.0001\n  estimate_noise: true\n"],
    ids=["ratio_x10", "ratio_x1000"],
)
def test_positions_and_orientations_by_kind_with_the_diagnosis(tmp_path, one_target_campaign, noise):
    """The default groups (kind), the diagnosis on: both sigmas within 10 % of the truth; the declared orientation
    sigma is rejected as too small, so the result is unexplained although the fit meets its estimated noise."""
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", [*UR10_ONE_TARGET, (DECLARED[0], noise)], one_target_campaign)
    found = {g.group: g for g in calibrated.noise.groups}
    assert set(found) == {"position", "orientation"}
    assert abs(found["position"].sigma / ONE_TARGET_TRUTH[0] - 1) < 0.10
    assert abs(found["orientation"].sigma / ONE_TARGET_TRUTH[1] - 1) < 0.10
    assert found["orientation"].test.verdict == "declared_too_small"
    assert calibrated.diagnosis is not None and calibrated.diagnosis.unexplained
    assert calibrated.identified.least_squares.uncertainty.verdict == "consistent"


def test_auto_noise_with_the_diagnosis_is_not_unexplained(tmp_path, one_target_campaign):
    noise = "  noise: auto\n  orientation_noise: auto\n"
    calibrated = _calibrate(tmp_path, SPECS / "ur10.yaml", [*UR10_ONE_TARGET, (DECLARED[0], noise)], one_target_campaign)
    assert not calibrated.diagnosis.unexplained
    assert all(g.test is None for g in calibrated.noise.groups)


def test_sonic_sigma_per_microphone(tmp_path):
    """Slant ranges of four microphones, 0.05-0.2 mm: noise: auto, noise_groups: [microphone], each within 10 %."""
    from armcal.kinematics.compiler import compile_robot

    truth_sigma = {"s_A": 0.05, "s_B": 0.1, "s_C": 0.15, "s_D": 0.2}  # mm
    spec_path = SPECS / "puma560_dh.yaml"
    more = ("  points_per_joint: 20", "  points_per_joint: 60")  # 360 samples: a sigma to 4 %
    _, data = _campaign(spec_path, [NO_DIAGNOSIS, more], lambda key, channel: truth_sigma[channel], seed=12)
    text = _spec_text(spec_path, [NO_DIAGNOSIS, more, ("  noise: {a: 9.6432e-5, b: 0.003}", "  noise: auto\n  noise_groups: [microphone]")])
    spec = _load(tmp_path, text)
    device = device_model(spec)
    calibrated = identify_and_diagnose(spec, compile_robot(spec.robot.chain()), device, data, data, None)  # ranges as the model predicts them
    found = {g.group: g for g in calibrated.noise.groups}
    assert set(found) == {f"range, microphone {m}" for m in "ABCD"}
    for channel, true in truth_sigma.items():
        group = found[f"range, microphone {channel[2:]}"]
        assert group.readings == len(data) and abs(group.sigma / true - 1) < 0.10, (channel, group.sigma)


def test_a_range_noise_model_keeps_estimating_in_the_calibrated_spec(tmp_path):
    """A sonic digitizer's a s + b cannot hold one sigma: calibrated.yaml keeps the model and estimate_noise, loads,
    and a run of it estimates the same sigma, to a tenth of its standard deviation."""
    from conftest import copy_example

    from armcal.commands.run import run

    copy_example("puma560_sonic", tmp_path)
    spec = tmp_path / "spec.yaml"
    old = "  noise: {a: 9.6432e-5, b: 0.003}"
    text = spec.read_text()
    assert old in text
    spec.write_text(text.replace(old, old + "\n  estimate_noise: true").replace("armcal: 1\n", "armcal: 1\ndiagnose: {enabled: false}\n", 1))
    first = run(spec, tmp_path / "out", pdf=False).results
    calibrated = load_spec(tmp_path / "out" / "calibrated.yaml").spec
    assert calibrated.device.estimate_noise and calibrated.device.noise.a == pytest.approx(9.6432e-5)  # the declared model kept
    second = run(tmp_path / "out" / "calibrated.yaml", tmp_path / "again", pdf=False).results
    for a, b in zip(first.noise.groups, second.noise.groups):
        assert a.group == b.group and abs(b.sigma - a.sigma) < 0.1 * a.std  # far inside its own uncertainty


def test_a_validation_group_the_calibration_lacks_is_a_located_error(tmp_path):
    """Goswami's held-out shells use the 15 mm rod, the calibration shells never do: per pairing, their noise has no
    estimate, and the run says so, naming the validation file."""
    from conftest import armcal_cli, copy_example

    copy_example("goswami_ballbar", tmp_path)
    spec = tmp_path / "spec.yaml"
    spec.write_text(spec.read_text().replace("  noise: 0.0084", "  noise: auto\n  noise_groups: [kind, pairing]", 1))
    result = armcal_cli("run", str(spec), "--out", str(tmp_path / "out"), "--no-pdf")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    assert "which the calibration data do not have" in result.stderr and ".csv" in result.stderr
