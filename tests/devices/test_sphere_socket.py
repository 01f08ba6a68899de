"""The sphere-in-sockets method (armcal/devices/sphere_socket.py): a ball on the flange held in fixed sockets.

Every campaign is the starting spec `armcal new --robot ur5e --device sphere_socket` writes, simulated and
calibrated through the CLI. The oracles: the simulation's truth (truth.json: the true robot, the true sockets),
a rigid registration of numpy's own (tests/rigid_fit.py), and the count of identifiable parameters reasoned
from the method's invariances (docs/devices/sphere_socket.md).
"""

import json
import re

import numpy as np
import pytest
from conftest import armcal_cli
from rigid_fit import kabsch

from armcal.devices import device_model
from armcal.support.errors import SpecError
from armcal.kinematics.compiler import compile_robot
from armcal.simulate.truth import TrueRobot
from armcal.spec import load_spec

NOISE = 0.005  # mm: the starter's seating repeatability per coordinate
CONE = 60.0  # deg: random approaches within this of straight down (the module's CONE, restated)
HIDDEN = "effects: [{type: gear_harmonic, joint: 2, order: 1, sin: 0.01, cos: 0.004}]"  # deg


def _cli(*args):
    result = armcal_cli(*args)
    assert result.returncode == 0, result.stdout + result.stderr
    return result


