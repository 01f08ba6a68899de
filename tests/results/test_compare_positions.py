"""armcal compare on a Gen3-like arm imported from its URDF (a six_parameter chain, its angles written 1.5708 and
3.1416 as the maker's file writes them), simulated outside armcal (the URDF's own forward kinematics,
tests/robot_urdfs.py, and a tracker in numpy) and measured twice at other poses: one truth compares clean, parameter
by parameter and by predicted positions; a longer forearm in the second truth is found in the parameters at 5 combined
standard uncertainties and in the positions at 10 (FAR says why). The propagation J C J^T is checked against finite
differences of an independent numpy chain."""

import json

import numpy as np
import pytest
from conftest import armcal_cli
from independent_sim import pose
from robot_urdfs import Chain, Joint, urdf_flange_pose

from armcal.commands.run import run
from armcal.results.compare import compare
from armcal.results.reader import read_results
from armcal.evaluate.position_changes import RunModel, poses, predicted, run_model

# Kinova Gen3 (6 dof) joint origins as kortex_description writes them, metres and radians (rounded angles included)
JOINTS = [((0, 0, 0.15643), (3.1416, 0, 0)), ((0, 0.005375, -0.12838), (1.5708, 0, 0)), ((0, -0.41, 0), (3.1416, 0, 0)),
          ((0, 0.20843, -0.006375), (1.5708, 0, 0)), ((0, -0.00017505, -0.10593), (-1.5708, 0, 0)),
          ((0, 0.10593, -0.00017505), (1.5708, 0, 0))]
FLANGE = Joint((0, 0, -0.0615), (np.pi, 0, 0))
LIMITS = [(-360, 360), (-138, 138), (-152, 152), (-360, 360), (-127, 127), (-360, 360)]  # deg
SMR = np.array([0.040, 0.025, 0.0])  # the reflector in the flange frame, m: (40, -25, -61.5) mm on link 6
TRACKER = pose(2000.0, -500.0, 300.0, np.deg2rad(30), np.deg2rad(1), np.deg2rad(-2))  # base seen from the tracker, mm
NOISE = 0.01  # mm
SIGMAS = 5.0  # the forearm change in combined standard uncertainties the parameters must find
FAR = 10.0  # and the positions: each pose sees a part of one parameter's change (its chi2 up to FAR^2), and Holm's
# threshold over 100 positions is chi2 = 21 on 3 dof, so 5 (at most 25) is not enough with a margin


def _urdf() -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(8))
    joints = "".join(f'<joint name="joint_{i + 1}" type="revolute"><origin xyz="{" ".join(map(str, xyz))}" rpy="{" ".join(map(str, rpy))}"/>'
                     f'<parent link="l{i}"/><child link="l{i + 1}"/><axis xyz="0 0 1"/>'
                     f'<limit lower="{np.deg2rad(lo)}" upper="{np.deg2rad(hi)}" effort="1" velocity="1"/></joint>'
                     for i, ((xyz, rpy), (lo, hi)) in enumerate(zip(JOINTS, LIMITS)))
    return (f'<robot name="gen3_like">{links}{joints}<joint name="flange" type="fixed"><origin xyz="0 0 -0.0615" rpy="{np.pi} 0 0"/>'
            '<parent link="l6"/><child link="l7"/></joint></robot>')


def _truth(rng) -> list[Joint]:
    """The true robot: every joint origin off the URDF's by 0.2 mm and 0.02 deg (one sigma)."""
    return [Joint(tuple(np.add(xyz, rng.normal(0, 2e-4, 3))), tuple(np.add(rpy, rng.normal(0, np.deg2rad(0.02), 3))), (0, 0, 1))
            for xyz, rpy in JOINTS]


def _campaign(folder, spec_text, truth, seed):
    """A tracker campaign of ``truth`` (120 calibration and 60 validation poses from ``seed``), then armcal run."""
    rng = np.random.default_rng(seed)
    folder.mkdir()
    (folder / "spec.yaml").write_text(spec_text)
    chain = Chain("simulated truth", (*truth, FLANGE))
    low, high = np.array(LIMITS).T * 0.8
    for name, count in (("calibration.csv", 120), ("validation.csv", 60)):
        q = rng.uniform(low, high, (count, 6))
        points = [urdf_flange_pose(chain, np.deg2rad(row)) @ np.append(SMR, 1.0) for row in q]
        xyz = np.array([(TRACKER @ np.append(p[:3] * 1000.0, 1.0))[:3] for p in points]) + rng.normal(0, NOISE, (count, 3))
        lines = ["sample,target," + ",".join(f"q{i + 1}" for i in range(6)) + ",x,y,z"]
        lines += [",".join([str(k + 1), "smr", *(f"{v:.10f}" for v in qs), *(f"{v:.6f}" for v in p)]) for k, (qs, p) in enumerate(zip(q, xyz))]
        (folder / name).write_text("\n".join(lines) + "\n")
    run(folder / "spec.yaml", folder / "out", pdf=False)
    return folder / "out"


