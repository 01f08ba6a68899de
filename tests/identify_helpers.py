"""Synthetic campaigns whose truth is known exactly: the fitted model with its base parameters moved."""

import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices import device_model
from armcal.identify.identifiability import analyse
from armcal.identify.problem import build_problem
from armcal.kinematics.compiler import compile_robot
from armcal.model.measurement import predict
from armcal.kinematics.params import ParameterSet
from armcal.procedures import plan
from armcal.spec import load_spec

PERTURBATION = {"length": 0.5, "angle": 1e-3, "scale": 1e-4}  # mm, rad, 1


@dataclass
class Setup:
    spec: object
    kinematics: object
    device: object
    plans: list
    base: np.ndarray  # indices of the base parameters


def setup(spec_path: Path, text_changes=()) -> Setup:
    text = spec_path.read_text()
    for old, new in text_changes:
        assert old in text, old
        text = text.replace(old, new)
    with tempfile.TemporaryDirectory() as scratch:  # never beside the shipped spec: other tests and workers read that folder
        path = Path(scratch) / spec_path.name
        path.write_text(text)
        spec = load_spec(path).spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    plans = [plan(p, kinematics, device, spec, spec_path.parent) for p in (spec.procedure, spec.validation or spec.procedure)]
    probe = build_problem(kinematics, device, measure(kinematics, device, plans[0], None, None))
    _, J = probe.evaluate(probe.parameters.nominal)
    names = analyse(J, probe.parameters, probe.parameters.free).base
    base = np.array([probe.parameters.index(n) for n in names])
    return Setup(spec, kinematics, device, plans, base)


def restricted(problem, base: np.ndarray):
    """The problem with exactly the truth's base parameters free, so the fit and the truth share one gauge.

    Among near-equivalent columns the pivoted QR may pick another base set on
    noisy data than on noise-free data; the robot is then the same but its
    parameters are expressed differently, and comparing them one by one is moot.
    """
    free = np.zeros(len(problem.parameters), dtype=bool)
    free[base] = True
    entries = tuple(replace(e, free=bool(f)) for e, f in zip(problem.parameters.entries, free))
    return replace(problem, parameters=ParameterSet(entries))


def truth(s: Setup, rng) -> np.ndarray:
    parameters = build_problem(s.kinematics, s.device, measure(s.kinematics, s.device, s.plans[0], None, None)).parameters
    theta = parameters.nominal.copy()
    kinds = np.array([e.kind for e in parameters.entries])
    theta[s.base] += rng.normal(size=len(s.base)) * np.array([PERTURBATION[k] for k in kinds[s.base]])
    n_robot = len(s.kinematics.parameters)
    theta[n_robot:] = s.device.true_parameters(theta[n_robot:])  # e.g. a true scale bar has its calibrated length
    return theta


def measure(kinematics, device, planned, theta, rng) -> Measurements:
    """Readings of a plan predicted at theta (nominal if None), plus the device's noise if rng is given."""
    n_robot = len(kinematics.parameters)
    p = None if theta is None else theta[:n_robot]
    pd = None if theta is None else theta[n_robot:]
    keys = planned.keys
    readings: dict[str, np.ndarray] = {}
    for key in dict.fromkeys(keys):
        rows = np.flatnonzero([k == key for k in keys])
        if device.target(key) is None:
            values = device.evaluate(key, np.repeat(np.eye(4)[None], len(rows), 0), pd)
        else:
            values = predict(kinematics, device, key, planned.q[rows], p, pd)
        if rng is not None:
            values = values + rng.normal(size=values.shape) * device.sigma(key, values)
        for c, channel in enumerate(device.channels(key)):
            readings.setdefault(channel.name, np.full(len(keys), np.nan))[rows] = values[:, c]
    return Measurements(keys=keys, q=planned.q, readings=readings)
