"""The least-squares problem: weighted residuals of all samples and their exact Jacobian.

theta = [robot parameters; device parameters]. Each sample contributes one
residual per reading, (predicted - measured) / sigma with sigma from the
device's noise model (angles wrapped to [-pi, pi]). Each key's samples are
evaluated by one mapped call of a compiled function (identify/compiled.py) that
returns the readings and their exact Jacobian, from automatic differentiation of
the measurement function (never finite differences); the data are inputs of that
call, not constants of a graph, and the weighting is done in numpy on its outputs.
Parameter values and sigmas never enter the function either, so its compiled library
(keyed on the generated code) serves every edit of noise, nominal values or limits.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel, Key
from armcal.devices.theodolite import BAR_LENGTH, TheodoliteModel
from armcal.effects.model import EffectSet, extras_matrix
from armcal.identify.compiled import compiled
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet


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
    parameters: ParameterSet  # robot, device, then effect parameters
    n_robot: int
    blocks: tuple["KeyBlock", ...]  # the samples of each key, in the order of the residuals
    residuals: Residual

    def evaluate(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (M,) and their Jacobian (M, len(theta))."""
        theta = np.asarray(theta, dtype=float).ravel()
        parts = [block.weighted(theta) for block in self.blocks]
        return np.concatenate([r for r, _ in parts]), np.concatenate([J for _, J in parts])


@dataclass(frozen=True)
class ChannelRows:
    """The readings of one channel of a key that take part: rows, measured values, weights 1 / sigma."""

    channel: int
    rows: np.ndarray
    measured: np.ndarray
    weight: np.ndarray
    angle: bool


