"""One identifiable set per model: decided at the design point, kept by every refit and fold; parallel dh axes
get Hayati's beta; an effect never frees a geometric parameter; Levenberg-Marquardt stops at a minimum."""

import json

import numpy as np
import pytest
from conftest import ROOT, SPECS, armcal_cli, random_configurations
from round_trip import round_trip

from armcal.identify.identifiability import EFFECT_NEW_PART, RANK_TOLERANCE, analyse, extend
from armcal.identify.lm import solve
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.params import ParameterInfo, ParameterSet
from armcal.spec import load_spec


def _dh(theta, d, a, alpha, beta=0.0):
    """Rz(theta) Tz(d) Tx(a) Rx(alpha) Ry(beta), written out (Stone 2.9; Hayati's Ry)."""
    ct, st, ca, sa, cb, sb = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    A = np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st], [0, sa, ca, d], [0, 0, 0, 1.0]])
    return A @ np.array([[cb, 0, sb, 0], [0, 1, 0, 0], [-sb, 0, cb, 0], [0, 0, 0, 1.0]])


def _closed_form(robot, q, betas):
    """Base-to-flange pose of a dh spec robot (the spec's mounting base times the A_i), numpy only."""
    T = np.eye(4)
    base = robot.base
    T[:3, 3] = [base.x.value, base.y.value, base.z.value]
    c, s = np.cos(base.rz.value), np.sin(base.rz.value)
    T[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]  # the shipped dh specs turn their base about z only
    for joint, qi, beta in zip(robot.joints, q, betas):
        T = T @ _dh(joint.theta.value + qi, joint.d.value, joint.a.value, joint.alpha.value, beta)
    return T


@pytest.mark.parametrize("name, parallel", [("ur10.yaml", ["shoulder_lift", "elbow"]), ("puma560_dh.yaml", ["j2"])])
def test_parallel_dh_axes_get_hayatis_beta_and_keep_the_nominal_poses(name, parallel):
    robot = load_spec(SPECS / name).spec.robot
    model = compile_robot(robot.chain())
    entries = {e.name: e for e in model.parameters.entries}
    assert sorted(n.split(".")[0] for n in entries if n.endswith(".beta")) == sorted(parallel)
    for joint in parallel:
        assert entries[f"{joint}.beta"].free and entries[f"{joint}.beta"].nominal == 0.0
        assert not entries[f"{joint}.d"].free and "parallel" in entries[f"{joint}.d"].reason
    Q = random_configurations(model, 20, seed=3)
    for q, pose in zip(Q, model.tool_poses(Q)):  # beta = 0: the nominal poses are those of plain DH
        assert np.allclose(pose, _closed_form(robot, q, np.zeros(robot.dof)), atol=1e-9)
    p = model.parameters.nominal.copy()
    betas = np.zeros(robot.dof)
    for joint in parallel:
        i = robot.joint_names().index(joint)
        betas[i] = 0.01 * (i + 1)
        p[model.parameters.index(f"{joint}.beta")] = betas[i]
    for q, pose in zip(Q, model.tool_poses(Q, p)):  # and beta tilts the next axis about y, as Hayati's link does
        assert np.allclose(pose, _closed_form(robot, q, betas), atol=1e-9)


def test_validate_says_how_parallel_axes_are_modelled():
    out = armcal_cli("validate", SPECS / "ur10.yaml")
    assert out.returncode == 0, out.stderr
    assert "axes 2 and 3: Hayati's shoulder_lift.beta added (free, 0), shoulder_lift.d held" in out.stdout
    assert "axes 3 and 4: Hayati's elbow.beta added (free, 0), elbow.d held" in out.stdout


def _parameters(roles: dict[str, str]) -> ParameterSet:
    return ParameterSet(tuple(ParameterInfo(n, "length", 0.0, True, None, None, role=r) for n, r in roles.items()))


