"""Touch probe on planes (device plane_contact): simulate -> run -> certificate on a UR5e and a datum cube, the
identifiable-parameter counts reasoned in docs/devices/plane_contact.md, a hidden gear harmonic found by the
diagnosis, located spec errors. Oracles: the simulation's truth (truth.json: the true robot, the true
instrument), an independent numpy version of the contact geometry, and the counts reasoned from invariances."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import armcal_cli
from scipy.spatial.transform import Rotation

from armcal.dataio.reader import read_measurements
from armcal.devices import device_model
from armcal.support.errors import SpecError
from armcal.identify.fit import design_identifiability
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import compile_robot
from armcal.simulate import simulate_campaign
from armcal.simulate.truth import TrueRobot
from armcal.spec import load_spec

NOISE = 0.01  # mm, the starting spec's touch repeatability
HARMONIC = {"sin": 0.01, "cos": 0.005}  # deg, joint 2's hidden first harmonic


def _new_spec(folder: Path, edit=lambda text: text) -> Path:
    """`armcal new --robot ur5e --device plane_contact`, edited, as folder/spec.yaml."""
    folder.mkdir(parents=True, exist_ok=True)
    result = armcal_cli("new", "--robot", "ur5e", "--device", "plane_contact", "--out", folder / "new.yaml")
    assert result.returncode == 0, result.stderr
    text = (folder / "new.yaml").read_text().replace('"new-calibration.csv"', "calibration.csv").replace('"new-validation.csv"', "validation.csv")
    (folder / "spec.yaml").write_text(edit(text))
    return folder / "spec.yaml"


def _simulate_and_run(spec: Path) -> dict:
    for args in (("simulate", spec, "--out", spec.parent), ("run", spec, "--no-pdf", "--out", spec.parent / "out")):
        result = armcal_cli(*args)
        assert result.returncode == 0, result.stdout + result.stderr
    return json.loads((spec.parent / "out" / "results.json").read_text())


@pytest.fixture(scope="module")
def cube(tmp_path_factory) -> Path:
    """A UR5e touching a known datum cube's five faces, simulated and calibrated by the CLI."""
    spec = _new_spec(tmp_path_factory.mktemp("cube"))
    _simulate_and_run(spec)
    return spec.parent


@pytest.fixture(scope="module")
def hidden(tmp_path_factory) -> Path:
    """The same campaign with a first harmonic of joint 2 hidden in the simulated robot."""
    effect = f"  effects: [{{type: gear_harmonic, joint: 2, order: 1, sin: {HARMONIC['sin']}, cos: {HARMONIC['cos']}}}]\n"
    spec = _new_spec(tmp_path_factory.mktemp("hidden"), lambda text: text.replace("  seed: 1\n", "  seed: 1\n" + effect, 1))
    _simulate_and_run(spec)
    return spec.parent


def _truth(folder: Path, data_set: str):
    """From truth.json: the true ball centres of a data set in the planes' frame, and each touch's true contact
    (the ball's distance from its plane minus the radius: the simulated touch's noise), in numpy, not armcal's model."""
    spec = load_spec(folder / "spec.yaml").spec
    record = json.loads((folder / "truth.json").read_text())
    robot = TrueRobot.from_record(compile_robot(spec.robot.chain()), record)
    data = read_measurements(folder / getattr(spec.data, data_set), spec)
    P = _pose({f: record["device_parameters"][f"robot_base.{f}"] for f in ("x", "y", "z", "rx", "ry", "rz")})
    centres = (P @ robot.target_poses(spec.device.probe, data.q, data.extras))[:, :3, 3]
    planes = spec.device.planes  # known (held) faces: their nominal normals and offsets are the truth
    contact = np.array([np.dot(planes[k[0]].normal, c) - planes[k[0]].offset.value - spec.device.radius for k, c in zip(data.keys, centres)])
    return data, centres, contact


def _pose(v: dict) -> np.ndarray:
    """Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx) by scipy (intrinsic ZYX)."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("ZYX", [v["rz"], v["ry"], v["rx"]]).as_matrix()
    T[:3, 3] = [v["x"], v["y"], v["z"]]
    return T


def _centres(spec, data) -> np.ndarray:
    """A spec's model of the ball centres at the data's poses, in the planes' frame."""
    device = device_model(spec)
    values = device.parameters.values(device.parameters.nominal)
    P = _pose({f: values[f"robot_base.{f}"] for f in ("x", "y", "z", "rx", "ry", "rz")})
    return (P @ compile_robot(spec.robot.chain()).target_poses(spec.device.probe, data.q))[:, :3, 3]


