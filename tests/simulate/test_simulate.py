"""Simulated campaigns: reproducible, faithful to the truth model, planned within limits and travel."""

import csv
import json

import numpy as np
import pytest
from conftest import ROOT, SPECS, armcal_cli

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.kinematics.compiler import compile_robot
from armcal.model.measurement import predict
from armcal.procedures import plan
from armcal.simulate import simulate_campaign, write_simulation
from armcal.simulate.truth import TrueRobot
from armcal.spec import load_spec
from armcal.spec.sections import Simulate


def _spec(tmp_path, name, replace=()):
    text = (SPECS / f"{name}.yaml").read_text()
    for old, new in replace:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    return load_spec(path)


def test_same_seed_gives_the_same_bytes(tmp_path):
    loaded = load_spec(SPECS / "puma560_theodolite.yaml")
    _, first = write_simulation(loaded, tmp_path / "a")
    _, second = write_simulation(loaded, tmp_path / "b")
    for a, b in zip(first, second):
        assert a.read_bytes() == b.read_bytes(), a.name
    other = _spec(tmp_path, "puma560_theodolite", [("armcal: 1\n", "armcal: 1\nsimulate: {seed: 7}\n")])
    _, third = write_simulation(other, tmp_path / "c")
    assert third[0].read_bytes() != first[0].read_bytes()


def test_written_data_read_back_equal_the_simulation(tmp_path):
    loaded = load_spec(SPECS / "puma560_six.yaml")
    campaign, written = write_simulation(loaded, tmp_path)
    back = read_measurements(written[0], loaded.spec)
    assert back.keys == campaign.calibration.keys
    assert np.allclose(back.q, campaign.calibration.q, rtol=1e-9, atol=1e-9)
    for channel in ("x", "y", "z"):
        assert np.allclose(back.readings[channel], campaign.calibration.readings[channel], rtol=1e-9, atol=1e-9)
    truth = json.loads(written[-1].read_text())
    assert truth["spec_sha256"] == loaded.sha256 and len(truth["encoder_errors"]) == 6


def test_a_perfect_robot_and_instrument_read_as_the_nominal_model(tmp_path):
    """No manufacturing error, no noise: readings equal the nominal measurement model."""
    loaded = _spec(tmp_path, "puma560_theodolite", [("armcal: 1\n", "armcal: 1\nsimulate: {sigma_p: 0, sigma_o: 0, sigma_e: 0, noise: false}\n")])
    spec = loaded.spec
    campaign = simulate_campaign(spec, loaded.path.parent)
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    data = campaign.calibration
    for key, rows in data.groups().items():
        if device.target(key) is None:
            continue
        predicted = predict(kinematics, device, key, data.q[rows])
        measured = np.stack([data.readings["azimuth"][rows], data.readings["elevation"][rows]], axis=1)
        assert np.abs(predicted - measured).max() < 1e-12


def test_manufacturing_errors_move_the_tool_by_their_size():
    """sigma_p = 0.1 mm, sigma_o = 0.01 deg, sigma_e = 0.1 deg (Stone 7.4) move a PUMA tool by about a millimetre."""
    spec = load_spec(SPECS / "puma560_six.yaml").spec
    kinematics = compile_robot(spec.robot.chain())
    robot = TrueRobot.draw(kinematics, Simulate(), np.random.default_rng(3))
    Q = np.random.default_rng(4).uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (200, 6))
    error = np.linalg.norm(robot.target_poses("reflector", Q, {})[:, :3, 3] - kinematics.target_poses("reflector", Q)[:, :3, 3], axis=1)
    assert 0.2 < np.median(error) < 10.0


