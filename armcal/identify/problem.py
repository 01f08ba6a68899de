"""The least-squares problem: weighted residuals of all samples and their exact Jacobian.

theta = [robot parameters; device parameters]. Each sample contributes one
residual per reading, (predicted - measured) / sigma with sigma from the
device's noise model (angles wrapped to [-pi, pi]). One CasADi Function of
theta evaluates every sample: for each key a mapped call of a compiled function
(identify/compiled.py) that returns the readings and their exact Jacobian, from
automatic differentiation of the measurement function (never finite differences).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel, Key
from armcal.devices.theodolite import BAR_LENGTH, TheodoliteModel
from armcal.effects.model import EffectSet, extras_matrix
from armcal.identify.compiled import compiled
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterInfo, ParameterSet


@dataclass(frozen=True)
class Residual:
    """Where each residual comes from: sample index, reading, key."""

    sample: np.ndarray  # (M,) index into the measurements (-1 for spec pseudo-observations)
    channel: tuple[str, ...]  # (M,)
    kind: tuple[str, ...]  # (M,) length | angle
    key: tuple[Key, ...]  # (M,)
    sigma: np.ndarray  # (M,) in the reading's internal unit
    measured: np.ndarray  # (M,)


@dataclass(frozen=True)
class Problem:
    parameters: ParameterSet  # robot then device parameters
    n_robot: int
    function: ca.Function  # theta -> (r (M,), J (M, n_theta)): all samples in one call
    residuals: Residual

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (M,) and their Jacobian (M, len(theta))."""
        r, J = self._call(theta)
        return r.ravel(), J

    @cached_property
    def _call(self) -> "BufferedCall":
        return BufferedCall(self.function)


class BufferedCall:
    """Evaluates a one-input CasADi Function through its FunctionBuffer: numpy in, numpy out.

    Converting the outputs from CasADi matrices costs more than evaluating them;
    the buffer writes each output's nonzeros straight into numpy memory, which
    are then scattered into dense arrays (fresh ones on every call).
    """

    def __init__(self, function: ca.Function):
        self._input = np.zeros(function.nnz_in(0))
        self._nonzeros, self._shapes, self._positions = [], [], []
        self._buffer, self._run = function.buffer()
        self._buffer.set_arg(0, memoryview(self._input))
        for i in range(function.n_out()):
            sparsity = function.sparsity_out(i)
            shape = (sparsity.size1(), sparsity.size2())
            rows, columns = sparsity.get_triplet()
            self._nonzeros.append(np.zeros(sparsity.nnz()))
            self._shapes.append(shape)
            self._positions.append(np.ravel_multi_index((np.array(rows, dtype=int), np.array(columns, dtype=int)), shape))
            self._buffer.set_res(i, memoryview(self._nonzeros[i]))

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        self._input[:] = np.asarray(x, dtype=float).ravel()
        self._run()
        outputs = []
        for nonzeros, shape, positions in zip(self._nonzeros, self._shapes, self._positions):
            dense = np.zeros(shape)
            dense.flat[positions] = nonzeros
            outputs.append(dense)
        return tuple(outputs)


def combined_parameters(kinematics: KinematicModel, device: DeviceModel, effects: EffectSet = EffectSet()) -> ParameterSet:
    """theta's parameters: the robot's, the device's, the effects'."""
    return ParameterSet(kinematics.parameters.entries + device.parameters.entries + effects.parameters.entries)


def _value_and_jacobian(kinematics: KinematicModel, device: DeviceModel, effects: EffectSet, key: Key) -> ca.Function:
    """(q, x, p, pd, pe) -> (readings, d readings / d [p; pd; pe]) of one sample of a key."""
    h = effects.measurement_function(kinematics, device, key)
    q, x, p, pd, pe = (ca.SX.sym(n, h.size1_in(i)) for i, n in enumerate(("q", "x", "p", "pd", "pe")))
    y = h(q, x, p, pd, pe)
    return ca.Function("hj", [q, x, p, pd, pe], [y, ca.jacobian(y, ca.vertcat(p, pd, pe))])


def build_problem(
    kinematics: KinematicModel, device: DeviceModel, data: Measurements, effects: EffectSet = EffectSet()
) -> Problem:
    """Assemble residuals of all samples of ``data`` (already prepared by the device), with ``effects``."""
    parameters = combined_parameters(kinematics, device, effects)
    samples, channels, kinds, keys, sigmas, measured = [], [], [], [], [], []
    key_rows = data.groups()
    if isinstance(device, TheodoliteModel) and device.spec.scale_bar is not None:
        key_rows[BAR_LENGTH] = np.array([-1])
    canonical = sorted(key_rows, key=str)  # one library serves every data set with the same keys
    identity = f"{kinematics.identity}|{device.identity}|{effects.identity}|{[str(k) for k in canonical]}"
    functions = dict(zip(canonical, compiled([_value_and_jacobian(kinematics, device, effects, k) for k in canonical], identity)))
    n_robot, n_device = len(kinematics.parameters), len(device.parameters)
    theta = ca.MX.sym("theta", len(parameters))
    p, pd, pe = theta[:n_robot], theta[n_robot : n_robot + n_device], theta[n_robot + n_device :]
    extras = extras_matrix(data.extras, len(data), kinematics.dof)
    r_parts, J_parts = [], []
    for key, rows in key_rows.items():
        key_channels = device.channels(key)
        if key == BAR_LENGTH:  # the bar's calibrated length, a pseudo-observation from the spec
            y = np.array([[device.spec.scale_bar.length]])
            Q, X = np.zeros((1, kinematics.dof)), np.zeros((1, extras.shape[1]))
        else:
            y = np.stack([data.readings[c.name][rows] for c in key_channels], axis=1)
            Q, X = np.nan_to_num(data.q[rows]), extras[rows]
        sigma = device.sigma(key, y)
        count = len(rows)
        value, jacobian = functions[key].map(count)(ca.DM(Q.T), ca.DM(X.T), p, pd, pe)  # (m, N), (m, n_theta N)
        for c, channel in enumerate(key_channels):
            ok = np.flatnonzero(~np.isnan(y[:, c]))
            if not len(ok):
                continue
            difference = value[c, ok.tolist()].T - ca.DM(y[ok, c])
            if channel.kind == "angle":
                difference = ca.atan2(ca.sin(difference), ca.cos(difference))
            weight = ca.DM(1.0 / sigma[ok, c])
            J_rows = ca.reshape(jacobian[c, :], len(parameters), count).T[ok.tolist(), :]
            r_parts.append(difference * weight)
            J_parts.append(J_rows * ca.repmat(weight, 1, len(parameters)))
            samples.append(rows[ok])
            channels += [channel.name] * len(ok)
            kinds += [channel.kind] * len(ok)
            keys += [key] * len(ok)
            sigmas.append(sigma[ok, c])
            measured.append(y[ok, c])
    function = ca.Function("residuals", [theta], [ca.vertcat(*r_parts), ca.vertcat(*J_parts)], ["theta"], ["r", "J"])
    residual = Residual(
        sample=np.concatenate(samples),
        channel=tuple(channels),
        kind=tuple(kinds),
        key=tuple(keys),
        sigma=np.concatenate(sigmas),
        measured=np.concatenate(measured),
    )
    return Problem(parameters, n_robot, function, residual)


def with_values(parameters: ParameterSet, values: np.ndarray) -> ParameterSet:
    """The same parameters with new nominal values (e.g. identified ones)."""
    return ParameterSet(
        tuple(ParameterInfo(e.name, e.kind, float(v), e.free, e.lower, e.upper) for e, v in zip(parameters.entries, values))
    )
