"""pybotics' calibration of one bench_peers case, in pybotics' own interpreter (no armcal import).

Usage: python pybotics_fit.py CASE.npz OUT.json

The spec's standard DH chain is rewritten in pybotics' Modified DH (Craig): link 1 (alpha 0, a 0,
theta_1, d_1), link i (alpha_(i-1), a_(i-1), theta_i, d_i); the last DH link's Tx(a_n) Rx(alpha_n)
and the target offset on the flange become pybotics' tool; the registered tracker-to-robot start
becomes its world frame. As in pybotics' calibration example: an OptimizationHandler with masks
(every kinematic-chain parameter, the world frame's six, the tool's position), optimize_accuracy
(one residual a pose: the distance between predicted and measured position) minimised by
scipy.optimize.least_squares with its defaults.
"""

import json
import sys
import time

import numpy as np
import scipy.optimize
from pybotics.kinematic_chain import MDHKinematicChain
from pybotics.optimization import OptimizationHandler, optimize_accuracy
from pybotics.robot import Robot
from pybotics.tool import Tool


def rot_x(alpha):
    c, s = np.cos(alpha), np.sin(alpha)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def trans_x(a):
    T = np.eye(4)
    T[0, 3] = a
    return T


def main(case_path, out_path):
    case = np.load(case_path)
    dh = case["dh"]  # (n, 4): theta, d, a, alpha (mm, rad)
    mdh = []
    for i, (theta, d, _, _) in enumerate(dh):
        alpha_prev, a_prev = (0.0, 0.0) if i == 0 else (dh[i - 1, 3], dh[i - 1, 2])
        mdh.append([alpha_prev, a_prev, theta, d])
    tool = Tool(matrix=trans_x(dh[-1, 2]) @ rot_x(dh[-1, 3]) @ case["target"])
    robot = Robot(MDHKinematicChain.from_parameters(np.array(mdh)), tool=tool, world_frame=case["world"].copy())
    handler = OptimizationHandler(
        robot=robot, kinematic_chain_mask=True, tool_mask=[True, True, True, False, False, False], world_mask=True
    )
    x0 = handler.generate_optimization_vector()
    started = time.perf_counter()
    result = scipy.optimize.least_squares(fun=optimize_accuracy, x0=x0, args=(handler, case["q_cal"], case["y_cal"]))
    seconds = time.perf_counter() - started
    handler.apply_optimization_vector(result.x)
    predicted = [handler.robot.fk(q)[:3, 3].tolist() for q in case["q_val"]]
    fitted = [handler.robot.fk(q)[:3, 3].tolist() for q in case["q_cal"]]
    note = f"least_squares trf, 2-point FD Jacobian: {result.njev} Jacobians, status {result.status}; MDH chain 4x{len(dh)} + world 6 + tool xyz"
    with open(out_path, "w") as f:
        json.dump({"predicted": predicted, "fitted": fitted, "fit_seconds": seconds, "parameters": int(len(x0)), "note": note}, f)


if __name__ == "__main__":
    main(*sys.argv[1:3])