def test_hidden_gear_harmonic_is_the_joint_error_it_declares():
    """With only a first-order harmonic on joint 2, the true pose is the nominal one at q2 + A sin(q2) + B cos(q2)."""
    spec = load_spec(SPECS / "puma560_six.yaml").spec
    kinematics = compile_robot(spec.robot.chain())
    settings = Simulate.model_validate(
        {
            "sigma_p": 0.0, "sigma_o": 0.0, "sigma_e": 0.0,
            "effects": [{"type": "gear_harmonic", "joint": 2, "order": 1, "sin": 0.002, "cos": -0.001}],
        },
        context={"units": {"angle": "rad"}},
    )
    robot = TrueRobot.draw(kinematics, settings, np.random.default_rng(0))
    Q = np.random.default_rng(5).uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (100, 6))
    expected = Q.copy()
    expected[:, 1] += 0.002 * np.sin(Q[:, 1]) - 0.001 * np.cos(Q[:, 1])
    assert np.abs(robot.target_poses("reflector", Q, {}) - kinematics.target_poses("reflector", expected)).max() < 1e-9


def test_shell_poses_lie_within_joint_limits_and_lvdt_travel(tmp_path):
    loaded = _spec(tmp_path, "goswami_puma560", [("  longitudes: 23", "  longitudes: 8")])
    spec = loaded.spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    planned = plan(spec.procedure, kinematics, device, spec, tmp_path)
    assert len(planned) > 0.6 * 9 * 5 * 8
    assert np.all((planned.q >= kinematics.limits[:, 0]) & (planned.q <= kinematics.limits[:, 1]))
    for key, rows in _groups(planned).items():
        lengths = predict(kinematics, device, key, planned.q[rows])
        assert np.all(np.abs(lengths[:, 0] - 460.0) <= 37.5)
        assert np.abs(lengths[:, 0] - 460.0).max() < 1e-3  # on the shell at mid-travel


def test_circle_point_sweeps_keep_the_other_joints_at_the_signature():
    spec = load_spec(SPECS / "puma560_dh.yaml").spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    planned = plan(spec.procedure, kinematics, device, spec, SPECS)
    signature = np.asarray(spec.procedure.signature)
    for (target,), rows in _groups(planned).items():
        joint = int(target[-1]) - 1
        others = np.delete(planned.q[rows], joint, axis=1)
        assert np.all(others == np.delete(signature, joint))
        assert len(np.unique(planned.q[rows, joint])) == len(rows) == 20


def _groups(planned):
    out = {}
    for i, key in enumerate(planned.keys):
        out.setdefault(key, []).append(i)
    return out


@pytest.mark.parametrize("name", ["puma560_dh", "puma560_smodel"])
def test_sonic_campaign_has_raw_ranges_and_rods(tmp_path, name):
    loaded = load_spec(SPECS / f"{name}.yaml")
    campaign = simulate_campaign(loaded.spec, SPECS)
    data = campaign.calibration
    assert {"s_A", "s_B", "s_C", "s_D"} <= set(data.readings)
    assert {"rod_B_1", "rod_B_2", "rod_D_1", "rod_D_2"} <= set(data.extras)
    quantum = data.readings["s_A"] / 0.1  # the mean of 10 readings quantised to 0.01 cm
    assert np.allclose(quantum * 10, np.round(quantum * 10), atol=1e-6)


def test_a_procedure_that_plans_no_readable_pose_is_a_clear_error(tmp_path):
    from armcal.support.errors import UserError

    loaded = _spec(tmp_path, "goswami_puma560", [("  longitudes: 23", "  longitudes: 4\n  radius: 500")])  # 5 m shells
    with pytest.raises(UserError, match="the calibration procedure plans no pose the instrument can read"):
        simulate_campaign(loaded.spec, tmp_path)


def test_simulating_hidden_effects_reproduces_the_shipped_example(tmp_path):
    """examples/hidden_harmonic: the same CSV files (every text field, every number to the 10 digits written: another
    processor's last bits may round the tenth the other way), and a truth.json the run can read back."""
    folder = ROOT / "examples" / "hidden_harmonic"
    loaded = load_spec(folder / "spec.yaml")
    _, written = write_simulation(loaded, tmp_path)
    for path in (p for p in written if p.suffix == ".csv"):
        ours, shipped = (list(csv.reader(f.open())) for f in (path, folder / path.name))
        assert ours[0] == shipped[0] and len(ours) == len(shipped), path.name
        for mine, theirs in zip(ours[1:], shipped[1:]):
            assert mine[:2] == theirs[:2], path.name  # sample, target
            np.testing.assert_allclose(np.array(mine[2:], float), np.array(theirs[2:], float), rtol=2e-9, atol=1e-12, err_msg=path.name)
    record = json.loads((tmp_path / "truth.json").read_text())
    robot = TrueRobot.from_record(compile_robot(loaded.spec.robot.chain()), record)
    assert [(e.type, e.joint, e.order, e.values) for e in robot.effects.effects] == [("gear_harmonic", 2, 1, record["hidden_effects"][0]["values"])]


