"""import-urdf --convention, and the way on to a controller: import -> simulate -> run -> export (urdf, dh-table).

Oracles independent of armcal's model: yourdfpy (tests/urdf_oracle.py) moves every URDF, and the DH table's forward
kinematics is computed here in numpy from the table's text (Stone (2.9) then Rot(y, beta)). Three chains: armcal's
own UR5e export (dh), a hand-written arm with rpy origins and axes along y (dh), and ROS-Industrial style
tests/data/urdf/ros_industrial.urdf whose joint_a2 and joint_a3 axes are 0.0229 deg from parallel (no DH table holds
them with a near common normal: mdh, Hayati's beta)."""

import re

import numpy as np
import pytest
import urdf_oracle
from conftest import ROOT, armcal_cli

from armcal.kinematics.compiler import compile_robot
from armcal.commands.run import run
from armcal.spec import load_spec

HALF = "1.5707963267948966"
HAND = f"""<?xml version="1.0"?>
<robot name="hand_arm">
  <link name="base_link"/><link name="shoulder"/><link name="upper_arm"/><link name="forearm"/>
  <link name="wrist_1"/><link name="wrist_2"/><link name="wrist_3"/><link name="flange"/><link name="tool0"/>
  <joint name="pan" type="revolute"><origin xyz="0 0 0.3" rpy="0 0 {HALF}"/><parent link="base_link"/><child link="shoulder"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="lift" type="revolute"><origin xyz="0.05 0.02 0.1" rpy="0 0.3 0"/><parent link="shoulder"/><child link="upper_arm"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><origin xyz="0 0.01 0.45" rpy="3.141592653589793 0 0"/><parent link="upper_arm"/><child link="forearm"/>
    <axis xyz="0 -1 0"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <joint name="roll_1" type="revolute"><origin xyz="0.4 0 -0.03" rpy="0 {HALF} 0"/><parent link="forearm"/><child link="wrist_1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="bend" type="revolute"><origin xyz="0 0 0.08" rpy="0 0 0"/><parent link="wrist_1"/><child link="wrist_2"/>
    <axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint>
  <joint name="roll_2" type="continuous"><origin xyz="0 0 0.07" rpy="{HALF} 0 0.2"/><parent link="wrist_2"/><child link="wrist_3"/>
    <axis xyz="-1 0 0"/></joint>
  <joint name="wrist_3-flange" type="fixed"><origin xyz="-0.01 0 0" rpy="0 -{HALF} 0"/><parent link="wrist_3"/><child link="flange"/></joint>
  <joint name="flange-tool0" type="fixed"><origin xyz="0 0 0.12" rpy="0.1 0 0"/><parent link="flange"/><child link="tool0"/></joint>
</robot>
"""
CAMPAIGN = ("validation: {type: poses, count: 20, seed: 2}\ndata: {calibration: calibration.csv, validation: validation.csv}\n"
            "simulate: {seed: 7, sigma_p: 0.2, sigma_o: 0.02, sigma_e: 0.05}\nreport: {tasks: []}\n")


def _ur5e(folder):
    """armcal's own URDF of the library's UR5e (`armcal new`, then `armcal export --format urdf`)."""
    spec, urdf = folder / "ur5e.yaml", folder / "ur5e.urdf"
    assert armcal_cli("new", "--robot", "ur5e", "--device", "tracker", "--out", spec).returncode == 0
    assert armcal_cli("export", spec, "--format", "urdf", "--out", urdf).returncode == 0
    return urdf


def _hand(folder):
    (folder / "hand.urdf").write_text(HAND)
    return folder / "hand.urdf"