def test_simulate_run_certificate_on_a_known_cube(cube):
    """The certificate is written; the residuals are at the touch's noise; the calibrated ball centre is where the
    true robot puts it (3D, in-plane directions included, which no single touch sees) to a few noise sigmas."""
    results = json.loads((cube / "out" / "results.json").read_text())
    assert "touch probe on planes" in (cube / "out" / "certificate.html").read_text()
    check = results["noise_check"]
    assert abs(check["chi2"] / check["dof"] - 1) < 4 * np.sqrt(2 / check["dof"])  # chi2/dof: 1 within four of its sigmas
    calibrated = load_spec(cube / "out" / "calibrated.yaml").spec
    for data_set in ("calibration", "validation"):
        data, true_centres, contact = _truth(cube, data_set)
        assert abs(contact.std() / NOISE - 1) < 4 / np.sqrt(2 * len(contact)) and abs(contact.mean()) < 4 * NOISE / np.sqrt(len(contact))
        design = np.sqrt(np.mean(np.sum((_centres(load_spec(cube / "spec.yaml").spec, data) - true_centres) ** 2, axis=1)))
        error = np.sqrt(np.mean(np.sum((_centres(calibrated, data) - true_centres) ** 2, axis=1)))
        assert error < 3 * NOISE and error < design / 50, (data_set, error, design)
    validation = results["residuals"]["validation"]["after"]["rms"]
    assert validation < 1.2 * _truth(cube, "validation")[2].std()  # the noise these held-out touches carry


def test_identifiable_count_with_a_known_cube(cube):
    """4 n + 6 - 3 = 27 for six revolute joints (docs/devices/plane_contact.md): the cube fixes frame and scale."""
    identifiability = json.loads((cube / "out" / "results.json").read_text())["identifiability"]
    assert identifiability["rank"] == 4 * 6 + 6 - 3
    held = {f["name"] for f in identifiability["fixed"]}
    assert not any(name.startswith("robot_base.") for name in held)  # the base's pose in the cube: all six identified


def _design_rank(spec_path: Path) -> int:
    """Identified parameters at the design point (the nominal) of the spec's simulated calibration campaign."""
    spec = load_spec(spec_path).spec
    device = device_model(spec)
    data = device.prepare(simulate_campaign(spec, spec_path.parent).calibration)
    problem = build_problem(compile_robot(spec.robot.chain()), device, data)
    return design_identifiability(problem, problem.parameters.nominal).rank


def _free(faces: str, offsets: bool):
    """An edit of the starting spec freeing the tilts of ``faces`` and, with ``offsets``, their offsets."""
    def edit(text: str) -> str:
        for face in faces.split():
            held = rf"({face}: \{{normal: \[[^\]]*\], )offset: \{{value: ([\d.]+), vary: false\}}"
            text = re.sub(held, r"\1offset: \2, tilt1: 0, tilt2: 0" if offsets else r"\g<0>, tilt1: 0, tilt2: 0", text)
        return text
    return edit


@pytest.mark.parametrize("edits, expected", [
    # every face's tilts free: the faces turned together about the cube's centre keep their offsets, and the robot
    # base turns with them: three rotations lost
    ([("front back left right top", False)], 27 + 2 * 5 - 3),
    # front, back and top entirely free, left and right tilts free with their offsets (the cube's width) held: every
    # rigid motion but the translation across the held gap is lost (five), the gap fixes the scale
    ([("front back top", True), ("left right", False)], 27 + 3 * 3 + 2 * 2 - 5),
], ids=["tilts", "width"])
def test_identifiable_count_with_free_planes(tmp_path, edits, expected):
    """docs/devices/plane_contact.md's counts with free planes: 27 + what the free planes add - the lost motions."""
    def edit(text: str) -> str:
        for faces, offsets in edits:
            text = _free(faces, offsets)(text)
        return text
    spec = _new_spec(tmp_path, edit)
    assert "tilt1: 0" in spec.read_text()
    assert _design_rank(spec) == expected


def test_planes_that_fix_no_length_are_refused(tmp_path):
    """Every plane free: a scaling of the scene and a rigid motion of it change no contact; validate says both."""
    path = _new_spec(tmp_path, _free("front back left right top", True))
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    messages = {issue.field: issue.message for issue in caught.value.issues}
    assert set(messages) == {"device.planes", "device.robot_base"}
    assert "nothing fixes the length scale" in messages["device.planes"] and "hold robot_base" in messages["device.robot_base"]


def test_the_hidden_harmonic_is_found(hidden):
    results = json.loads((hidden / "out" / "results.json").read_text())
    diagnosis = results["diagnosis"]
    assert [(e["type"], e["joint"], e["order"]) for e in diagnosis["added_effects"]] == [("gear_harmonic", 2, 1)]
    first = diagnosis["rounds"][0]
    assert first["accepted"]["type"] == "gear_harmonic" and first["rms_after"]["validation"] < 0.7 * first["rms_before"]["validation"]
    for parameter in diagnosis["added_effects"][0]["parameters"]:
        truth = HARMONIC[parameter["name"].rsplit(".", 1)[-1]]
        assert abs(parameter["value"] - truth) < 3 * parameter["std"], parameter
    assert results["residuals"]["validation"]["after"]["rms"] < 1.2 * _truth(hidden, "validation")[2].std()


