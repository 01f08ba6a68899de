"""Compiled forward kinematics against Stone's closed form (App. B) and across conventions."""

import numpy as np
from conftest import random_configurations
from puma_closed_form import t6

from armcal.kinematics.transforms import inverse


def test_dh_spec_equals_stone_closed_form(puma_models):
    model = puma_models["puma560_dh"]
    Q = random_configurations(model, 1000)
    base = model.link_frames(np.zeros(6))[0]  # DH frame 0, 67.183 cm above the base (F.4)
    T = np.einsum("ij,njk->nik", inverse(base), model.tool_poses(Q))
    assert np.allclose(base[:3, 3], [0.0, 0.0, 671.83], atol=1e-12)
    assert np.abs(T - t6(Q)).max() < 1e-9


def test_closed_form_b7_as_printed_has_a_sign_error(puma_models):
    """(B.7) as printed disagrees with (B.2)-(B.6); o = a x n fixes its first term's sign."""
    Q = random_configurations(puma_models["puma560_dh"], 200, seed=1)
    printed = t6(Q, o_z_as_printed=True)
    corrected = t6(Q)
    assert np.abs(printed[:, 2, 1] - corrected[:, 2, 1]).max() > 0.5
    cross = np.cross(corrected[:, :3, 2], corrected[:, :3, 0])
    assert np.abs(cross - corrected[:, :3, 1]).max() < 1e-12


def test_conventions_give_the_same_tool_poses(puma_models):
    dh = puma_models["puma560_dh"]
    Q = random_configurations(dh, 1000, seed=2)
    reference = dh.tool_poses(Q)
    for name in ("puma560_smodel", "puma560_six"):
        assert np.abs(puma_models[name].tool_poses(Q) - reference).max() < 1e-9, name


def test_smodel_targets_match_dh_targets(puma_models):
    """The S-Model spec re-expresses each sparker in S_i = T_i Trans(0, 0, b_i) (3.8)."""
    dh, sm = puma_models["puma560_dh"], puma_models["puma560_smodel"]
    Q = random_configurations(dh, 200, seed=3)
    for name in dh.targets:
        assert np.abs(sm.target_poses(name, Q)[:, :3, 3] - dh.target_poses(name, Q)[:, :3, 3]).max() < 1e-9


def test_target_radius_matches_table_6_1(puma_models):
    """Sparker i lies at the nominal radius R_i (Table 6-1) from joint i's axis."""
    model = puma_models["puma560_dh"]
    radii_cm = [40.87, 41.62, 43.71, 33.30, 45.13, 33.30]
    q = np.radians([10.0, -60.0, 120.0, 20.0, 30.0, 40.0])
    frames = model.link_frames(q)
    for i, radius in enumerate(radii_cm, start=1):
        axis_frame = frames[i - 1]
        point = model.target_poses(f"sparker{i}", q)[0][:3, 3]
        local = inverse(axis_frame) @ np.append(point, 1.0)
        assert abs(np.hypot(local[0], local[1]) - 10 * radius) < 1e-9


def test_batch_evaluation_equals_single_calls(puma_models):
    model = puma_models["puma560_six"]
    Q = random_configurations(model, 5, seed=4)
    batch = model.tool_poses(Q)
    for q, T in zip(Q, batch):
        assert np.abs(np.array(model.fk(q, model.parameters.nominal)) - T).max() == 0.0


def test_prismatic_joint_translates_along_its_axis():
    from armcal.kinematics.compiler import compile_robot
    from armcal.spec_parts.robot import DHRobot

    robot = DHRobot.model_validate(
        {
            "name": "gantry",
            "serial": "g",
            "convention": "dh",
            "joints": [
                {"type": "prismatic", "limits": [0, 500], "theta": 0, "d": 100, "a": 0, "alpha": -90},
                {"limits": [-180, 180], "theta": 0, "d": 0, "a": 200, "alpha": 0},
            ],
        }
    )
    model = compile_robot(robot.chain())
    T = model.tool_poses(np.array([[0.0, 0.0], [250.0, 0.0]]))
    assert np.allclose(T[1][:3, 3] - T[0][:3, 3], [0.0, 0.0, 250.0], atol=1e-12)
