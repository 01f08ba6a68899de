"""Held-out data taken after the instrument was moved: re-register it before every evaluation.

The robot's parameters under test stay as given; only the instrument-to-base
transform is set to the least-squares rigid registration (Kabsch) of the
predicted target positions onto the measured ones, so the held-out error still
judges the robot model alone. (A weighted fit of all readings would trade
positions for the far more precise orientations whenever the model is poor.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.identify.problem import Problem
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import POSE_FIELDS


@dataclass(frozen=True)
class MovedInstrument(Problem):
    kinematics: KinematicModel | None = None
    device: DeviceModel | None = None
    data: Measurements | None = None

    def evaluate(self, theta: np.ndarray, columns: np.ndarray | None = None, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        return Problem.evaluate(self, self.registered(theta), columns, out)

    def registered(self, theta: np.ndarray) -> np.ndarray:
        """theta with the instrument-to-base transform registered to these data (the instrument's registration,
        every component of it)."""
        every = {f"robot_base.{f}" for f in POSE_FIELDS}
        return self.device.registered(np.array(theta, dtype=float), self.parameters.names, every, self.kinematics, self.data)


def held_out(problem: Problem, kinematics: KinematicModel, device: DeviceModel, data: Measurements, instrument_moved: bool) -> Problem:
    """The validation problem, re-registering the instrument when it was moved."""
    if not instrument_moved:
        return problem
    return MovedInstrument(problem.parameters, problem.n_robot, problem.blocks, problem.residuals, problem.design,
                           kinematics=kinematics, device=device, data=data)
