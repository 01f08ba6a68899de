"""S-Model <-> DH conversions (Stone 3.10-3.33) and the pseudo-DH model (4.71-4.73)."""

import math

import numpy as np
import pytest
from conftest import SPECS, random_configurations

from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.conventions import dh_link, smodel_link
from armcal.kinematics.smodel import DHRow, dh_to_smodel, pseudo_dh, smodel_from_transform, smodel_to_dh
from armcal.spec import load_spec
from armcal.spec_parts.robot import DHRobot, SModelRobot

DEG = math.pi / 180.0
TABLE_6_2 = [  # theta offset, d (mm), a (mm), alpha
    DHRow(0.0, 0.0, 0.0, -90 * DEG),
    DHRow(0.0, 149.09, 431.8, 0.0),
    DHRow(0.0, 0.0, -20.32, 90 * DEG),
    DHRow(0.0, 433.07, 0.0, -90 * DEG),
    DHRow(0.0, 0.0, 0.0, 90 * DEG),
    DHRow(0.0, 0.0, 0.0, 0.0),
]
MM_RAD = {"units": {"length": "mm", "angle": "rad"}}


def _robot(convention, rows, limits, base=None, tool=None):
    cls = DHRobot if convention == "dh" else SModelRobot
    joints = [{"limits": list(lim), **row.__dict__} for row, lim in zip(rows, limits)]
    data = {"name": "r", "serial": "s", "convention": convention, "joints": joints}
    for key, T in (("base", base), ("tool", tool)):
        if T is not None:
            from armcal.kinematics.transforms import pose_from_matrix

            data[key] = dict(zip(("x", "y", "z", "rz", "ry", "rx"), pose_from_matrix(T)))
    return compile_robot(cls.model_validate(data, context=MM_RAD).chain())


def test_dh_smodel_dh_round_trip_is_exact():
    rng = np.random.default_rng(0)
    gamma = list(rng.uniform(-math.pi, math.pi, 7))
    b = list(rng.uniform(-300, 300, 7))
    back = smodel_to_dh(dh_to_smodel(TABLE_6_2, gamma, b), gamma[0], b[0])
    for original, recovered in zip(TABLE_6_2, back):
        for field in ("theta", "d", "a", "alpha"):
            assert getattr(recovered, field) == pytest.approx(getattr(original, field), abs=1e-12)


def test_smodel_from_random_frames_keeps_tool_pose():
    """An S-Model chain with arbitrary frame offsets (3.8) reproduces the DH robot's tool poses."""
    from armcal.kinematics.smodel import offset_transform
    from armcal.kinematics.transforms import inverse

    rng = np.random.default_rng(1)
    gamma = list(rng.uniform(-math.pi, math.pi, 7))
    b = list(rng.uniform(-300, 300, 7))
    limits = [(-math.pi, math.pi)] * 6
    dh = _robot("dh", TABLE_6_2, limits)
    sm = _robot(
        "s_model",
        dh_to_smodel(TABLE_6_2, gamma, b),
        limits,
        base=offset_transform(gamma[0], b[0]),
        tool=inverse(offset_transform(gamma[6], b[6])),
    )
    Q = random_configurations(dh, 300)
    assert np.abs(sm.tool_poses(Q) - dh.tool_poses(Q)).max() < 1e-9


def test_backward_multiplication_inverts_smodel_link():
    """(3.21)-(3.33) recover the parameters of B_i built by (3.2), both branches."""
    rng = np.random.default_rng(2)
    for _ in range(200):
        beta, gamma = rng.uniform(-math.pi, math.pi, 2)
        alpha = rng.uniform(0.1, math.pi - 0.1) * rng.choice([-1, 1])
        d, a, b = rng.uniform(-500, 500, 3)
        B = smodel_link(beta, d, a, alpha, gamma, b)
        row = smodel_from_transform(B, reference=DHRow(0.0, 0.0, a, alpha))
        assert np.allclose([row.beta, row.d, row.a, row.alpha, row.gamma, row.b], [beta, d, a, alpha, gamma, b], atol=1e-9)
        assert np.abs(smodel_link(row.beta, row.d, row.a, row.alpha, row.gamma, row.b) - B).max() < 1e-9


