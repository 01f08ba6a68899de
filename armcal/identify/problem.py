"""The least-squares problem: weighted residuals of all samples and their exact Jacobian.

theta = [robot parameters; device parameters]. Each sample contributes one
residual per reading, (predicted - measured) / sigma with sigma from the
device's noise model (angles wrapped to [-pi, pi]). Each key's samples are
evaluated by mapped calls (CHUNK samples each) of a compiled function
(support/compiled.py) that returns the readings and their exact Jacobian, from
automatic differentiation of the measurement function (never finite differences);
the data are inputs of those calls, not constants of a graph, and the weighting is
done in numpy, written straight into the residual vector and the Jacobian (of the
columns asked for: a fit asks for its base set's), which is the only M x p array made.
Parameter values and sigmas never enter the function either, so its compiled library
(keyed on the generated code) serves every edit of noise, nominal values or limits.
"""

from __future__ import annotations

import copy
import os
import threading
from dataclasses import dataclass, replace
from weakref import WeakKeyDictionary

import casadi as ca
import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel, Key, held_in_contact
from armcal.effects.measurement import EffectSet, extras_matrix
from armcal.support.compiled import compiled, current
from armcal.identify.threads import each
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet
from armcal.model.measurement import measurement_function


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
    design: "Problem | None" = None  # a contact instrument's: the same readings where the nominal model holds its contacts

    def design_jacobian(self, theta: np.ndarray) -> np.ndarray:
        """The Jacobian that decides the base set at the design point ``theta`` (identifiability.py): at the data's
        poses; for a contact instrument at those poses moved into the contacts the nominal model holds (``design``).
        At the recorded poses it holds none: a contact's residual is a vector, and a motion of the robot and every
        socket together (a rigid motion, a scale) turns or stretches it instead of leaving it unchanged, so a
        Jacobian there would count such a motion as information of the size of the nominal model's error."""
        return (self.design or self).evaluate(theta)[1]

    def registration_noise(self, theta: np.ndarray) -> np.ndarray:
        """G (M, k) with G G' the covariance that frames fitted to held-out data themselves add to the weighted
        residuals (identify/heldout.py); none here."""
        return np.zeros((len(self.residuals.sigma), 0))

    def evaluate(self, theta: np.ndarray, columns: np.ndarray | None = None, out: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Weighted residuals (M,) and their Jacobian (M, len(columns)), columns of theta (default: all).

        The Jacobian is written straight into ``out`` (an (M, len(columns)) array filled by an earlier call with
        the same columns, so its structural zeros are in place) or a fresh column-major array."""
        theta = np.asarray(theta, dtype=float).ravel()
        columns = np.arange(len(theta)) if columns is None else np.asarray(columns, dtype=int)
        position = np.full(len(theta), -1)
        position[columns] = np.arange(len(columns))
        r = np.empty(len(self.residuals.sigma))
        J = np.zeros((len(r), len(columns)), order="F") if out is None else out
        start = 0
        for block in self.blocks:
            block.weighted(theta, position, r, J, start)
            start += block.size
        return r, J


@dataclass(frozen=True)
class ChannelRows:
    """The readings of one channel of a key that take part: rows, measured values, weights 1 / sigma."""

    channel: int
    rows: np.ndarray
    measured: np.ndarray
    weight: np.ndarray
    angle: bool


CHUNK = 256  # samples per mapped call: its buffers stay cache-sized and small whatever the size of the data
_CALLS: WeakKeyDictionary = WeakKeyDictionary()  # function -> {(thread, samples in a call): (buffer, run, thetas, values, jacobian)}
os.register_at_fork(after_in_child=_CALLS.clear)  # a forked child's threads are new: none owns a buffer


class KeyBlock:
    """All samples of one key: mapped calls of the key's compiled function over chunks of CHUNK samples, each
    weighted in numpy straight into the problem's residual vector and Jacobian, the chunks shared out to threads (threads.py).

    The joint readings and extras are the calls' fixed inputs; theta is the only one
    that changes, repeated for every sample of a call (a map widens each input; an MX
    wrapper repeating it would hold copies of the outputs too). Predicted minus measured,
    wrapped for angles, over sigma. A call's outputs land in numpy memory through
    CasADi's function buffer (converting CasADi matrices costs more than evaluating
    them); the Jacobian's nonzeros of sample k are the k-th run of the per-sample
    pattern (the mapped output is the samples' Jacobians side by side), so no dense
    copy of the mapped output is ever made. The mapped calls and their buffers belong to the
    function (_CALLS), shared by every block of it (the diagnosis's folds, a study's robots: one
    map, not one per problem), one set per thread: the chunks' threads, and callers' threads
    evaluating blocks of one function at once (a Dask worker's tasks), never share a buffer. The
    chunks write disjoint rows, so the numbers are the same as one thread's, bit for bit.
    """

    def __init__(self, function: ca.Function, Q: np.ndarray, X: np.ndarray, channels: list[ChannelRows]):
        self._function = function
        self._q = np.ascontiguousarray(Q, dtype=float)  # row k: column k of a mapped call's Q input (column-major)
        self._x = np.ascontiguousarray(X, dtype=float)
        self._evaluated = function  # what this evaluation calls: the function or its compiled twin (compiled.current)
        self._calls = _CALLS.setdefault(function, {})  # its mapped calls, shared by the blocks of the function (_mapped)
        values, jacobian = function.sparsity_out(0), function.sparsity_out(1)
        self._value_rows = np.array(values.get_triplet()[0], dtype=int)
        self._n_out = values.size1()
        rows, columns = jacobian.get_triplet()  # one sample's nonzeros, in CasADi's (column-major) order
        self._jacobian_rows, self._jacobian_columns = np.array(rows, dtype=int), np.array(columns, dtype=int)
        self.channels = channels

    @property
    def size(self) -> int:
        """Residuals of the block."""
        return sum(len(c.rows) for c in self.channels)

    def _mapped(self, count: int, theta: np.ndarray) -> tuple:
        """This thread's call of the function over ``count`` samples at ``theta``: its buffer, run, values and
        Jacobians (made once per function, thread and length: _CALLS)."""
        calls, key = self._calls, (threading.get_ident(), count)  # a thread's own: any callers' threads at once
        if key not in calls:
            mapped = self._evaluated.map(count)
            buffer, run = mapped.buffer()
            thetas = np.zeros((count, self._function.size1_in(2)))  # row k: theta of the call's sample k
            values, jacobian = np.zeros(mapped.nnz_out(0)), np.zeros(mapped.nnz_out(1))
            buffer.set_arg(2, memoryview(thetas.reshape(-1)))
            buffer.set_res(0, memoryview(values))
            buffer.set_res(1, memoryview(jacobian))
            calls[key] = (buffer, run, thetas, values, jacobian)
        buffer, run, thetas, values, jacobian = calls[key]
        thetas[:] = theta
        return buffer, run, values, jacobian

    def weighted(self, theta: np.ndarray, position: np.ndarray, r: np.ndarray, J: np.ndarray, start: int) -> None:
        """Write the block's weighted residuals into r[start:start + size] and their Jacobian into the same rows of J;
        ``position[j]`` is theta's j-th parameter's column of J (-1: not wanted)."""
        evaluated = current(self._function, len(self._q))  # its library once built in the background, the same for the whole call
        if evaluated is not self._evaluated:
            self._evaluated, self._calls = evaluated, _CALLS.setdefault(evaluated, {})
        taken = position[self._jacobian_columns] >= 0
        wanted = []  # per channel: its nonzeros of one sample that J wants, and their columns
        for c in self.channels:
            nonzeros = np.flatnonzero(taken & (self._jacobian_rows == c.channel))
            wanted.append((nonzeros, position[self._jacobian_columns[nonzeros]]))
        complete = all(len(c.rows) == len(self._q) for c in self.channels)
        chunk = self._complete_chunk if complete else self._chunk
        if complete:  # every channel reads every sample: the block's residuals are a (channels, samples) array
            wanted = (wanted, self._complete(r[start : start + self.size]))
        each(lambda first: chunk(first, theta, wanted, r, J, start), range(0, len(self._q), CHUNK))  # rows of its own each

    def _complete(self, r: np.ndarray) -> tuple:
        """What a chunk of a block whose channels read every sample needs: its residuals as (channels, samples), the
        measured values and weights as (samples, channels), the channels and their angle flags."""
        measured = np.stack([c.measured for c in self.channels], axis=1)
        weight = np.stack([c.weight for c in self.channels], axis=1)
        angles = np.array([c.angle for c in self.channels])
        return r.reshape(len(self.channels), len(self._q)), [c.channel for c in self.channels], measured, weight, angles

    def _called(self, first: int, theta: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
        """One mapped call over the samples first .. first + CHUNK at ``theta``: its last sample, readings and Jacobians."""
        last = min(first + CHUNK, len(self._q))
        buffer, run, values, jacobian = self._mapped(last - first, theta)
        buffer.set_arg(0, memoryview(self._q[first:last].reshape(-1)))
        buffer.set_arg(1, memoryview(self._x[first:last].reshape(-1)))
        run()
        predicted = np.zeros((last - first, self._n_out))
        predicted[:, self._value_rows] = values.reshape(last - first, -1)
        return last, predicted, jacobian.reshape(last - first, -1)

    def _complete_chunk(self, first: int, theta: np.ndarray, wanted: tuple, r: np.ndarray, J: np.ndarray, start: int) -> None:
        """A chunk of a block whose channels read every sample: the residuals of all channels at once (the same
        numbers as _chunk's, in a few calls, so a thread holds Python's lock briefly)."""
        (per_channel, (residuals, channels, measured, weight, angles)), n = wanted, len(self._q)
        last, predicted, per_sample = self._called(first, theta)
        difference = predicted[:, channels] - measured[first:last]
        if angles.any():
            wrapped = difference[:, angles]
            difference[:, angles] = np.arctan2(np.sin(wrapped), np.cos(wrapped))
        w = weight[first:last]
        residuals[:, first:last] = (difference * w).T
        for k, (nonzeros, target) in enumerate(per_channel):
            if len(nonzeros):
                J[start + k * n + first : start + k * n + last, target] = per_sample[:, nonzeros] * w[:, k, None]

    def _chunk(self, first: int, theta: np.ndarray, wanted: list, r: np.ndarray, J: np.ndarray, start: int) -> None:
        """The samples first .. first + CHUNK: one mapped call, weighted into their rows of r and J."""
        last, predicted, per_sample = self._called(first, theta)
        row = start
        for c, (nonzeros, target) in zip(self.channels, wanted):
            low, high = np.searchsorted(c.rows, (first, last))
            here = slice(row + low, row + high)
            local = c.rows[low:high] - first
            every = high - low == last - first  # all samples of the chunk take part: slices, no copies
            difference = (predicted[:, c.channel] if every else predicted[local, c.channel]) - c.measured[low:high]
            if c.angle:
                difference = np.arctan2(np.sin(difference), np.cos(difference))
            weight = c.weight[low:high]
            r[here] = difference * weight
            if len(nonzeros):
                block = per_sample[:, nonzeros] if every else per_sample[local][:, nonzeros]
                J[here, target] = block * weight[:, None]
            row += len(c.rows)

    def with_weights(self, weights: list[np.ndarray]) -> "KeyBlock":
        """The same block (the same compiled calls) with new weights 1 / sigma, one array per channel."""
        block = copy.copy(self)
        block.channels = [replace(c, weight=np.asarray(w, dtype=float)) for c, w in zip(self.channels, weights)]
        return block


def combined_parameters(kinematics: KinematicModel, device: DeviceModel, effects: EffectSet = EffectSet()) -> ParameterSet:
    """theta's parameters: the robot's, the device's (role "device"), the effects'."""
    instrument = tuple(replace(e, role="device") for e in device.parameters.entries)
    return ParameterSet(kinematics.parameters.entries + instrument + effects.parameters.entries)


def _value_and_jacobian(kinematics: KinematicModel, device: DeviceModel, effects: EffectSet, key: Key) -> ca.Function:
    """(q, x, theta) -> (readings, d readings / d theta) of one sample of a key, theta = [p; pd; pe]."""
    h = measurement_function(kinematics, device, key, effects)
    sizes = [h.size1_in(i) for i in range(5)]
    q, x, theta = ca.SX.sym("q", sizes[0]), ca.SX.sym("x", sizes[1]), ca.SX.sym("theta", sum(sizes[2:]))
    y = h(q, x, *ca.vertsplit(theta, np.cumsum([0] + sizes[2:]).tolist()))
    return ca.Function("hj", [q, x, theta], [y, ca.jacobian(y, theta)])


def build_problem(
    kinematics: KinematicModel,
    device: DeviceModel,
    data: Measurements,
    effects: EffectSet = EffectSet(),
    in_contact: bool = False,
    functions: dict[Key, ca.Function] | None = None,
) -> Problem:
    """Assemble residuals of all samples of ``data`` (already prepared by the device), with ``effects``; for a contact
    instrument with its ``design``, the problem at the poses moved into the nominal model's contacts (unless
    ``in_contact``: the data's poses hold them already).

    ``functions``: the keys' compiled functions of this model (robot, instrument, effects) from earlier problems,
    filled here with the keys it lacks. A caller that builds many problems of one model (the diagnosis's folds) passes
    one dict: the functions are derived and compiled once, and every fold evaluates the same machine code."""
    parameters = combined_parameters(kinematics, device, effects)
    samples, channels, kinds, keys, sigmas, measured = [], [], [], [], [], []
    key_rows = data.groups()
    given = device.pseudo_observations()  # readings the spec gives, at no sample
    key_rows.update({key: np.array([-1]) for key in given})
    functions = {} if functions is None else functions
    missing = sorted((k for k in key_rows if k not in functions), key=str)  # one library serves every data set with the same keys
    functions.update(zip(missing, compiled([_value_and_jacobian(kinematics, device, effects, k) for k in missing])))
    extras = extras_matrix(data.extras, len(data), kinematics.dof)
    design = None
    if device.contact and not in_contact:
        nominal = parameters.nominal
        moved = data.q.copy()
        for key, rows in data.groups().items():
            if device.target(key) is not None:
                contact = np.stack([data.readings[c.name][rows] for c in device.channels(key)], axis=1)
                moved[rows] = _held_by_nominal(functions[key], data.q[rows], extras[rows], contact, nominal, kinematics.limits)
        design = build_problem(kinematics, device, replace(data, q=moved), effects, in_contact=True, functions=functions)
    blocks = []
    for key, rows in key_rows.items():
        key_channels = device.channels(key)
        if key in given:
            y = np.array([given[key]], dtype=float)
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
            blocks.append(KeyBlock(functions[key], Q, X, taking))
    residual = Residual(
        sample=np.concatenate(samples),
        channel=tuple(channels),
        kind=tuple(kinds),
        key=tuple(keys),
        sigma=np.concatenate(sigmas),
        measured=np.concatenate(measured),
    )
    return Problem(parameters, len(kinematics.parameters), tuple(blocks), residual, design)


def rows_within(part: Problem, samples: np.ndarray, whole: Problem) -> np.ndarray:
    """The rows of ``whole``'s residuals that are ``part``'s, in ``part``'s order, where ``part``'s data are the samples
    ``samples`` of ``whole``'s (a fold's): the same reading (key, channel) of the same sample."""
    pairs: dict[tuple, int] = {}
    span = int(whole.residuals.sample.max()) + 2  # sample + 1 of any reading is below it
    sample = part.residuals.sample
    wanted = _readings(part, pairs) * span + np.where(sample >= 0, samples[np.maximum(sample, 0)], -1) + 1
    found = _readings(whole, pairs) * span + whole.residuals.sample + 1
    order = np.argsort(found, kind="stable")
    return order[np.searchsorted(found[order], wanted)]


def _readings(problem: Problem, pairs: dict[tuple, int]) -> np.ndarray:
    """Each residual's reading (key, channel) as its number in ``pairs`` (numbered here when new): one per channel
    of a block, whose residuals are consecutive."""
    numbers, lengths, row = [], [], 0
    for block in problem.blocks:
        for c in block.channels:
            numbers.append(pairs.setdefault((problem.residuals.key[row], problem.residuals.channel[row]), len(pairs)))
            lengths.append(len(c.rows))
            row += len(c.rows)
    return np.repeat(np.array(numbers, dtype=np.int64), lengths)


def _held_by_nominal(function: ca.Function, Q: np.ndarray, X: np.ndarray, measured: np.ndarray, theta: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Joint values (N, n) nearest ``Q`` at which the model at ``theta`` reads a key's ``measured`` contact readings
    (``function``: the key's readings and Jacobian); a pose it cannot hold within the limits keeps its recorded values."""
    def read(Q: np.ndarray) -> np.ndarray:
        return np.array(current(function, len(Q)).map(len(Q))(Q.T, X.T, theta)[0]).T

    moved, held = held_in_contact(read, Q, measured, limits)
    return np.where(held[:, None], moved, Q)


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
    design = None if problem.design is None else reweighted(problem.design, sigma)
    return replace(problem, blocks=tuple(blocks), residuals=replace(problem.residuals, sigma=sigma), design=design)


def with_values(parameters: ParameterSet, values: np.ndarray) -> ParameterSet:
    """The same parameters with new nominal values (e.g. identified ones)."""
    return ParameterSet(
        tuple(replace(e, nominal=float(v)) for e, v in zip(parameters.entries, values))
    )
