"""Where the fit starts: the nominal values, with the instrument's placement registered from the data.

An instrument that can stand anywhere (a laser tracker) has a transform to the robot
base unknown by metres and tens of degrees, far outside what Levenberg-Marquardt
recovers from zero; when that transform is free, the instrument registers it from
the data (DeviceModel.registered: a tracker's rigid registration, Kabsch / SVD, of
the nominal model's target positions onto the measured ones); components the spec
holds (vary: false) keep their values. A spec whose transform already explains the
data better than the registration (a calibrated spec, which carries the fitted
transform) starts from its own values.
"""

from __future__ import annotations

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.identify.problem import Problem
from armcal.kinematics.compiler import KinematicModel


def starting_values(problem: Problem, kinematics: KinematicModel, device: DeviceModel, data: Measurements) -> np.ndarray:
    """Nominal parameters, with a free instrument placement registered from the data where that fits better."""
    theta = problem.parameters.nominal.copy()
    free = {e.name for e in problem.parameters.entries if e.free}
    registered = device.registered(theta, problem.parameters.names, free, kinematics, data)
    if registered is None:
        return theta
    cost = lambda t: float(np.sum(problem.evaluate(t)[0] ** 2))  # noqa: E731
    return registered if cost(registered) < cost(theta) else theta
