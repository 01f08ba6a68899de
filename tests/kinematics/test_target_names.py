"""A target's name is any text the spec's schema takes: it names data, never code (kinematics/compiler.py)."""

import numpy as np
import pytest
from conftest import ROOT, armcal_cli

from armcal.kinematics.compiler import compile_robot
from armcal.spec import load_spec

SPEC = ROOT / "specs" / "puma560_dh.yaml"
NAMES = ["sparker-1", "sparker 2", "=SUM(1)", "3rd", "fk", "\u00fcber_punkt"]  # not identifiers: a dash, a space, a formula, a digit first, unicode


@pytest.mark.parametrize("name", NAMES)
def test_any_target_name_compiles_validates_and_moves_as_before(tmp_path, name):
    """The renamed target's pose equals the original's at random configurations (the same chain, another name), and
    `validate` and `fk` exit 0 without a traceback."""
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC.read_text().replace("sparker1", name if name.isascii() and " " not in name and "=" not in name else f'"{name}"'))
    before, after = compile_robot(load_spec(SPEC).spec.robot.chain()), compile_robot(load_spec(spec).spec.robot.chain())
    q = np.random.default_rng(1).uniform(-1.0, 1.0, (5, 6))
    np.testing.assert_array_equal(after.target_poses(name, q), before.target_poses("sparker1", q))
    for command in (("validate", spec), ("fk", spec, "--target", name, "--q", "0,0,0,0,0,0")):
        done = armcal_cli(*command)
        assert done.returncode == 0 and "Traceback" not in done.stderr, (command, done.stderr)
