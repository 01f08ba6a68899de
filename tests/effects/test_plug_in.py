"""An effect type defined here, outside armcal, and registered as a plug-in (effects/registry.py): a joint deviation
c q_j^2. A simulation hides it in a shipped example's robot, a run fits it as a declared effect, and compensate
inverts it; no file of armcal knows it (docs/architecture.md, "A new effect")."""

import csv
from typing import Literal

import numpy as np
import pytest
from conftest import copy_example
from ruamel.yaml import YAML

from armcal.commands.run import run
from armcal.effects.effect_type import EffectType, JointEffect
from armcal.effects.registry import register, unregister
from armcal.export.compensation import compensate
from armcal.kinematics.compiler import compile_robot
from armcal.kinematics.transforms import pose_from_matrix
from armcal.simulate import write_simulation
from armcal.spec import load_spec
from armcal.spec_parts.base import AngleParam, Parameter

TRUE_C = 0.03  # deg per rad^2: the hidden amplitude
JOINT = 3


class SquareOffset(JointEffect):
    """A joint offset growing with the square of the joint's reading."""

    type: Literal["square_offset"]
    c: AngleParam = Parameter(value=0.0)


class SquareOffsetType(EffectType):
    name = "square_offset"
    spec_model = SquareOffset
    compensated = True

    def fields(self, effect):
        return [("c", "angle")]

    def joint_deviation(self, effect, chain, value):
        return value("c") * chain.q[effect.joint - 1] ** 2


SQUARE_OFFSET = SquareOffsetType()


@pytest.fixture
def square_offset():
    register(SQUARE_OFFSET)
    yield SQUARE_OFFSET
    unregister(SQUARE_OFFSET)


def _spec(folder):
    """The hidden_harmonic example with the toy hidden in its simulation and declared in its model, no diagnosis."""
    copy_example("hidden_harmonic", folder, ("spec.yaml",))
    yaml = YAML()
    root = yaml.load((folder / "spec.yaml").read_text())
    root["simulate"]["effects"] = [{"type": "square_offset", "joint": JOINT, "c": TRUE_C}]
    root["effects"] = [{"type": "square_offset", "joint": JOINT}]
    root["diagnose"] = {"enabled": False}
    with open(folder / "spec.yaml", "w") as stream:
        yaml.dump(root, stream)
    return folder / "spec.yaml"


def test_a_registered_effect_is_simulated_fitted_and_compensated(tmp_path, square_offset):
    spec = _spec(tmp_path)
    write_simulation(load_spec(spec), tmp_path)
    results = run(spec, tmp_path / "out", pdf=False).results
    assert results.status == "converged"
    fitted = next(p for p in results.parameters if p.name == f"square_offset.j{JOINT}.c")
    assert fitted.free and abs(fitted.value - TRUE_C) < 3 * fitted.std

    calibrated = load_spec(tmp_path / "out" / "calibrated.yaml")
    kinematics = compile_robot(calibrated.spec.robot.chain())
    seeds = np.deg2rad([[10, -60, 80, 20, 30, 40], [-30, -100, 120, -40, 50, 10], [45, -20, 30, 60, -45, -90]])
    rows = ["name,x,y,z,rx,ry,rz,q1,q2,q3,q4,q5,q6"]
    for i, q in enumerate(seeds):
        x, y, z, rz, ry, rx = pose_from_matrix(np.array(kinematics.fk(q, kinematics.parameters.nominal)))
        rows.append(",".join([f"t{i}", *(repr(float(v)) for v in (x / 10, y / 10, z / 10, *np.rad2deg([rx, ry, rz]), *np.rad2deg(q)))]))  # cm, deg
    text, unreached, left_out, _ = compensate(calibrated, None, "\n".join(rows) + "\n", "targets")
    assert not unreached and left_out == []
    commands = np.deg2rad([[float(r[f"q{j}"]) for j in range(1, 7)] for r in csv.DictReader(text.splitlines())])
    c = np.deg2rad(fitted.value)
    reached = commands.copy()
    reached[:, JOINT - 1] += c * commands[:, JOINT - 1] ** 2  # where the calibrated robot's joint sits when so commanded
    assert np.abs(reached - seeds).max() < 1e-9
    assert np.abs(commands - seeds)[:, JOINT - 1].min() > 1e-5  # the command is not the target's joints: the toy was inverted