def _model_spec(tmp_path: Path, planes: str = "", probe: str = "probe") -> Path:
    def edit(text: str) -> str:
        text = text.replace("  probe: probe\n", f"  probe: {probe}\n")
        return text.replace("  planes:\n", f"  planes:\n{planes}", 1) if planes else text
    return _new_spec(tmp_path, edit)


def test_readings_against_an_independent_geometry(tmp_path):
    """contact = n . (P s) - d - r, n the nominal normal turned by tilt1 about u1 and tilt2 about u2 (scipy)."""
    spec = load_spec(_model_spec(tmp_path, "    slant: {normal: [1, 2, 2], offset: 30, tilt1: 0.5, tilt2: -0.8}\n")).spec
    device = device_model(spec)
    rng = np.random.default_rng(3)
    values = dict(zip(device.parameters.names, device.parameters.nominal))
    values.update({"robot_base.x": -500.0, "robot_base.rz": 0.3, "robot_base.rx": -0.2, "plane.slant.tilt1": 0.02, "plane.slant.tilt2": -0.05})
    pd = np.array([values[n] for n in device.parameters.names])
    poses = np.repeat(np.eye(4)[None], 5, 0)
    poses[:, :3, :3] = Rotation.random(5, random_state=1).as_matrix()
    poses[:, :3, 3] = rng.uniform(-500, 500, (5, 3))
    n0 = np.array([1.0, 2.0, 2.0]) / 3
    u2 = np.cross(n0, [1.0, 0.0, 0.0])  # x is the axis most nearly square to n0
    u2 /= np.linalg.norm(u2)
    u1 = np.cross(u2, n0)
    turn = Rotation.from_rotvec(0.02 * u1) * Rotation.from_rotvec(-0.05 * u2)
    n = turn.apply(n0)
    P = _pose({f: values[f"robot_base.{f}"] for f in ("x", "y", "z", "rx", "ry", "rz")})
    expected = (P @ poses)[:, :3, 3] @ n - 30.0 - spec.device.radius
    assert device.evaluate(("slant",), poses, pd)[:, 0] == pytest.approx(expected, abs=1e-9)


def test_planned_touches_are_on_the_planes_within_the_cone(tmp_path):
    """Random touches: the nominal robot's ball centre is radius off its plane, the flange's z axis within 30 deg
    of the inward normal, every face drawn."""
    loaded = load_spec(_model_spec(tmp_path))
    spec = loaded.spec
    device, kinematics = device_model(spec), compile_robot(spec.robot.chain())
    Q, keys, _ = device.random_keyed_poses(spec, kinematics, 60, np.random.default_rng(4))
    reached = ~np.isnan(Q).any(axis=1)
    assert reached.mean() > 0.6 and {k[0] for k in keys} == set(spec.device.planes)
    P = _pose({f: getattr(spec.device.robot_base, f).value for f in ("x", "y", "z", "rx", "ry", "rz")})
    frames = P @ kinematics.target_poses("probe", Q[reached])
    for key, frame in zip([k for k, r in zip(keys, reached) if r], frames):
        plane = spec.device.planes[key[0]]
        assert np.dot(plane.normal, frame[:3, 3]) - plane.offset.value == pytest.approx(spec.device.radius, abs=1e-3)
        assert np.degrees(np.arccos(-np.dot(plane.normal, frame[:3, 2]))) < 30 + 1e-3


@pytest.mark.parametrize("edit, expected", [
    (("  probe: probe\n", "  probe: stylus\n"), ("device.probe", "probe 'stylus' is not a robot target (targets: probe)")),
    (("normal: [0, 0, 1]", "normal: [0, 0, 0]"), ("device.planes.top.normal", "A plane's normal must not be zero")),
])
def test_a_bad_spec_is_one_located_message(tmp_path, edit, expected):
    path = _new_spec(tmp_path, lambda text: text.replace(*edit))
    line = next(i for i, text in enumerate(path.read_text().splitlines(), 1) if edit[1].strip() in text)
    with pytest.raises(SpecError) as caught:
        load_spec(path)
    [issue] = caught.value.issues
    assert (issue.line, issue.field) == (line, expected[0]) and expected[1] in issue.message, issue
    result = armcal_cli("validate", path)
    assert result.returncode == 1 and f"{path}:{line}:" in result.stderr and "Traceback" not in result.stderr