CASES = {  # name: (URDF maker, --base, --tip, the links that move, the convention chosen, the reason's start)
    "ur5e": (_ur5e, "world", "tool0", [f"link_{i}" for i in range(1, 7)], "dh", None),
    "hand": (_hand, "base_link", "tool0", ["shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"], "dh", None),
    "ros_industrial": (lambda folder: ROOT / "tests" / "data" / "urdf" / "ros_industrial.urdf", "base_link", "tool0",
                       [f"link_{i}" for i in range(1, 7)], "mdh",
                       "  mdh, not dh: the axes of joint_a2 and joint_a3 are 0.0229 deg from parallel, neither parallel nor more than "
                       "5 deg from it: their common normal lies 1.14e+06 mm along joint_a2's axis (Stone's Table 6-3); Hayati's beta holds them"),
}


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    T = np.eye(4)
    T[i, i], T[i, j], T[j, i], T[j, j] = c, -s, s, c
    return T


def _trans(x, y, z) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = x, y, z
    return T


def _table_poses(text: str, Q: np.ndarray) -> np.ndarray:
    """Tool poses (mm) of a DH table (mm and deg) at joint values Q (rad, mm): base A_1(q_1) ... A_n(q_n) tool, A_i =
    Rot(z, theta + q) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha) Rot(y, beta), a prismatic joint's q added to d."""
    lines = text.splitlines()
    assert lines[3] == "joint\ttype\ttheta (deg)\td (mm)\ta (mm)\talpha (deg)\tbeta (deg)", lines[3]
    rows = [line.split("\t") for line in lines[4:] if not line.startswith("#")]

    def pose(frame):
        line = next(line for line in lines if line.startswith(f"# {frame}: "))
        v = {k: float(x) for k, x, _ in re.findall(r"(\w+) (\S+) (mm|deg)", line)}
        return _trans(v["x"], v["y"], v["z"]) @ _rot(2, np.deg2rad(v["rz"])) @ _rot(1, np.deg2rad(v["ry"])) @ _rot(0, np.deg2rad(v["rx"]))

    out = []
    for q in Q:
        T = pose("base")
        for (_, kind, theta, d, a, alpha, beta), value in zip(rows, q):
            theta, alpha, beta, d = np.deg2rad(float(theta)), np.deg2rad(float(alpha)), np.deg2rad(float(beta)), float(d)
            theta, d = (theta + value, d) if kind == "revolute" else (theta, d + value)
            T = T @ _rot(2, theta) @ _trans(0, 0, d) @ _trans(float(a), 0, 0) @ _rot(0, alpha) @ _rot(1, beta)
        out.append(T @ pose("tool"))
    return np.array(out)


def _configurations(limits: np.ndarray, count: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).uniform(limits[:, 0], limits[:, 1], (count, len(limits)))