def test_pseudo_dh_of_the_ideal_puma_is_table_6_2(puma_models):
    """From the joint axes of any convention, (4.52)-(4.57) and (3.12)-(3.15) give Table 6-2.

    The pseudo-DH model starts at the model's S_0 (4.71), so d1 holds whatever
    offset S_0 has along joint 1 from DH frame 0 (67.183 cm up, F.4).
    """
    for name, model in puma_models.items():
        result = pseudo_dh(model, np.zeros(6), reference=TABLE_6_2)
        for i, (row, expected) in enumerate(zip(result.rows, TABLE_6_2), start=1):
            got = [row.theta, row.d if i > 1 else 0.0, row.a, row.alpha]
            want = [expected.theta, expected.d, expected.a, expected.alpha]
            assert np.allclose(got, want, atol=1e-9), (name, i, got, want)
        assert np.allclose(result.base[:3, 3] + [0.0, 0.0, result.rows[0].d], [0.0, 0.0, 671.83], atol=1e-9)
        assert np.allclose(result.base[:3, :3], np.eye(3), atol=1e-12)


def _tilted_puma(tilt_about_y: float, tilt_about_x: float):
    """The Table 6-2 PUMA in mdh with joint 3's axis tilted out of parallel with joint 2's."""
    from armcal.spec_parts.robot import MDHRobot

    joints = [{"limits": [-math.pi, math.pi], **row.__dict__} for row in TABLE_6_2]
    joints[1] = {**joints[1], "alpha": tilt_about_x, "beta": tilt_about_y}
    data = {"name": "tilted", "serial": "t", "convention": "mdh", "joints": joints}
    return compile_robot(MDHRobot.model_validate(data, context=MM_RAD).chain())


def test_near_parallel_axes_give_table_6_3_behaviour():
    """Axes 2 and 3 out of parallel by 0.2 deg: d2 and d3 huge and nearly opposite (Table 6-3), same tool."""
    model = _tilted_puma(tilt_about_y=0.2 * DEG, tilt_about_x=0.02 * DEG)
    q_signature = np.zeros(6)
    result = pseudo_dh(model, q_signature, reference=TABLE_6_2)
    d2, d3 = result.rows[1].d, result.rows[2].d
    assert abs(d2) > 50_000 and abs(d3) > 50_000  # over 50 m, against a 1 m robot
    assert d2 * d3 < 0
    assert abs(d2 + d3) < 0.05 * abs(d2)
    assert abs(result.rows[1].a) < 0.5 * 431.8  # the common normal moved: a2 collapses as in Table 6-3
    dh = compile_robot(DHRobot.model_validate(result.robot_dict("x", "y", model.limits), context=MM_RAD).chain())
    Q = random_configurations(model, 500, seed=5)
    assert np.abs(dh.tool_poses(Q)[:, :3, 3] - model.tool_poses(Q)[:, :3, 3]).max() < 1e-6
    assert np.abs(dh.tool_poses(Q)[:, :3, :3] - model.tool_poses(Q)[:, :3, :3]).max() < 1e-9


def test_goswami_table_ii_is_the_same_puma_as_stone_table_6_2():
    """Goswami's design values (Table II, ZYX Euler links) extract to Stone's DH lengths (Table 6-2)."""
    model = compile_robot(load_spec(SPECS / "goswami_puma560.yaml").spec.robot.chain())
    result = pseudo_dh(model, np.radians([155.0, -100.0, 178.0, 10.0, 20.0, 30.0]))  # any signature
    assert abs(result.rows[1].a) == pytest.approx(431.8, abs=1e-9)
    assert abs(result.rows[1].d + result.rows[2].d) == pytest.approx(149.09, abs=1e-9)
    assert abs(result.rows[2].a) == pytest.approx(20.32, abs=1e-9)
    assert abs(result.rows[3].d) == pytest.approx(433.07, abs=1e-9)
    assert [round(abs(r.alpha) / DEG, 9) for r in result.rows] == [90, 0, 90, 90, 90, 0]
    dh = compile_robot(DHRobot.model_validate(result.robot_dict("x", "y", model.limits), context=MM_RAD).chain())
    Q = random_configurations(model, 300, seed=6)
    assert np.abs(dh.tool_poses(Q) - model.tool_poses(Q)).max() < 1e-9


def test_dh_link_matches_expanded_matrix_2_10():
    theta, d, a, alpha = 0.3, 12.0, -7.0, 1.1
    ct, st, ca_, sa = math.cos(theta), math.sin(theta), math.cos(alpha), math.sin(alpha)
    expected = np.array(
        [[ct, -st * ca_, st * sa, a * ct], [st, ct * ca_, -ct * sa, a * st], [0, sa, ca_, d], [0, 0, 0, 1]]
    )
    assert np.abs(dh_link(theta, d, a, alpha) - expected).max() < 1e-15
