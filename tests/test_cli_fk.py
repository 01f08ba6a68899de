"""`armcal fk`: nominal poses in the spec's units, joint values checked against limits."""

import subprocess

from conftest import SPECS, armcal_cli


def _fk(*args: str) -> subprocess.CompletedProcess:
    return armcal_cli("fk", *args)


def test_fk_prints_the_tool_position_in_spec_units():
    # Table 6-2 PUMA at DH zero: (a2 + a3, d2, base + d4) = (41.148, 14.909, 67.183 + 43.307) cm
    result = _fk(str(SPECS / "puma560_dh.yaml"), "--q", "0,0,0,0,0,0")
    assert result.returncode == 0, result.stderr
    position = next(line for line in result.stdout.splitlines() if "position" in line)
    assert [round(float(v), 4) for v in position.split(":")[1].split(",")] == [41.148, 14.909, 110.49]


def test_fk_of_a_target():
    # sparker6 of puma560_dh at (33.3, 0, 10.225) cm in the flange frame, DH zero: flange z up
    result = _fk(str(SPECS / "puma560_dh.yaml"), "--q", "0,0,0,0,0,0", "--target", "sparker6")
    position = next(line for line in result.stdout.splitlines() if "position" in line)
    assert [round(float(v), 4) for v in position.split(":")[1].split(",")] == [74.448, 14.909, 120.715]  # (41.148 + 33.3, 14.909, 110.49 + 10.225)


def test_fk_refuses_a_joint_outside_its_limits():
    result = _fk(str(SPECS / "puma560_dh.yaml"), "--q", "0,0,0,0,0,300")
    assert result.returncode == 1
    assert "joint 6 = 300 lies outside its limits [-266, 266] deg" in result.stderr
    assert "Traceback" not in result.stderr


def test_fk_refuses_a_wrong_count_or_unit():
    assert "needs 6 joint values, got 2" in _fk(str(SPECS / "puma560_dh.yaml"), "--q", "0,0").stderr
    result = _fk(str(SPECS / "puma560_dh.yaml"), "--q", "0,0,0,0,0,1 furlong")
    assert result.returncode == 1 and "'furlong' is not an angle unit" in result.stderr
