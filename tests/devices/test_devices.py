"""Measurement models against independent numpy geometry, triangulation and compensation (Stone 6.3, App. E)."""

import math

import numpy as np
import pytest
from conftest import SPECS, random_configurations

from armcal.devices import device_model
from armcal.devices.sonic import SonicModel, microphone_distances, triangulate
from armcal.devices.sonic import compensate, raw_range, rod_ratio, speed_of_sound, true_range, vertical
from armcal.kinematics.compiler import compile_robot
from armcal.model.measurement import predict
from armcal.spec import load_spec


def _setup(name):
    spec = load_spec(SPECS / f"{name}.yaml").spec
    return spec, compile_robot(spec.robot.chain())


def _pose(x, y, z, rz, ry, rx):
    """Trans Rot(z) Rot(y) Rot(x), written out with numpy only."""
    cz, sz, cy, sy, cx, sx = math.cos(rz), math.sin(rz), math.cos(ry), math.sin(ry), math.cos(rx), math.sin(rx)
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    T = np.eye(4)
    T[:3, :3] = Rz @ Ry @ Rx
    T[:3, 3] = [x, y, z]
    return T


def _values(device, prefix):
    values = device.parameters.values(device.parameters.nominal)
    return [values[f"{prefix}.{f}"] for f in ("x", "y", "z", "rz", "ry", "rx")]


STONE_MICS = {"A": np.array([1429.96, 1440.87, 0.0]), "B": np.array([0.0, 1430.0, 0.0]), "C": np.zeros(3)}


def test_triangulation_recovers_a_point_exactly():
    rng = np.random.default_rng(0)
    points = rng.uniform([200, 200, 300], [1300, 1300, 2000], (500, 3))
    ranges = [np.linalg.norm(points - STONE_MICS[m], axis=1) for m in "ABC"]
    xyz = np.stack(triangulate(*ranges, *microphone_distances(STONE_MICS)), axis=1)
    assert np.abs(xyz - points).max() < 1e-9


def test_triangulation_noise_matches_the_noise_model():
    """Noisy ranges (7.9) give point errors with the spread the propagated noise model predicts."""
    spec, _ = _setup("puma560_dh")
    model = SonicModel(spec.device, averaging=1, mode="points")
    point = np.array([700.0, 700.0, 1200.0])
    ranges = np.array([np.linalg.norm(point - STONE_MICS[m]) for m in "ABC"])
    sigma = model.range_sigma(ranges)
    rng = np.random.default_rng(1)
    noisy = ranges + rng.normal(size=(20000, 3)) * sigma
    xyz = np.stack(triangulate(*noisy.T, *microphone_distances(STONE_MICS)), axis=1)
    predicted = model.sigma(None, point[None, :])[0]
    assert np.allclose(xyz.std(axis=0), predicted, rtol=0.03)
    assert np.allclose(xyz.mean(axis=0), point, atol=3 * predicted / np.sqrt(20000) + 1e-3)


@pytest.mark.parametrize("mode", ["ranges", "points"])
def test_sonic_readings_equal_numpy_geometry(mode):
    spec, robot = _setup("puma560_dh")
    device = SonicModel(spec.device, mode=mode)
    Q = random_configurations(robot, 50)
    readings = predict(robot, device, ("sparker6",), Q)
    base_in_sensor = _pose(*_values(device, "robot_base"))
    points = np.einsum("ij,nj->ni", base_in_sensor, np.c_[robot.target_poses("sparker6", Q)[:, :3, 3], np.ones(50)])[:, :3]
    mics = {m: device.nominal_microphones[m] for m in device.microphones}
    ranges = {m: np.linalg.norm(points - mics[m], axis=1) for m in mics}
    if mode == "ranges":
        assert np.abs(readings - np.stack([ranges[m] for m in device.microphones], axis=1)).max() < 1e-9
    else:  # exact in front of the microphone plane; mirrored behind it (only |z| is known)
        front = points[:, 2] > 0
        assert 0 < front.sum() < 50
        assert np.abs(readings[front] - points[front]).max() < 1e-9
        assert np.abs(readings[~front] - points[~front] * [1, 1, -1]).max() < 1e-9
        assert device.visible(("sparker6",), robot.target_poses("sparker6", Q))[~front].sum() == 0


def test_ballbar_reading_equals_numpy_distance_and_travel():
    spec, robot = _setup("goswami_puma560")
    device = device_model(spec)
    Q = random_configurations(robot, 50, seed=2)
    key = ("chuck2", "sphere3", "rod15")
    readings = predict(robot, device, key, Q)[:, 0]
    values = device.parameters.values(device.parameters.nominal)
    pivot = np.array([values[f"pivot.chuck2.{c}"] for c in "xyz"])
    sphere = robot.target_poses("sphere3", Q)[:, :3, 3]
    assert np.abs(readings - np.linalg.norm(sphere - pivot, axis=1)).max() < 1e-9
    # a bar 0.2 mm longer than nominal reads 0.2 mm short
    pd = device.parameters.nominal.copy()
    pd[device.parameters.index("bar.length")] += 0.2
    assert np.allclose(predict(robot, device, key, Q, pd=pd)[:, 0], readings - 0.2, atol=1e-9)
    mid = 460.0 + 150.0
    inside = np.array([[mid - 37.4], [mid + 37.4], [mid + 37.6], [mid - 40.0]])
    assert device.measurable(key, inside).tolist() == [True, True, False, False]


