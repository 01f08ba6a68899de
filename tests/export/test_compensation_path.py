"""compensate keeps one branch along a path of targets: the PUMA 560's tool along a smooth joint trajectory through a
region where the wrist flips easily (joint 5 through 0, where the wrist's two branches meet; joint 4 across the middle
of its limits, beyond which the other wrist branch lies nearer the middle). The targets come from Stone's closed form
(tests/puma_closed_form.py), not from armcal; the rows carry no seeds."""

import csv

import numpy as np
from conftest import SPECS, armcal_cli
from puma_closed_form import t6

BASE_Z = 671.83  # mm: DH frame 0 above the PUMA's base (specs/puma560_dh.yaml, Stone F.4)
POSES = 200


def _trajectory(count: int) -> np.ndarray:
    """Joint values (count, 6) in rad along a smooth path: elbow bent, away from the shoulder and elbow singularities."""
    t = np.linspace(0.0, 1.0, count)
    degrees = [-20 + 40 * t, -100 + 20 * np.sin(np.pi * t), 50 + 10 * t, 40 + 120 * t, 30 * np.cos(np.pi * t), 90 + 40 * t]
    return np.deg2rad(np.stack(degrees, axis=1))


def _targets_csv(Q: np.ndarray) -> str:
    """The tool frame at each configuration as compensate reads it: cm (the spec's unit), Rot(z, rz) Rot(y, ry) Rot(x, rx) in deg."""
    T = t6(Q)
    R = T[:, :3, :3]
    rz, ry, rx = np.arctan2(R[:, 1, 0], R[:, 0, 0]), np.arcsin(-R[:, 2, 0]), np.arctan2(R[:, 2, 1], R[:, 2, 2])
    position = (T[:, :3, 3] + [0.0, 0.0, BASE_Z]) / 10
    rows = [",".join([f"p{i}", *(repr(float(v)) for v in (*position[i], *np.rad2deg([rx[i], ry[i], rz[i]])))]) for i in range(len(Q))]
    return "\n".join(["name,x,y,z,rx,ry,rz", *rows]) + "\n"


def test_commands_along_a_path_follow_it_without_a_flip(tmp_path):
    """Each joint's command moves between neighbouring targets by at most the trajectory's largest step of that joint
    (0.6 deg for joint 4) plus 1e-6 rad. On one branch the inverse kinematics is the forward kinematics' inverse, so
    the commands are the trajectory itself, up to the solver's tolerance (1e-6 mm, 1e-9 in the axis columns: below
    1e-6 rad even at joint 5's smallest 0.24 deg, where joints 4 and 6 are least determined); a flip of the wrist
    moves joints 4 and 6 by about 180 deg, a change of elbow or shoulder joints 1-3 by tens. The first target takes
    the branch nearest the middle of the limits, the trajectory's here; each next one starts from the one before."""
    Q = _trajectory(POSES)
    (tmp_path / "targets.csv").write_text(_targets_csv(Q))
    done = armcal_cli("compensate", SPECS / "puma560_dh.yaml", "--targets", tmp_path / "targets.csv", "--out", tmp_path / "commands.csv")
    assert done.returncode == 0, done.stderr
    with open(tmp_path / "commands.csv") as stream:
        rows = list(csv.DictReader(stream))
    assert [r["status"] for r in rows] == ["ok"] * POSES
    commands = np.deg2rad([[float(r[f"q{j}"]) for j in range(1, 7)] for r in rows])
    bound = np.abs(np.diff(Q, axis=0)).max(axis=0) + 1e-6
    assert np.all(np.abs(np.diff(commands, axis=0)) <= bound), np.rad2deg(np.abs(np.diff(commands, axis=0)).max(axis=0))
    np.testing.assert_allclose(commands, Q, atol=1e-6)