@pytest.fixture(scope="module")
def gen3(tmp_path_factory):
    root = tmp_path_factory.mktemp("gen3")
    (root / "gen3.urdf").write_text(_urdf())
    imported = armcal_cli("import-urdf", root / "gen3.urdf", "--base", "l0", "--tip", "l7", "--out", root / "imported.yaml", "--convention", "six_parameter")
    assert imported.returncode == 0, imported.stderr
    text = (root / "imported.yaml").read_text().replace('"EDIT-ME"', "GEN3-SIM")
    stand_in = "tool_point: {link: 6, x: {value: 50, vary: false}, y: {value: 0, vary: false}"  # 50 mm off joint 6's axis
    assert stand_in in text
    text = text.replace(stand_in, "smr: {link: 6, x: {value: 40, vary: false}, y: {value: -25, vary: false}")
    text = text.replace("targets: [tool_point]", "targets: [smr]").replace("robot_base: {x: 0, y: 0, z: 0, rz: 0, ry: 0, rx: 0}", "robot_base: {x: 2000, y: 0, z: 0, rz: 0, ry: 0, rx: 0}")
    text += "validation: {type: poses, count: 60}\ndata: {calibration: calibration.csv, validation: validation.csv}\n"
    truth = _truth(np.random.default_rng(5))
    first = _campaign(root / "first", text, truth, seed=51)
    same = _campaign(root / "same", text, truth, seed=52)
    std = next(p["std"] for p in json.loads((first / "results.json").read_text())["parameters"] if p["name"] == "L3.y")
    (xyz, rpy, axis) = truth[2].xyz, truth[2].rpy, truth[2].axis
    changed = {}
    for sigmas in (SIGMAS, FAR):  # L3.y = -410 mm made longer by that many combined standard uncertainties
        longer = [*truth[:2], Joint((xyz[0], xyz[1] - sigmas * np.sqrt(2.0) * std / 1000.0, xyz[2]), rpy, axis), *truth[3:]]
        changed[sigmas] = _campaign(root / f"changed{sigmas:g}", text, longer, seed=52)
    return first, same, changed


def _rows(text: str) -> dict[str, str]:
    """The parameter block's lines by parameter name."""
    block = text.split("\n\n")[0].splitlines()[2:-1]
    return {line.split()[0]: line for line in block}


def test_one_robot_measured_twice_compares_clean_and_a_held_parameter_gets_no_z(gen3):
    first, same, _ = gen3
    text, significant = compare(str(first), str(same))
    assert significant == 0, text
    assert "0 significant change(s) among 100 predicted positions" in text
    held = {f["name"] for out in (first, same) for f in json.loads((out / "results.json").read_text())["identifiability"]["fixed"]}
    rows = _rows(text)
    for name in held & rows.keys():  # held on at least one side, identified on the other: shown, never given a z
        assert "not comparable (" in rows[name] and rows[name].split()[5] == "-", rows[name]
    for name in ("L4.y", "L5.y", "L4.beta"):  # the Gen3's redundant pairs: each campaign identifies the same member
        assert name in rows and "not comparable" not in rows[name], rows.get(name)


def test_a_longer_forearm_is_found_in_the_parameters_and_the_positions(gen3):
    first, _, changed = gen3
    text, _ = compare(str(first), str(changed[SIGMAS]))
    rows = _rows(text)
    assert [name for name, line in rows.items() if line.endswith("significant")] == ["L3.y"], text
    z = float(rows["L3.y"].split()[5])
    assert -SIGMAS - 3 < z < -SIGMAS + 3  # -SIGMAS expected, its own noise 1
    positions = compare(str(first), str(changed[FAR]))[0].split("\n\n")[1]
    assert "0 significant change(s) among" not in positions and "  smr at pose" in positions, positions


def _six_parameter_fk(robot, q, values):
    """Tool origin and reflector (mm) of a six_parameter spec robot in numpy (Goswami (3): Trans Rz Ry Rx per link,
    Rz(q) per joint), with the spec's values replaced by ``values`` {name: internal value}."""
    def v(name, default):
        return values.get(name, default)

    T = np.eye(4)
    for i, link in enumerate(robot.links[: robot.dof]):
        f = {k: v(f"L{i + 1}.{k}", getattr(link, k).value) for k in ("x", "y", "z", "alpha", "beta", "gamma")}
        T = T @ pose(f["x"], f["y"], f["z"], f["alpha"], f["beta"], f["gamma"]) @ pose(0, 0, 0, q[i], 0, 0)
    tool = robot.tool
    flange = T @ pose(*(v(f"tool.{k}", getattr(tool, k).value) for k in ("x", "y", "z", "rz", "ry", "rx")))
    target = robot.targets["smr"]
    return flange[:3, 3], (T @ np.array([target.x.value, target.y.value, target.z.value, 1.0]))[:3]


def test_the_propagated_covariance_is_j_c_jt_of_an_independent_chain(gen3):
    """S = J C J^T at three of the common poses, J by central differences of a numpy chain (not armcal's), C random."""
    first, _, _ = gen3
    from armcal.spec import load_spec

    base = run_model(first, read_results(first / "results.json"))
    robot = load_spec(first / "calibrated.yaml").spec.robot
    names = [base.model.parameters.names[i] for i in base.identified]
    nominal = {n: base.model.parameters.nominal[base.model.parameters.index(n)] for n in names}
    A = np.random.default_rng(0).normal(size=(len(names), len(names))) * 1e-3
    model = RunModel(base.model, base.identified, A @ A.T, base.ranges)
    Q = poses(base.ranges)[:3]
    found = predicted(model, Q)
    for k, q in enumerate(Q):
        columns = []
        for n in names:
            h = 1e-6
            up, down = (_six_parameter_fk(robot, q, {**nominal, n: nominal[n] + s}) for s in (h, -h))
            columns.append(np.concatenate([(up[0] - down[0]), (up[1] - down[1])]) / (2 * h))
        J = np.array(columns).T
        S = J @ model.covariance @ J.T
        tool, smr = _six_parameter_fk(robot, q, nominal)
        np.testing.assert_allclose(found["tool"][0][k], tool, atol=1e-9)
        np.testing.assert_allclose(found["smr"][0][k], smr, atol=1e-9)
        np.testing.assert_allclose(found["tool"][1][k], S[:3, :3], rtol=1e-5, atol=1e-9 * np.abs(S).max())
        np.testing.assert_allclose(found["smr"][1][k], S[3:, 3:], rtol=1e-5, atol=1e-9 * np.abs(S).max())