def _starter(folder, edit=lambda text: text):
    """The starting spec for a UR5e in sockets, edited, written to ``folder``/spec.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    _cli("new", "--robot", "ur5e", "--device", "sphere_socket", "--out", folder / "starter.yaml")
    text = edit((folder / "starter.yaml").read_text()).replace('"starter-', '"spec-')
    (folder / "spec.yaml").write_text(text)
    return folder / "spec.yaml"


def _simulate_and_run(folder, edit=lambda text: text):
    spec = _starter(folder, edit)
    _cli("simulate", spec, "--out", folder)
    _cli("run", spec, "--no-pdf")
    out = folder / "out" / "spec"
    return spec, out, json.loads((out / "results.json").read_text())


def _without_distances(text: str) -> str:
    changed = re.sub(r"  distances:.*\n(    - .*\n)+", "", text)
    assert changed != text
    return changed


def _hidden_harmonic(text: str) -> str:
    old = "simulate:   # a simulated true robot for a rehearsal (Stone 7.1-7.8 manufacturing errors)\n  seed: 1\n"
    assert old in text
    return text.replace(old, f"simulate:\n  seed: 1\n  {HIDDEN}\n")


@pytest.fixture(scope="module")
def campaign(tmp_path_factory):
    return _simulate_and_run(tmp_path_factory.mktemp("socket"))


@pytest.fixture(scope="module")
def unscaled(tmp_path_factory):
    return _simulate_and_run(tmp_path_factory.mktemp("unscaled"), _without_distances)


def reasoned_count(revolute: int, prismatic: int, sockets: int, distance: bool) -> int:
    """Identifiable parameters of an arm whose ball sits in free sockets (docs/devices/sphere_socket.md):
    Everett-Hollerbach's 4R + 2P + 6 of a pose measured in a frame of its own (Goswami (1)), less the
    last link's orientation beyond the ball (3: a point is measured), plus 3 per socket, less the rigid motion
    of the robot and the sockets together (6) and, without a certified distance, the overall scale (1)."""
    return 4 * revolute + 2 * prismatic + 6 - 3 + 3 * sockets - 6 - (0 if distance else 1)


def test_random_seatings_put_the_nominal_ball_in_its_socket_within_the_cone(tmp_path):
    loaded = load_spec(_starter(tmp_path))
    spec = loaded.spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    Q, keys, _ = device.random_keyed_poses(spec, kinematics, 40, np.random.default_rng(5))
    reached = ~np.isnan(Q).any(axis=1)
    assert reached.sum() >= 36  # a UR5e reaches sockets on the table in front of it from almost any approach
    poses = kinematics.target_poses(spec.device.ball, Q[reached])
    sockets = np.array([[getattr(spec.device.sockets[k[0]], c).value for c in "xyz"] for k, r in zip(keys, reached) if r])
    assert np.abs(poses[:, :3, 3] - sockets).max() < 1e-3  # mm: the inverse kinematics' tolerance
    tilt = np.degrees(np.arccos(-poses[:, 2, 2]))  # the flange's z axis against straight down
    assert tilt.max() <= CONE + 1e-3 and tilt.max() > CONE / 2  # within the cone, and filling it
    assert set(keys) == {(name,) for name in spec.device.sockets}


def test_simulate_run_certificate_and_the_identified_robot_is_the_true_one(campaign):
    spec_path, out, results = campaign
    assert (out / "certificate.html").exists()
    assert results["status"] == "converged"
    check = results["noise_check"]
    assert 0.8 < check["chi2"] / check["dof"] < 1.2 and check["p_value"] > 1e-3
    for data in ("calibration", "validation"):
        after = results["residuals"][data]["after"]["rms"]
        assert after < 1.2 * NOISE and results["residuals"][data]["before"]["rms"] > 20 * after
    # The identified robot against the simulated truth, where neither was measured: ball positions at random
    # configurations, each model's registered rigidly onto the true robot's (the sockets define the frame, so
    # only the arm's own geometry can be compared). Rigid only: the certified distance fixed the scale.
    spec = load_spec(spec_path).spec
    nominal = compile_robot(spec.robot.chain())
    calibrated = compile_robot(load_spec(out / "calibrated.yaml").spec.robot.chain())
    truth = TrueRobot.from_record(nominal, json.loads((spec_path.parent / "truth.json").read_text()))
    Q = np.random.default_rng(7).uniform(np.radians(-180), np.radians(180), (300, 6))
    true = truth.target_poses("ball", Q, {})[:, :3, 3]

    def registered_rms(model) -> float:
        points = model.target_poses("ball", Q)[:, :3, 3]
        T = kabsch(points, true)
        moved = points @ T[:3, :3].T + T[:3, 3]
        return float(np.sqrt(np.mean(np.sum((moved - true) ** 2, axis=1))))

    assert registered_rms(calibrated) < 0.03 and registered_rms(calibrated) < registered_rms(nominal) / 20
    # the sockets' geometry: every identified socket-to-socket distance the true one
    values = {p["name"]: p["value"] for p in results["parameters"]}
    true_sockets = json.loads((spec_path.parent / "truth.json").read_text())["device_parameters"]
    names = list(spec.device.sockets)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            distance = lambda v: np.linalg.norm([v[f"socket.{a}.{c}"] - v[f"socket.{b}.{c}"] for c in "xyz"])  # noqa: E731
            assert distance(values) == pytest.approx(distance(true_sockets), abs=0.01)


def test_identifiable_count_is_the_reasoned_one_with_and_without_a_certified_distance(campaign, unscaled):
    spec = load_spec(campaign[0]).spec
    sockets = len(spec.device.sockets)
    revolute = sum(j.type == "revolute" for j in spec.robot.joints)
    assert revolute == 6 and sockets == 4
    with_distance, without = campaign[2]["identifiability"], unscaled[2]["identifiability"]
    assert with_distance["rank"] == reasoned_count(revolute, 0, sockets, distance=True) == 33
    assert without["rank"] == reasoned_count(revolute, 0, sockets, distance=False) == 32
    assert "scale" in without["unidentifiable"] and "scale" not in with_distance["unidentifiable"]


def test_a_hidden_gear_harmonic_is_found_and_the_residuals_drop_to_the_noise(tmp_path):
    _, _, results = _simulate_and_run(tmp_path, _hidden_harmonic)
    diagnosis = results["diagnosis"]
    assert [(e["type"], e["joint"], e["order"]) for e in diagnosis["added_effects"]] == [("gear_harmonic", 2, 1)]
    first = diagnosis["rounds"][0]
    assert first["accepted"]["type"] == "gear_harmonic"
    assert first["rms_before"]["validation"] > 2 * NOISE and first["rms_after"]["validation"] < 1.2 * NOISE
    fitted = {p["name"].rsplit(".", 1)[1]: p for p in first["accepted"]["parameters"]}
    for field, truth in (("sin", 0.01), ("cos", 0.004)):
        assert abs(fitted[field]["value"] - truth) < 4 * fitted[field]["std"]
    assert results["residuals"]["validation"]["after"]["rms"] < 1.2 * NOISE
    assert not diagnosis["unexplained"]


def _problems(path):
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    return [(i.line, i.field, i.message) for i in caught.value.issues]


def test_a_ball_that_is_no_robot_target_and_an_unknown_socket_are_located(tmp_path):
    text = _starter(tmp_path).read_text()
    text = text.replace("  ball: ball\n", "  ball: probe\n").replace("between: [socket1, socket4]", "between: [socket1, socket9]")
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    lines = text.splitlines()
    line_of = lambda needle: next(i for i, line in enumerate(lines, 1) if needle in line)  # noqa: E731
    assert _problems(path) == [
        (line_of("ball: probe"), "device.ball", "ball 'probe' is not a robot target (targets: ball)"),
        (line_of("socket9"), "device.distances[0].between[1]", "socket 'socket9' is not in device.sockets (socket1, socket2, socket3, socket4)"),
    ]


def test_every_planned_or_random_design_keeps_the_certified_distance(tmp_path):
    """`armcal plan` scores designs by their information: the certified distance (a reading of no pose) is an
    entry every design keeps, so a random design is no less determined than the plan; without it the scale is lost."""
    from armcal.procedures import pose_selection as ps

    spec = load_spec(_starter(tmp_path)).spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    fixed = ps.fixed_readings(device, kinematics)
    assert fixed is not None and fixed.keys == ((),)  # an entry with no sample: the pseudo-observation alone
    fresh = ps.candidate_poses(spec, kinematics, device, 80, 3)
    information = ps.information(spec, kinematics, device, ps.Candidates.joined([fixed, fresh]))
    assert len(information.base) == reasoned_count(6, 0, len(spec.device.sockets), distance=True)
    rows = ps.random_rows(1 + len(fresh), 40, 1, np.random.default_rng(4))
    assert rows[0] == 0
    covariance = lambda rows: ps.Selection(rows, ps.design_information(information.blocks, rows), "D").covariance()  # noqa: E731
    assert np.isfinite(covariance(rows)).all()
    assert not np.isfinite(covariance(rows[1:])).all()  # the same poses without the distance: the scale is free