def test_a_redundancy_is_carried_by_the_instrument_then_the_target_not_the_robot():
    """Two exactly redundant columns: the device's (or target's) parameter is kept, the robot's held."""
    rng = np.random.default_rng(0)
    a, b, c = rng.normal(size=(3, 50))
    parameters = _parameters({"j1.theta": "chain", "robot_base.rz": "device", "j6.d": "chain", "tmac.z": "target", "j2.a": "chain"})
    J = np.column_stack([a, 2 * a, b, -0.5 * b, c])
    result = analyse(J, parameters, parameters.free)
    assert set(result.base) == {"robot_base.rz", "tmac.z", "j2.a"}
    assert dict(result.fixed) == {"j1.theta": "redundant with robot_base.rz", "j6.d": "redundant with tmac.z"}


def test_of_two_redundant_robot_parameters_the_spec_s_first_is_identified_whatever_the_last_bits():
    """Exactly redundant columns (a joint's offset along the line of the next one's) whose computed values differ in
    their last bits, either way: the first in the spec's order is kept, as the rule says, not the rounding."""
    rng = np.random.default_rng(2)
    a, b, c = rng.normal(size=(3, 80))
    parameters = _parameters({"L1.a": "chain", "L2.y": "chain", "L3.z": "chain", "L3.b": "chain"})
    for _ in range(20):  # L1.a is taken first; then L2.y and L3.z are a tie that the noise breaks either way
        J = np.column_stack([b + 0.5 * a, a, 3 * a * (1 + 1e-12 * rng.normal(size=80)), c])
        result = analyse(J, parameters, parameters.free)
        assert set(result.base) == {"L1.a", "L2.y", "L3.b"} and dict(result.fixed) == {"L3.z": "redundant with L2.y"}
    barely = b + 2e-7 * a  # after L1.a = b, the pair adds only 2e-7 of a unit column: still a tie, still the spec's order
    for _ in range(20):
        J = np.column_stack([b, barely, 3 * barely * (1 + 1e-13 * rng.normal(size=80)), c])
        result = analyse(J, parameters, parameters.free)
        assert set(result.base) == {"L1.a", "L2.y", "L3.b"} and dict(result.fixed) == {"L3.z": "redundant with L2.y"}


def test_the_pivots_are_greedy_by_new_part_ties_in_the_spec_s_order():
    """Independent oracle: the rule computed by least squares, each step the unit column farthest from the span of
    those taken (the first of equals), until none is farther than the rank tolerance."""
    rng = np.random.default_rng(3)
    names = [f"j{k}.p" for k in range(8)]
    parameters = _parameters(dict.fromkeys(names, "chain"))
    for _ in range(5):
        J = rng.normal(size=(200, 8)) * rng.uniform(0.1, 10.0, size=8)
        J[:, 5] = J[:, 1] - 2 * J[:, 6]  # one dependent column
        unit, taken = J / np.linalg.norm(J, axis=0), []
        while True:
            span = unit[:, taken]
            parts = np.array([np.linalg.norm(u - span @ np.linalg.lstsq(span, u, rcond=None)[0]) if taken else 1.0 for u in unit.T])
            parts[taken] = 0.0
            if parts.max() <= RANK_TOLERANCE:
                break
            taken.append(int(np.flatnonzero(parts >= parts.max() - 1e-10)[0]))
        result = analyse(J, parameters, parameters.free)
        assert result.base == tuple(names[k] for k in taken) and len(taken) == 7


def test_an_effect_never_frees_a_geometric_parameter_and_is_held_where_the_geometry_absorbs_it():
    rng = np.random.default_rng(1)
    a, b, c = rng.normal(size=(3, 60))
    parameters = _parameters({"j1.theta": "chain", "j2.theta": "chain", "e1": "effect", "e2": "effect"})
    free = np.array([True, True, False, False])
    # j2.theta is redundant with j1.theta at the design point; e1 is what j1.theta does; e2 is new
    J = np.column_stack([a, -a, 3 * a + 1e-9 * b, c])
    design = analyse(J, parameters, free)
    assert design.base == ("j1.theta",)
    added = extend(design, J, parameters, ["e1", "e2"])
    assert added.base == ("j1.theta", "e2") and added.rank == 2
    reasons = dict(added.fixed)
    assert reasons["e1"] == "redundant with j1.theta at the design point"
    assert reasons["j2.theta"] == "redundant with j1.theta"  # still held: the effect did not free it
    # a column that keeps more than EFFECT_NEW_PART of its norm off the base is kept
    unit_b = b - a * (a @ b) / (a @ a)
    unit_a, unit_b = a / np.linalg.norm(a), unit_b / np.linalg.norm(unit_b)
    J[:, 2] = np.sqrt(1 - 4 * EFFECT_NEW_PART**2) * unit_a + 2 * EFFECT_NEW_PART * unit_b  # new part 2 EFFECT_NEW_PART
    assert "e1" in extend(design, J, parameters, ["e1"]).base
    # one that keeps more than the rank tolerance but less than EFFECT_NEW_PART is held as weakly identifiable:
    # its std would be over 1000 times what an independent column gives it (issue 29: a fit sliding along it)
    J[:, 2] = np.sqrt(1 - 1e-10) * unit_a + 1e-5 * unit_b  # new part 1e-5
    held = extend(design, J, parameters, ["e1"])
    assert "e1" not in held.base
    assert dict(held.fixed)["e1"] == ("weakly identifiable: nearly redundant with j1.theta (new part 1.0e-05 of its "
                                      "column, below 0.001) at the design point")


