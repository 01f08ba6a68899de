"""joint_coupling: joint `from` drives joint `joint` too, q_joint -> q_joint + c q_from.

The issue: a simulated coupling dq3 = c q2 (a parallelogram forearm, coupled wrists,
a SCARA's ball-screw spline) was blamed on an encoder scale of joint 2, every time.
Oracles: a numpy DH chain (tests/independent_sim.py) with q3 += c q2 for the formula,
in armcal's measurement model and in its simulator; campaigns simulated by
tests/independent_effects.py (numpy, no armcal) for the diagnosis.
"""

import numpy as np
import pytest
from independent_effects import coupling, write_campaign
from independent_sim import DEG, ROBOTS, TRACKER, frames, pose, spec_text
from round_trip import round_trip

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.diagnose.calibration import identify_and_diagnose
from armcal.effects.library import from_spec, to_spec_dict
from armcal.effects.types.joint_coupling import coupling as coupling_effect, coupling_pairs
from armcal.effects.measurement import EffectSet, extras_size
from armcal.kinematics.compiler import compile_robot
from armcal.model.measurement import measurement_function
from armcal.simulate.truth import TrueRobot
from armcal.spec import load_spec
from armcal.spec.sections import Simulate

C = 2e-3  # rad/rad: large, so that the formula shows far above rounding


def _puma(tmp_path, effects_yaml: str = ""):
    path = tmp_path / "spec.yaml"
    path.write_text(spec_text("puma560", "tracker").replace("armcal: 1\n", f"armcal: 1\n{effects_yaml}", 1))
    return load_spec(path)