@pytest.mark.parametrize("case", CASES)
def test_import_simulate_run_export_keeps_the_chain_and_its_names(tmp_path, case):
    """The convention chosen (and why not dh); the imported spec's tool, the exported URDF's links (by the source's
    names) and the DH table's tool where yourdfpy puts the source URDF's (1e-6 mm, 1e-9); then a small simulated
    campaign's calibrated.yaml exports to a URDF with the source's names and a DH table whose tool is the calibrated
    spec's (1e-6 mm)."""
    make, base, tip, links, convention, reason = CASES[case]
    source = make(tmp_path)
    spec = tmp_path / "spec.yaml"
    imported = armcal_cli("import-urdf", source, "--base", base, "--tip", tip, "--out", spec)
    assert imported.returncode == 0, imported.stderr
    assert f"joints from '{base}' to '{tip}', {convention}" in imported.stdout.splitlines()[0]
    said = imported.stdout.splitlines()[1]
    assert said == reason if reason else said.startswith("  its serial, target, device and procedure are stand-ins"), imported.stdout
    robot = load_spec(spec).spec.robot
    assert robot.convention == convention and robot.link_names() == [base, *links, tip]
    nominal = compile_robot(robot.chain())
    Q = _configurations(nominal.limits, 200, seed=31)
    truth = urdf_oracle.poses(urdf_oracle.load(source), urdf_oracle.joint_values(Q, nominal.joint_types), [*links, tip], base)
    position, rotation = urdf_oracle.differences(nominal.tool_poses(Q), truth[tip])
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)

    for fmt in ("urdf", "dh-table"):
        assert armcal_cli("export", spec, "--format", fmt, "--out", tmp_path / f"nominal.{fmt}").returncode == 0
    exported = urdf_oracle.load(tmp_path / "nominal.urdf")
    assert exported.actuated_joint_names == list(nominal.joint_names)
    moved = urdf_oracle.poses(exported, urdf_oracle.joint_values(Q, nominal.joint_types), [*links, tip], base)
    for link in [*links, tip]:  # every link frame where the source URDF has it: its meshes attach
        position, rotation = urdf_oracle.differences(moved[link], truth[link])
        assert position < 1e-6 and rotation < 1e-9, (link, position, rotation)
    position, rotation = urdf_oracle.differences(_table_poses((tmp_path / "nominal.dh-table").read_text(), Q), truth[tip])
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)

    spec.write_text(spec.read_text().replace("  count: 100", "  count: 40") + CAMPAIGN)
    assert armcal_cli("simulate", spec).returncode == 0
    run(spec, tmp_path / "out", pdf=False)
    calibrated = compile_robot(load_spec(tmp_path / "out" / "calibrated.yaml").spec.robot.chain())
    for fmt in ("urdf", "dh-table"):
        done = armcal_cli("export", tmp_path / "out", "--format", fmt, "--out", tmp_path / f"calibrated.{fmt}")
        assert done.returncode == 0, done.stderr
    exported = urdf_oracle.load(tmp_path / "calibrated.urdf")
    assert [base, *links, tip] == [name for name in exported.link_map if name in (base, *links, tip)]
    found = urdf_oracle.poses(exported, urdf_oracle.joint_values(Q, nominal.joint_types), [tip], base)[tip]
    position, rotation = urdf_oracle.differences(found, calibrated.tool_poses(Q))
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)
    position, rotation = urdf_oracle.differences(_table_poses((tmp_path / "calibrated.dh-table").read_text(), Q), calibrated.tool_poses(Q))
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)
    assert np.max(np.abs(calibrated.tool_poses(Q)[:, :3, 3] - truth[tip][:, :3, 3])) > 1e-3  # the calibration moved it


def test_a_six_parameter_import_exports_to_a_dh_table(tmp_path):
    """--convention six_parameter keeps Goswami's links; its DH table moves as yourdfpy moves the URDF."""
    source = _hand(tmp_path)
    spec = tmp_path / "six.yaml"
    done = armcal_cli("import-urdf", source, "--base", "base_link", "--tip", "tool0", "--out", spec, "--convention", "six_parameter")
    assert done.returncode == 0 and ", six_parameter" in done.stdout, done.stderr
    assert armcal_cli("export", spec, "--format", "dh-table", "--out", tmp_path / "six.txt").returncode == 0
    table = (tmp_path / "six.txt").read_text()
    assert "the six_parameter chain converted to DH parameters" in table.splitlines()[0]
    limits = compile_robot(load_spec(spec).spec.robot.chain()).limits
    Q = _configurations(limits, 200, seed=32)
    truth = urdf_oracle.poses(urdf_oracle.load(source), Q, ["tool0"], "base_link")["tool0"]
    position, rotation = urdf_oracle.differences(_table_poses(table, Q), truth)
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)


def test_a_chain_beyond_dh_values_falls_back_to_six_parameter(tmp_path):
    """Axes 6 deg apart whose common normal lies 2e5 m * cot(6 deg) = 1.9e9 mm up: beyond armcal's 1e9 mm, so
    neither dh nor mdh; the six_parameter spec (links 2e8 mm) moves as yourdfpy moves the URDF."""
    (tmp_path / "far.urdf").write_text(
        '<robot name="far"><link name="a"/><link name="b"/><link name="c"/>'
        '<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint>'
        '<joint name="j2" type="revolute"><origin xyz="0 2e5 0" rpy="0.10471975511965977 0 0"/><parent link="b"/><child link="c"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1"/></joint></robot>')
    done = armcal_cli("import-urdf", tmp_path / "far.urdf", "--base", "a", "--tip", "c", "--out", tmp_path / "far.yaml")
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[1].startswith("  six_parameter, not dh: the chain makes no valid spec: robot.joints[0].d: "), done.stdout
    model = compile_robot(load_spec(tmp_path / "far.yaml").spec.robot.chain())
    Q = _configurations(model.limits, 50, seed=33)
    truth = urdf_oracle.poses(urdf_oracle.load(tmp_path / "far.urdf"), Q, ["c"], "a")["c"]
    position, rotation = urdf_oracle.differences(model.tool_poses(Q), truth)
    assert position < 1e-6 and rotation < 1e-9, (position, rotation)