def test_theodolite_angles_equal_numpy_geometry():
    spec, robot = _setup("puma560_theodolite")
    device = device_model(spec)
    Q = random_configurations(robot, 50, seed=3)
    readings = predict(robot, device, ("t2", "ball"), Q)
    world = _pose(*_values(device, "robot_base"))
    station = _pose(*_values(device, "station.t2"))
    points = robot.target_poses("ball", Q)[:, :3, 3]
    local = (np.linalg.inv(station) @ world @ np.c_[points, np.ones(50)].T).T[:, :3]
    azimuth = np.arctan2(local[:, 1], local[:, 0])
    elevation = np.arcsin(local[:, 2] / np.linalg.norm(local, axis=1))
    assert np.abs(readings - np.stack([azimuth, elevation], axis=1)).max() < 1e-12
    bar = device.evaluate(("scale_bar",), np.eye(4)[None])[0, 0]
    assert bar == pytest.approx(1000.0)


def test_tracker_position_and_orientation_equal_numpy_geometry():
    spec, robot = _setup("ur10")
    device = device_model(spec)
    pd = device.parameters.nominal.copy()
    truth = [1200.0, -300.0, 150.0, 0.4, -0.2, 0.1]
    for name, value in zip(("x", "y", "z", "rz", "ry", "rx"), truth):
        pd[device.parameters.index(f"robot_base.{name}")] = value
    Q = random_configurations(robot, 50, seed=4)
    readings = predict(robot, device, ("tmac",), Q, pd=pd)
    seen = np.einsum("ij,njk->nik", _pose(*truth), robot.target_poses("tmac", Q))
    assert np.abs(readings[:, :3] - seen[:, :3, 3]).max() < 1e-9
    rx, ry, rz = readings[:, 3], readings[:, 4], readings[:, 5]
    for R, a, b, c in zip(seen[:, :3, :3], rx, ry, rz):
        Rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        Ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
        Rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
        assert np.abs(Rx @ Ry @ Rz - R).max() < 1e-9


def _reading(distance, temperature, internal_speed):
    v = speed_of_sound(temperature)
    return raw_range(distance, v, v, internal_speed)


def test_one_degree_fahrenheit_error_and_stones_example_are_removed_by_the_rods():
    """A speed-of-sound error stretches every range; the calibration rods (E.1) undo it within the 0.1 mm resolution.

    Stone (6.3.1) quotes 150.0 cm read as 155.79 cm for 1 F; the physics gives
    about 0.1 % per F (150.15 cm). Both are removed alike, being a speed ratio.
    """
    internal = speed_of_sound((70.0 - 32.0) * 5 / 9)  # S* set for 70 F
    actual = (69.0 - 32.0) * 5 / 9
    physical = _reading(1500.0, actual, internal)
    assert 1501.0 < physical < 1502.0
    ratio = 1500.0 / 1557.9  # Stone's printed example
    for true_speed in (speed_of_sound(actual), ratio * internal):
        reading = np.round(raw_range(1500.0, true_speed, true_speed, internal), 1)  # 0.01 cm quantisation
        rod = np.round(raw_range(np.array([300.0, 1300.0]), true_speed, true_speed, internal), 1)
        f = rod_ratio(rod[0], rod[1], 1000.0)
        assert abs(true_range(reading, f, f) - 1500.0) <= 0.1 + 1e-9


def test_compensation_with_a_vertical_temperature_gradient():
    """App. E.2: two rods at two heights, a linear gradient; ranges recovered within the resolution."""
    mics = {**STONE_MICS, "D": np.array([1430.0, 0.0, 0.0])}
    up = vertical(mics)
    internal = speed_of_sound(21.1)
    temperature = lambda h: 21.1 + 0.8 * (h / 1000.0)  # noqa: E731 - 0.8 degC per metre, B-3/B-4
    rng = np.random.default_rng(5)
    points = rng.uniform([300, 300, 500], [1200, 1200, 1800], (200, 3))
    raw, truth = {}, {}
    for m in "ABC":
        truth[m] = np.linalg.norm(points - mics[m], axis=1)
        v_target = speed_of_sound(temperature(points @ up))
        v_mic = speed_of_sound(temperature(mics[m] @ up))
        raw[m] = np.round(raw_range(truth[m], v_target, v_mic, internal), 1)
    rods = {}
    for m in ("B", "D"):
        v = speed_of_sound(temperature(mics[m] @ up))
        near, far = np.round(raw_range(np.array([300.0, 1300.0]), v, v, internal), 1)
        rods[m] = rod_ratio(near, far, 1000.0)
    uncorrected = max(np.abs(raw[m] - truth[m]).max() for m in "ABC")
    corrected = compensate(raw, rods, mics)
    error = max(np.abs(corrected[m] - truth[m]).max() for m in "ABC")
    assert uncorrected > 1.0 and error < 0.25  # within 2.5 quantisation steps after two rods' own rounding