def _numpy_readings(q: np.ndarray) -> np.ndarray:
    """Tracker x, y, z (N, 3) of the nominal PUMA (independent_sim's DH rows) at joint angles q (N, 6) rad."""
    geom = {"rows": [(t * DEG, d, a, al * DEG, 0.0) for t, d, a, al in ROBOTS["puma560"]["dh"]]}
    flange = frames(geom, q)[-1]
    base = pose(2000.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # the spec's robot_base
    return (flange @ np.append(TRACKER["target"], 1.0) @ base.T)[:, :3]


def test_the_coupling_is_q3_plus_c_q2_in_a_numpy_dh_chain(tmp_path):
    """armcal's prediction (the fitted model) and its simulator's truth, each with dq3 = c q2, equal a numpy DH
    chain at q3 + c q2; the same numpy chain at q3 alone is millimetres off."""
    spec = _puma(tmp_path).spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    q = np.random.default_rng(1).uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (50, 6))
    coupled = q.copy()
    coupled[:, 2] += C * q[:, 1]
    expected = _numpy_readings(coupled)

    effects = EffectSet((coupling_effect(3, 2, values={"coefficient": C}),))
    h = measurement_function(kinematics, device, ("smr",), effects).map(len(q))
    x = np.zeros((extras_size(6), len(q)))
    predicted = np.array(h(q.T, x, kinematics.parameters.nominal, device.parameters.nominal, effects.values())).T
    assert np.abs(predicted - expected).max() < 1e-9  # mm

    settings = Simulate.model_validate(
        {"sigma_p": 0, "sigma_o": 0, "sigma_e": 0, "effects": [{"type": "joint_coupling", "joint": 3, "from": 2, "coefficient": C}]}
    )
    truth = TrueRobot.draw(kinematics, settings, np.random.default_rng(0))
    base = pose(2000.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    simulated = truth.target_poses("smr", q, {})[:, :3, 3] @ base[:3, :3].T + base[:3, 3]
    assert np.abs(simulated - expected).max() < 1e-9
    assert np.abs(_numpy_readings(q) - expected).max() > 1.0  # the coupling moves the flange by millimetres


def test_the_spec_declares_it_with_from_and_calibrated_yaml_writes_it_back(tmp_path):
    loaded = _puma(tmp_path, "effects:\n  - {type: joint_coupling, joint: 3, from: 2, coefficient: 0.001}\n")
    effect = from_spec(loaded.spec.effects[0])
    assert (effect.id, effect.source_joint) == ("joint_coupling.j3.from2", 2)
    assert [(p.name, p.nominal, p.free, p.unit) for p in effect.parameters()] == [("joint_coupling.j3.from2.coefficient", 0.001, True, "1")]
    entry = to_spec_dict(effect, {"coefficient": 0.00123})
    assert entry == {"type": "joint_coupling", "joint": 3, "from": 2, "coefficient": 0.00123}


@pytest.mark.parametrize(
    "entry, message",
    [
        ("{type: joint_coupling, joint: 3, from: 3}", "a joint driving itself is its encoder scale"),
        ("{type: joint_coupling, joint: 3, from: 7}", "joint 7 does not exist"),
        ("{type: joint_coupling, joint: 3}", "This field is required"),
    ],
)
def test_a_wrong_coupling_is_a_located_spec_error(tmp_path, entry, message):
    from armcal.support.errors import SpecError

    with pytest.raises(SpecError) as error:
        _puma(tmp_path, f"effects:\n  - {entry}\n")
    assert message in str(error.value) and "effects[0]" in str(error.value)


def test_couplings_are_proposed_between_neighbours_and_within_the_wrist():
    assert set(coupling_pairs(6)) == {(1, 2), (2, 1), (2, 3), (3, 2), (3, 4), (4, 3), (4, 5), (5, 4), (5, 6), (6, 5), (4, 6), (6, 4)}
    assert set(coupling_pairs(4)) == {(1, 2), (2, 1), (2, 3), (3, 2), (3, 4), (4, 3)}  # no wrist: neighbours only


def _calibrate(spec_path):
    """The stages of `armcal run` up to the diagnosis' final fit."""
    spec = load_spec(spec_path).spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    raw = read_measurements(spec_path.parent / spec.data.calibration, spec)
    validation = device.prepare(read_measurements(spec_path.parent / spec.data.validation, spec))
    return identify_and_diagnose(spec, kinematics, device, raw, device.prepare(raw), validation)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_hidden_coupling_is_found_not_an_encoder_scale_and_its_coefficient_identified(tmp_path, seed):
    """dq3 = c q2 hidden at three noise sigmas in a PUMA tracker campaign: joint_coupling j3 from 2 is added first,
    no encoder scale at all, c within three standard deviations, the held-out RMS at the noise."""
    info = write_campaign(tmp_path, "puma560", [coupling(3, 2)], seed=seed, sigmas=3.0)
    diagnosis = _calibrate(info["spec"]).diagnosis
    first = diagnosis.rounds[0]
    assert first.accepted is not None and first.accepted.id == "joint_coupling.j3.from2", first.note
    assert not any(e.type == "encoder_scale" for e in diagnosis.added)
    name = "joint_coupling.j3.from2.coefficient"
    index = diagnosis.problem.parameters.index(name)
    value, std, truth = diagnosis.fit.theta[index], diagnosis.fit.std[index], info["effects"][0]["value"]
    assert abs(value - truth) < 3 * std, (value, std, truth)
    assert std < 0.1 * truth
    r, _ = diagnosis.validation.evaluate(diagnosis.fit.theta)
    assert np.sqrt(np.mean(r**2)) < 1.15  # noise sigmas


def test_calibrated_yaml_with_an_added_coupling_reproduces_the_fit(tmp_path):
    """`armcal run`: the coupling written into calibrated.yaml (joint, from, coefficient) predicts as the fit did."""
    info = write_campaign(tmp_path, "puma560", [coupling(3, 2)], seed=0, sigmas=3.0)
    first, _ = round_trip(info["spec"], tmp_path / "out")
    [added] = first.diagnosis.added_effects
    assert (added.type, added.joint, added.from_joint) == ("joint_coupling", 3, 2)  # driven 3, driving 2, as simulated
    assert [p.unit for p in added.parameters] == ["1"]


def test_a_simulated_coupling_is_recorded_in_truth_json_and_read_back(tmp_path):
    """`armcal simulate` with the coupling under simulate.effects: truth.json holds it, the run's truth reads it back."""
    import json

    from armcal.simulate import write_simulation

    loaded = _puma(tmp_path, "simulate:\n  effects:\n    - {type: joint_coupling, joint: 3, from: 2, coefficient: 0.0002}\n")
    write_simulation(loaded, tmp_path / "sim")
    record = json.loads((tmp_path / "sim" / "truth.json").read_text())
    robot = TrueRobot.from_record(compile_robot(loaded.spec.robot.chain()), record)
    [effect] = robot.effects.effects
    assert (effect.id, effect.values) == ("joint_coupling.j3.from2", {"coefficient": 0.0002})