class KeyBlock:
    """All samples of one key: one mapped call of the key's compiled function, then weighting in numpy.

    The joint readings and extras are the mapped call's fixed inputs; theta is the
    only one that changes. Predicted minus measured, wrapped for angles, over sigma;
    the Jacobian rows of sample k are columns k n..(k+1) n of the mapped output.
    """

    def __init__(self, function: ca.Function, Q: np.ndarray, X: np.ndarray, sizes: tuple[int, int, int], channels: list[ChannelRows]):
        n_robot, n_device, _ = sizes
        count = len(Q)
        q, x, theta = ca.MX.sym("Q", *Q.T.shape), ca.MX.sym("X", *X.T.shape), ca.MX.sym("theta", sum(sizes))
        p, pd, pe = theta[:n_robot], theta[n_robot : n_robot + n_device], theta[n_robot + n_device :]
        mapped = ca.Function("block", [q, x, theta], list(function.map(count)(q, x, p, pd, pe)))
        self._call = BufferedCall(mapped, {0: Q.T, 1: X.T})
        self._count, self._n = count, sum(sizes)
        self.channels = channels

    def weighted(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        values, jacobian = self._call(theta)
        r_parts, J_parts = [], []
        for c in self.channels:
            difference = values[c.channel, c.rows] - c.measured
            if c.angle:
                difference = np.arctan2(np.sin(difference), np.cos(difference))
            r_parts.append(difference * c.weight)
            J_parts.append(jacobian[c.channel].reshape(self._count, self._n)[c.rows] * c.weight[:, None])
        return np.concatenate(r_parts), np.concatenate(J_parts)

    def with_weights(self, weights: list[np.ndarray]) -> "KeyBlock":
        """The same block (the same compiled call) with new weights 1 / sigma, one array per channel."""
        block = copy.copy(self)
        block.channels = [replace(c, weight=np.asarray(w, dtype=float)) for c, w in zip(self.channels, weights)]
        return block


class BufferedCall:
    """Evaluates a CasADi Function through its FunctionBuffer: numpy in, numpy out.

    Converting the outputs from CasADi matrices costs more than evaluating them;
    the buffer writes each output's nonzeros straight into numpy memory, which
    are then scattered into dense arrays (fresh ones on every call). ``fixed``
    inputs are set once; the call gives the remaining input (the last).
    """

    def __init__(self, function: ca.Function, fixed: dict[int, np.ndarray] | None = None):
        self._buffer, self._run = function.buffer()
        self._inputs = {i: np.ascontiguousarray(np.asarray(v, dtype=float).T).ravel() for i, v in (fixed or {}).items()}  # column-major
        self._free = function.n_in() - 1
        self._inputs[self._free] = np.zeros(function.nnz_in(self._free))
        for i, array in self._inputs.items():
            self._buffer.set_arg(i, memoryview(array))
        self._nonzeros, self._shapes, self._positions = [], [], []
        for i in range(function.n_out()):
            sparsity = function.sparsity_out(i)
            shape = (sparsity.size1(), sparsity.size2())
            rows, columns = sparsity.get_triplet()
            self._nonzeros.append(np.zeros(sparsity.nnz()))
            self._shapes.append(shape)
            self._positions.append(np.ravel_multi_index((np.array(rows, dtype=int), np.array(columns, dtype=int)), shape))
            self._buffer.set_res(i, memoryview(self._nonzeros[i]))

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        self._inputs[self._free][:] = np.asarray(x, dtype=float).ravel()
        self._run()
        outputs = []
        for nonzeros, shape, positions in zip(self._nonzeros, self._shapes, self._positions):
            dense = np.zeros(shape)
            dense.flat[positions] = nonzeros
            outputs.append(dense)
        return tuple(outputs)


def combined_parameters(kinematics: KinematicModel, device: DeviceModel, effects: EffectSet = EffectSet()) -> ParameterSet:
    """theta's parameters: the robot's, the device's (role "device"), the effects'."""
    instrument = tuple(replace(e, role="device") for e in device.parameters.entries)
    return ParameterSet(kinematics.parameters.entries + instrument + effects.parameters.entries)


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
    functions = dict(zip(canonical, compiled([_value_and_jacobian(kinematics, device, effects, k) for k in canonical])))
    sizes = (len(kinematics.parameters), len(device.parameters), len(effects.parameters))
    extras = extras_matrix(data.extras, len(data), kinematics.dof)
    blocks = []
    for key, rows in key_rows.items():
        key_channels = device.channels(key)
        if key == BAR_LENGTH:  # the bar's calibrated length, a pseudo-observation from the spec
            y = np.array([[device.spec.scale_bar.length]])
            Q, X = np.zeros((1, kinematics.dof)), np.zeros((1, extras.shape[1]))
        else:
            y = np.stack([data.readings[c.name][rows] for c in key_channels], axis=1)
            Q, X = np.nan_to_num(data.q[rows]), extras[rows]
        sigma = device.sigma(key, y)
        taking = []
        for c, channel in enumerate(key_channels):
            ok = np.flatnonzero(~np.isnan(y[:, c]))
            if not len(ok):
                continue
            taking.append(ChannelRows(c, ok, y[ok, c], 1.0 / sigma[ok, c], channel.kind == "angle"))
            samples.append(rows[ok])
            channels += [channel.name] * len(ok)
            kinds += [channel.kind] * len(ok)
            keys += [key] * len(ok)
            sigmas.append(sigma[ok, c])
            measured.append(y[ok, c])
        if taking:
            blocks.append(KeyBlock(functions[key], Q, X, sizes, taking))
    residual = Residual(
        sample=np.concatenate(samples),
        channel=tuple(channels),
        kind=tuple(kinds),
        key=tuple(keys),
        sigma=np.concatenate(sigmas),
        measured=np.concatenate(measured),
    )
    return Problem(parameters, sizes[0], tuple(blocks), residual)


def reweighted(problem: Problem, sigma: np.ndarray) -> Problem:
    """The same problem with new sigmas (M,) in the order of its residuals (e.g. noise estimated from the data).

    Nothing is rebuilt: each block keeps its compiled call and takes the new weights 1 / sigma.
    """
    sigma = np.asarray(sigma, dtype=float)
    if sigma.shape != problem.residuals.sigma.shape:
        raise ValueError(f"{len(problem.residuals.sigma)} sigmas needed, got {sigma.shape}")
    blocks, start = [], 0
    for block in problem.blocks:
        weights = []
        for c in block.channels:
            weights.append(1.0 / sigma[start : start + len(c.rows)])
            start += len(c.rows)
        blocks.append(block.with_weights(weights))
    return replace(problem, blocks=tuple(blocks), residuals=replace(problem.residuals, sigma=sigma))


def with_values(parameters: ParameterSet, values: np.ndarray) -> ParameterSet:
    """The same parameters with new nominal values (e.g. identified ones)."""
    return ParameterSet(
        tuple(replace(e, nominal=float(v)) for e, v in zip(parameters.entries, values))
    )