def _rosenbrock(x):
    r = np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])
    J = np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])
    return r, J


def test_lm_stops_at_the_minimum_on_a_scale_free_test_and_not_at_the_limit():
    result = solve(_rosenbrock, np.array([-1.2, 1.0]), max_iterations=200)[0]
    assert result.converged and result.iterations < 200, result
    assert np.allclose(result.x, [1.0, 1.0], atol=1e-8)
    stopped = solve(_rosenbrock, np.array([-1.2, 1.0]), max_iterations=2)[0]
    assert not stopped.converged and "iteration limit (2)" in stopped.reason


def test_lm_stopping_does_not_depend_on_the_noise_scale():
    """Residuals of 2^-100 or 2^100 sigmas: the same iterations to the same minimum (the tests are scale-free). Powers
    of two scale every number exactly, so no stopping test meets other last bits than at scale 1."""
    rng = np.random.default_rng(4)
    x = np.linspace(0, 3, 40)
    y = 2.5 * np.exp(-1.3 * x) + 0.01 * rng.normal(size=len(x))
    runs = []
    for scale in (2.0**-100, 1.0, 2.0**100):
        def residuals(p, scale=scale):
            e = np.exp(-p[1] * x)
            return scale * (p[0] * e - y), scale * np.column_stack([e, -p[0] * x * e])

        runs.append(solve(residuals, np.array([1.0, 0.5]))[0])
    assert all(r.converged for r in runs)
    assert len({r.iterations for r in runs}) == 1
    assert np.allclose(runs[0].x, runs[2].x, rtol=1e-9)


