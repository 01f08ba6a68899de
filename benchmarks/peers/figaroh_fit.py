"""FIGAROH's geometric calibration of one bench_peers case, in FIGAROH's own interpreter (no armcal import).

Usage: python figaroh_fit.py CASE.npz OUT.json

FIGAROH works on a URDF (here armcal's export of the spec's nominal chain) through Pinocchio, in
metres. Its unified config asks for the "full_params" calibration level (six placement errors a
joint, reduced by its own structural QR selection to an identifiable set), an unknown base frame
(the tracker: its closed-form initial guess, then estimated) and an unknown tip frame (the target's
position on the flange), position-only markers. The subclass's cost function is the one its
BaseCalibration documents (updated forward kinematics, log-map residuals in the world frame,
its unit weighting); solve() runs its Levenberg-Marquardt with its outlier rounds.
"""

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin
from figaroh.calibration.base_calibration import BaseCalibration
from figaroh.calibration.calibration_tools import calc_updated_fkm

CONFIG = """\
meta: {{schema_version: "2.0"}}
robot:
  name: peer
tasks:
  calibration:
    type: kinematic_calibration
    kinematics: {{base_frame: universe, tool_frame: {tool}}}
    measurements:
      markers: [{{measurable_dof: [true, true, true, false, false, false]}}]
    parameters: {{calibration_level: full_params, include_non_geometric: false}}
    data: {{source_file: {data}, number_of_samples: {count}}}
"""


class PeerCalibration(BaseCalibration):
    def load_param(self, config_file, setting_type="calibration"):
        super().load_param(config_file, setting_type)
        self.calib_config["known_baseframe"] = False  # the tracker's pose in the robot's frame: unknown
        self.calib_config["known_tipframe"] = False  # the target's offset on the flange: unknown

    def cost_function(self, var):
        estimated = calc_updated_fkm(self.model, self.data, var, self.q_measured, self.calib_config)
        residuals = self._compute_logmap_residuals(self.PEE_measured, estimated, position_frame="world")
        return self.apply_measurement_weighting(residuals)


def _positions(calibration, robot, x, q):
    """Marker positions (N, 3) in mm of the fitted model ``x`` at joint angles ``q`` (N, n)."""
    padded = np.zeros((len(q), robot.model.nq))
    padded[:, : q.shape[1]] = q
    config = dict(calibration.calib_config, NbSample=len(padded))
    flat = calc_updated_fkm(calibration.model, calibration.data, x, padded, config)
    return 1000.0 * np.asarray(flat).reshape(3, -1).T  # component-major, as FIGAROH stores PEE


def main(case_path, out_path):
    case = np.load(case_path)
    folder = Path(tempfile.mkdtemp(prefix="figaroh_"))
    (folder / "robot.urdf").write_text(str(case["urdf"]))
    robot = pin.RobotWrapper.BuildFromURDF(str(folder / "robot.urdf"))
    joints = [robot.model.names[i] for i in range(1, robot.model.njoints)]
    tool = robot.model.frames[len(robot.model.frames) - 1].name
    flange = [f.name for f in robot.model.frames if f.parentJoint == robot.model.njoints - 1 and f.type == pin.FrameType.BODY]
    tool = flange[0] if flange else tool
    q_cal, y_cal = case["q_cal"], case["y_cal"] / 1000.0  # m
    lines = [",".join(["x1", "y1", "z1", *joints])]
    lines += [",".join(f"{v:.12g}" for v in (*y, *q)) for y, q in zip(y_cal, q_cal)]
    (folder / "data.csv").write_text("\n".join(lines) + "\n")
    (folder / "config.yaml").write_text(CONFIG.format(tool=tool, data=folder / "data.csv", count=len(q_cal)))
    calibration = PeerCalibration(robot, str(folder / "config.yaml"))
    calibration.initialize()
    started = time.perf_counter()
    result = calibration.solve(enable_logging=False)
    seconds = time.perf_counter() - started
    predicted, fitted = (_positions(calibration, robot, result.x, case[key]) for key in ("q_val", "q_cal"))
    note = f"solve(): {len(result.x)} identifiable of full_params + base + tip, status {calibration.STATUS}, frame {tool}"
    with open(out_path, "w") as f:
        json.dump({"predicted": predicted.tolist(), "fitted": fitted.tolist(), "fit_seconds": seconds, "parameters": int(len(result.x)), "note": note}, f)


if __name__ == "__main__":
    main(*sys.argv[1:3])