# -- hostile report 30 item 11: truth.json carries a digest of its own content, checked where it is read ------------


def test_an_edited_or_undigested_truth_record_is_refused_and_its_layout_does_not_count(tmp_path):
    """Edits that keep the data hashes (a parameter of the true robot, a hidden effect's value, the record's digest
    removed as in an older file, the digest recomputed by another rule): 'not a truth record', exit 1, no traceback,
    the file unchanged. Re-indenting and reordering keys is no edit. The shipped examples carry a matching digest."""
    import hashlib
    import shutil

    from armcal.support.errors import UserError
    from armcal.simulate import find_truth

    for example in sorted((ROOT / "examples").glob("*/truth.json")):
        assert find_truth(example.parent / "calibration.csv") is not None, example
    folder = ROOT / "examples" / "hidden_harmonic"
    for name in ("spec.yaml", "calibration.csv", "validation.csv", "truth.json"):
        shutil.copy(folder / name, tmp_path / name)
    path, shipped = tmp_path / "truth.json", json.loads((folder / "truth.json").read_text())

    path.write_text(json.dumps(dict(reversed(list(shipped.items()))), indent=4))
    assert find_truth(tmp_path / "calibration.csv")["parameters"] == shipped["parameters"]

    first = sorted(shipped["parameters"])[0]
    edits = {
        "a true parameter": (lambda r: r["parameters"].update({first: r["parameters"][first] + 1e-6}), "does not match"),
        "a hidden effect's value": (lambda r: r["hidden_effects"][0].update({"values": [2 * v for v in r["hidden_effects"][0]["values"]]}), "does not match"),
        "the digest removed": (lambda r: r.pop("record_sha256"), "carries no record_sha256"),
        "the digest of the indented file": (lambda r: r.update({"record_sha256": hashlib.sha256((folder / "truth.json").read_bytes()).hexdigest()}), "does not match"),
    }
    for what, (edit, phrase) in edits.items():
        record = json.loads(json.dumps(shipped))
        edit(record)
        text = json.dumps(record, indent=1, sort_keys=True) + "\n"
        path.write_text(text)
        with pytest.raises(UserError, match=f"{path}: not a truth record written by armcal simulate .*{phrase}"):
            find_truth(tmp_path / "calibration.csv")
        assert path.read_text() == text, what

    done = armcal_cli("run", tmp_path / "spec.yaml", "--out", tmp_path / "out", "--no-pdf")
    assert done.returncode == 1 and "Traceback" not in done.stderr and "not a truth record" in done.stderr, done.stderr
    assert not (tmp_path / "out" / "results.json").exists()


def test_simulate_writes_a_truth_record_whose_digest_is_sha256_of_its_canonical_json(tmp_path):
    """Oracle: hashlib over json.dumps(sort_keys, compact separators) of the record without its digest field."""
    import hashlib

    write_simulation(load_spec(ROOT / "examples" / "hidden_harmonic" / "spec.yaml"), tmp_path)
    record = json.loads((tmp_path / "truth.json").read_text())
    rest = {k: v for k, v in record.items() if k != "record_sha256"}
    canonical = json.dumps(rest, sort_keys=True, separators=(",", ":"), ensure_ascii=True).encode()
    assert record["record_sha256"] == hashlib.sha256(canonical).hexdigest()
    assert record["data_sha256"] == json.loads((ROOT / "examples" / "hidden_harmonic" / "truth.json").read_text())["data_sha256"]