def test_kfold_folds_keep_the_full_fits_base_set(tmp_path, monkeypatch):
    """Without a validation set the diagnosis cross-validates: every fold fits the base set of the full fit."""
    import armcal.diagnose.loop as loop
    from armcal.commands.run import run

    folder = ROOT / "examples" / "hidden_harmonic"
    text = (folder / "spec.yaml").read_text().replace("  validation: validation.csv\n", "")
    for name in ("calibration.csv", "truth.json"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    (tmp_path / "spec.yaml").write_text(text)
    calls = []
    real_fit = loop.fit

    def spy(problem, settings, start=None, identifiability=None, initial=None):
        result = real_fit(problem, settings, start, identifiability, initial)
        calls.append((len(problem.residuals.sample), identifiability.base if identifiability else None, result))
        return result

    monkeypatch.setattr(loop, "fit", spy)
    monkeypatch.setattr(loop, "fit_theta", lambda *arguments: spy(*arguments).theta)  # a fold's fit, seen whole
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    full = max(n for n, _, _ in calls)
    trials = {base for n, base, _ in calls if n == full}
    folds = [(base, result) for n, base, result in calls if n < full]
    assert folds and all(base in trials for base, _ in folds)  # each fold on a base set of a full-data fit
    assert all(result.solver.converged for _, result in folds)
    assert results.status == "converged"
    assert [e.type for e in results.diagnosis.added_effects][:1] == ["gear_harmonic"]


def test_a_fit_that_truly_cannot_converge_says_why_everywhere(tmp_path):
    """Two iterations from a start a metre off: exit 3, and the terminal, results.json and certificate agree."""
    folder = ROOT / "examples" / "hidden_harmonic"
    text = (folder / "spec.yaml").read_text()
    text = text.replace("    - {x: 43.18, y: 0, z: 14.909,", "    - {x: 143.18, y: 0, z: 14.909,")  # cm: a2 one metre long
    text = text.replace("procedure:", "fit: {max_iterations: 2}\ndiagnose: {enabled: false}\nprocedure:")
    for name in ("calibration.csv", "validation.csv"):
        (tmp_path / name).write_bytes((folder / name).read_bytes())
    (tmp_path / "spec.yaml").write_text(text)
    out = armcal_cli("run", tmp_path / "spec.yaml", "--out", tmp_path / "out")
    assert out.returncode == 3, out.stderr
    data = json.loads((tmp_path / "out" / "results.json").read_text())
    reason = data["solver"]["reason"]
    assert data["status"] == "not_converged" and reason == "iteration limit (2) reached before a minimum"
    assert f"not_converged ({reason}, 2 iterations)" in out.stdout
    html = (tmp_path / "out" / "certificate.html").read_text()
    assert f"not_converged ({data['solver']['method']}, {reason}, 2 iterations)" in html


SMALL_ARM = """\
armcal: 1
data: {calibration: calibration.csv, validation: validation.csv}
simulate:
  seed: 5
  effects:
    - {type: joint_compliance, joint: 2, compliance: 2.0e-5}
robot:
  name: small six-axis arm
  serial: SMALL-1
  units: {length: mm, angle: deg}
  convention: dh
  joints:
    - {name: j1, limits: [-180, 180], theta: 0, d: 151.9, a: 0, alpha: 90}
    - {name: j2, limits: [-180, 0], theta: 0, d: 0, a: -243.65, alpha: 0}
    - {name: j3, limits: [-150, 150], theta: 0, d: 0, a: -213.25, alpha: 0}
    - {name: j4, limits: [-180, 180], theta: 0, d: 112.35, a: 0, alpha: 90}
    - {name: j5, limits: [-180, 180], theta: 0, d: 85.35, a: 0, alpha: -90}
    - {name: j6, limits: [-180, 180], theta: 0, d: 81.9, a: 0, alpha: 0}
  targets:
    reflector: {link: 6, x: 0, y: 0, z: 40}   # on the last joint's axis
device:
  type: tracker
  targets: [reflector]
  robot_base: {x: 1500, y: 200, z: -300, rz: 150, ry: 0, rx: 0}
  noise: 0.01
effects:
  - {type: joint_compliance, joint: 2}
diagnose: {max_rounds: 2}
procedure: {type: poses, count: 200, seed: 1}
validation: {type: poses, count: 80, seed: 2}
"""


def test_a_reflector_on_the_last_axis_leaves_the_flange_at_its_nominal(tmp_path):
    """The small arm of issue 13: no reading sees joint 6's frame, the reflector carries what the data see,
    and the compliance (default masses) frees none of the flange's parameters."""
    from armcal.commands.run import run
    from armcal.simulate import write_simulation

    (tmp_path / "spec.yaml").write_text(SMALL_ARM)
    write_simulation(load_spec(tmp_path / "spec.yaml"), tmp_path)
    results = run(tmp_path / "spec.yaml", tmp_path / "out", pdf=False).results
    assert results.status == "converged"
    held = {f.name: f.reason for f in results.identifiability.fixed}
    assert held["j6.theta"] == "does not affect the measurements"
    for name in ("j6.d", "j6.a", "j6.alpha"):
        assert held[name].startswith("redundant with reflector."), (name, held[name])
    values = {p.name: p for p in results.parameters}
    for name in ("j6.theta", "j6.d", "j6.a", "j6.alpha"):
        assert values[name].value == values[name].nominal and not values[name].free
    assert "joint_compliance.j2.compliance" in results.identifiability.free
    assert results.identifiability.condition_number < 1e3
    assert results.residuals.validation.after.rms < 1.5 * 0.01  # the noise, per coordinate


@pytest.mark.parametrize("name", sorted(p.parent.name for p in (ROOT / "examples").glob("*/spec.yaml")))
def test_calibrated_spec_reproduces_the_fit(tmp_path, name):
    round_trip(ROOT / "examples" / name / "spec.yaml", tmp_path / "out")