@pytest.mark.parametrize("value, message", [
    ("foo", "unknown convention 'foo': import-urdf writes dh, mdh, six_parameter"),
    ("DH", "unknown convention 'DH': import-urdf writes dh, mdh, six_parameter"),
    ("s_model", "unknown convention 's_model': import-urdf writes dh, mdh, six_parameter"),
    ("", "unknown convention '': import-urdf writes dh, mdh, six_parameter"),
    ("dh", "{urdf}: a dh spec cannot hold the chain: the axes of joint_a2 and joint_a3 are 0.0229 deg from parallel, neither "
           "parallel nor more than 5 deg from it: their common normal lies 1.14e+06 mm along joint_a2's axis (Stone's Table 6-3); "
           "Hayati's beta holds them (import it as mdh or six_parameter)"),
])
def test_a_convention_the_chain_cannot_have_is_one_message(tmp_path, value, message):
    urdf = ROOT / "tests" / "data" / "urdf" / "ros_industrial.urdf"
    out = tmp_path / "spec.yaml"
    done = armcal_cli("import-urdf", urdf, "--base", "base_link", "--tip", "tool0", "--out", out, "--convention", value)
    assert done.returncode == 1 and done.stdout == "" and not out.exists()
    assert done.stderr == f"error: {message.format(urdf=urdf)}\n"


def test_the_imported_instrument_stands_anywhere(tmp_path):
    """import-urdf's stand-in tracker has its robot base free, so the fit starts from a rigid registration: readings
    simulated with the instrument 9 m away and turned by large angles on every axis are calibrated by the imported
    spec as written (only the data named), the instrument's pose found where the simulation put it. Held, as a
    tracker's default is, the robot's own base has to travel there by Levenberg-Marquardt alone: on these data it
    stops in a false minimum at 189 mm RMS (measured when the stand-in lacked robot_base)."""
    spec = tmp_path / "spec.yaml"
    assert armcal_cli("import-urdf", _hand(tmp_path), "--base", "base_link", "--tip", "tool0", "--out", spec).returncode == 0
    stand_in = "robot_base: {x: 0, y: 0, z: 0, rz: 0, ry: 0, rx: 0}"
    text = spec.read_text()
    assert stand_in in text
    far = {"x": 7000.0, "y": 5500.0, "z": -1800.0, "rz": -170.0, "ry": 40.0, "rx": 100.0}
    campaign = "data: {calibration: calibration.csv}\nsimulate: {seed: 3, sigma_p: 0.2, sigma_o: 0.02, sigma_e: 0.05}\nreport: {tasks: []}\n"
    spec.write_text(text + campaign)
    simulated = tmp_path / "simulated.yaml"
    simulated.write_text(text.replace(stand_in, "robot_base: {" + ", ".join(f"{k}: {v}" for k, v in far.items()) + "}") + campaign)
    assert armcal_cli("simulate", simulated, "--out", tmp_path).returncode == 0
    outcome = run(spec, tmp_path / "out", pdf=False)
    assert outcome.exit_code == 0
    results = outcome.results
    assert results.status == "converged" and results.residuals.calibration.after.rms < 0.05  # mm: readings at the 0.01 mm the spec states
    found = {p.name.split(".")[1]: p for p in results.parameters if p.name.startswith("robot_base.")}
    for field, value in far.items():  # the truth: the simulated pose, at its small simulated error (sigma_p, sigma_o)
        assert abs(found[field].value - value) < (5.0 if field in "xyz" else 0.5), (field, found[field].value)
