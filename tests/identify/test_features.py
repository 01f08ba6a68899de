"""Stone's feature-based identification (4.3) on circle-point sweeps of the Table 6-2 PUMA."""

import numpy as np
import pytest
from conftest import SPECS
from test_smodel import TABLE_6_2

from armcal.devices import device_model
from armcal.identify import stone_features
from armcal.kinematics.compiler import compile_robot
from armcal.procedures import plan
from armcal.spec import load_spec


@pytest.fixture(scope="module")
def sweeps():
    spec = load_spec(SPECS / "puma560_dh.yaml").spec
    kinematics = compile_robot(spec.robot.chain())
    planned = plan(spec.procedure, kinematics, device_model(spec), spec, SPECS)
    out = []
    for i, target in enumerate(spec.procedure.targets):
        rows = np.array([k == (target,) for k in planned.keys])
        points = kinematics.target_poses(target, planned.q[rows])[:, :3, 3]
        out.append((points, planned.q[rows, i]))
    return spec, kinematics, out


def test_noise_free_sweeps_give_table_6_2(sweeps):
    spec, kinematics, data = sweeps
    result = stone_features.identify(data, kinematics.joint_types, np.asarray(spec.procedure.signature), reference=TABLE_6_2)
    # theta_1 and d_1 depend on where S_0 sits (4.71-4.72); theta_6 on where target 6 starts its
    # circle (4.50): no end-effector frame is measured (Stone's theta_6 offsets, Table 6-3, are arbitrary too)
    for i, (row, expected) in enumerate(zip(result.pseudo_dh.rows, TABLE_6_2), start=1):
        got = [row.a, row.alpha] + ([row.d] if i > 1 else []) + ([row.theta] if 1 < i < 6 else [])
        want = [expected.a, expected.alpha] + ([expected.d] if i > 1 else []) + ([expected.theta] if 1 < i < 6 else [])
        assert np.allclose(got, want, atol=1e-7), (i, got, want)
    radii = [f.radius / 10 for f in result.features]
    assert np.allclose(radii, [40.87, 41.62, 43.71, 33.30, 45.13, 33.30], atol=1e-9)  # Table 6-1


def test_eigenvector_and_repeated_least_squares_planes_agree(sweeps):
    """Stone (4.3.2.1, ch. 6): both plane methods give the same features on sonic-like data."""
    _, _, data = sweeps
    rng = np.random.default_rng(0)
    for points, _ in data:
        noisy = points + rng.normal(scale=0.15, size=points.shape)
        a, _ = stone_features.plane_by_eigenvector(noisy)
        b, _ = stone_features.plane_by_repeated_least_squares(noisy)
        assert min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < 1e-6


def test_plane_accuracy_formula_6_11_matches_monte_carlo():
    """sigma_delta^2 = 2 sigma_n^2 / (R^2 n) for a full circle (6.11)."""
    rng = np.random.default_rng(1)
    radius, count, sigma = 333.0, 20, 0.15
    angles = 2 * np.pi * np.arange(count) / count
    circle = np.c_[radius * np.cos(angles), radius * np.sin(angles), np.zeros(count)]
    tilts = []
    for _ in range(4000):
        normal, _ = stone_features.plane_by_eigenvector(circle + rng.normal(scale=sigma, size=circle.shape))
        tilts.append(normal[:2] * np.sign(normal[2]))
    empirical = np.std(np.array(tilts), axis=0)
    predicted, _ = stone_features.feature_accuracy(sigma, sigma, radius, count, 360.0)
    assert np.allclose(empirical, predicted, rtol=0.06)


def test_centre_of_a_noisy_arc(sweeps):
    """The centre-of-rotation of a 270 degree arc comes back within a few sigma_c of (6.13)."""
    rng = np.random.default_rng(2)
    radius, count, sigma = 400.0, 30, 0.1
    angles = np.radians(np.linspace(-135, 135, count))
    centre = np.array([100.0, -50.0, 20.0])
    arc = centre + np.c_[radius * np.cos(angles), radius * np.sin(angles), np.zeros(count)]
    found = stone_features.joint_features(1, True, arc + rng.normal(scale=sigma, size=arc.shape), angles)
    assert np.linalg.norm(found.centre - centre) < 4 * found.sigma_centre
    assert found.axis @ [0, 0, 1] > 0.999999  # counter-clockwise sweep: axis +z


def test_line_of_translation_of_a_prismatic_joint():
    """(4.44)-(4.47): the line through the mean along the principal axis, pointing with positive travel."""
    rng = np.random.default_rng(3)
    direction = np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    travel = np.linspace(-300, 300, 25)
    points = np.array([10.0, 20.0, 30.0]) + np.outer(travel, direction) + rng.normal(scale=0.05, size=(25, 3))
    found, mean = stone_features.line_of_translation(points)
    assert np.degrees(np.arccos(found @ direction)) < 0.01  # same sense as the travel
    assert np.linalg.norm(np.cross(mean - [10.0, 20.0, 30.0], direction)) < 0.05
    reversed_found, _ = stone_features.line_of_translation(points[::-1])
    assert reversed_found @ direction < 0  # measured in the other order, the joint moves the other way
