"""A simulated measuring campaign: plan the poses, read the true robot with the true instrument.

Readings are the instrument's geometry applied to the true robot's target
poses and the instrument's true parameters, with its hidden effects, its
physics (the sonic digitizer's speed of sound, App. E) and, unless
``simulate.noise`` is false, its noise model (sigma = a * range + b (7.9),
quantised to the resolution and averaged over N_avg readings for the sonic
digitizer; a constant sigma for the others).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.support.errors import UserError
from armcal.spec_parts.instrument import AUTO
from armcal.devices import device_model
from armcal.devices.base import DeviceModel, held_in_contact
from armcal.kinematics.compiler import compile_robot
from armcal.procedures import Plan, plan
from armcal.effects.library import from_spec, needs
from armcal.effects.measurement import EffectSet
from armcal.simulate.truth import TrueRobot
from armcal.spec import sections as fx
from armcal.spec.document import Spec

@dataclass(frozen=True)
class Campaign:
    calibration: Measurements
    validation: Measurements | None
    truth: dict
    dropped: dict[str, dict[str, int]]  # per data set, planned poses dropped per reason ("c1-s1: joint limit (j2)")
    where: dict[str, dict[str, list[str]]] = field(default_factory=dict)  # per data set and reason, which points
    lost: dict[str, dict[str, int]] = field(default_factory=dict)  # per data set and key, readings the true robot put out of range


def simulate_campaign(spec: Spec, spec_dir: Path) -> Campaign:
    """Calibration and validation data of a spec's procedures, from one random true robot."""
    return CampaignSimulator(spec, spec_dir).run((spec.simulate or fx.Simulate()).seed)


class CampaignSimulator:
    """A spec's campaign, compiled and planned once, measured on as many random true robots as asked.

    Every robot comes from its own seed: the same seed gives the same robot and the
    same readings, whoever runs it (Monte-Carlo studies draw robot i from seed i).
    """

    def __init__(self, spec: Spec, spec_dir: Path, validation: bool = True, calibration: bool = True):
        self.spec = spec
        self.settings = spec.simulate or fx.Simulate()
        self.kinematics = compile_robot(spec.robot.chain())
        auto = [f for f in spec.device.noise_fields() if getattr(spec.device, f) == AUTO]
        if auto and self.settings.noise:
            raise UserError(
                f"{spec.device.type}: device.{auto[0]} is auto, but the simulator adds the declared noise: give it a sigma "
                "to simulate with (a run estimates it from the data with estimate_noise: true), or set simulate.noise: false"
            )
        self.device = device_model(spec)
        procedures = (("calibration", spec.procedure if calibration else None), ("validation", spec.validation if validation else None))
        self.plans = {name: self._plan(name, procedure, spec_dir) for name, procedure in procedures}

    def _plan(self, name: str, procedure, spec_dir: Path) -> Plan | None:
        if procedure is None:
            return None
        planned = plan(procedure, self.kinematics, self.device, self.spec, spec_dir)
        if not len(planned):
            reasons = "; ".join(f"{count} {why}" for why, count in planned.dropped.items()) or "no poses"
            raise UserError(f"the {name} procedure plans no pose the instrument can read ({reasons})")
        return planned

    def run(self, seed, plans: dict[str, Plan | None] | None = None, exact: tuple[str, ...] = ()) -> Campaign:
        """The campaign measured on the true robot of ``seed`` (an int or a numpy SeedSequence).

        ``plans`` (calibration, validation) replace the spec's procedures' (pose planning measures its own);
        the plans named in ``exact`` are read without noise (the truth, to score a prediction against).
        """
        sequence = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
        truth_rng, *noise_rngs = (np.random.default_rng(s) for s in sequence.spawn(3))
        robot = TrueRobot.draw(self.kinematics, self.settings, truth_rng)
        pd = _true_device_parameters(self.device, self.settings, robot.effects, truth_rng)
        sets, dropped, where, lost, start = [], {}, {}, {}, 0.0
        for (name, planned), rng in zip((plans or self.plans).items(), noise_rngs):
            if planned is None:
                sets.append(None)
                continue
            settings = self.settings.model_copy(update={"noise": False}) if name in exact else self.settings
            measurements, lost[name] = _measure(settings, robot, self.device, pd, planned, rng, start)
            start = float(measurements.extras["t"][-1]) + self.settings.time_step
            sets.append(measurements)
            dropped[name] = planned.dropped
            where[name] = planned.where
        truth = {**robot.describe(), "device_parameters": dict(zip(self.device.parameters.names, pd.tolist()))}
        return Campaign(sets[0], sets[1], truth, dropped, where, lost)


def _true_device_parameters(device: DeviceModel, settings: fx.Simulate, effects: EffectSet, rng: np.random.Generator) -> np.ndarray:
    """Free instrument parameters off their nominal by sigma_p / sigma_o; pivot offsets added; scale bars true to length."""
    pd = device.parameters.nominal.copy()
    for i, entry in enumerate(device.parameters.entries):
        if entry.free and entry.kind != "scale":
            pd[i] += rng.normal() * (settings.sigma_p if entry.kind == "length" else settings.sigma_o)
    pd = np.array(effects.device_parameter_function(device.parameters)(pd, effects.values())).ravel()
    return device.true_parameters(pd)


def _extras(settings: fx.Simulate, count: int, start: float, rng: np.random.Generator, n: int) -> dict:
    extras = {"t": start + settings.time_step * np.arange(count)}
    needed = needs([from_spec(e) for e in settings.effects])
    if settings.temperature is not None or "temperature" in needed:
        low, high = settings.temperature or (20.0, 25.0)
        extras["temperature"] = np.linspace(low, high, count)
    if "dir" in needed:
        extras["dir"] = rng.choice([-1.0, 1.0], size=(count, n))
    return extras


def _measure(settings, robot: TrueRobot, device: DeviceModel, pd, planned: Plan, rng, start: float) -> tuple[Measurements, dict[str, int]]:
    """The readings of the planned samples on the true robot, and per key how many it could not read (out of the
    instrument's range on the true robot, though the nominal model planned them within it)."""
    count = len(planned)
    extras = _extras(settings, count, start, rng, robot.kinematics.dof)
    channels = {} if device.contact else {c.name: c for key in dict.fromkeys(planned.keys) for c in device.channels(key)}
    readings = {name: np.full(count, np.nan) for name in channels}
    keep = np.ones(count, dtype=bool)
    keys = np.empty(count, dtype=object)
    keys[:] = planned.keys
    lost: dict[str, int] = {}
    q = planned.q.copy()
    for key in dict.fromkeys(planned.keys):
        rows = np.flatnonzero([k == key for k in planned.keys])
        target = device.target(key)
        group_extras = {name: value[rows] for name, value in extras.items()}
        true_readings = _true_readings(robot, device, key, pd, group_extras)
        poses, values = true_readings(planned.q[rows])
        keep[rows] = device.visible(key, poses, pd)
        if device.contact and target is not None:
            sigma = device.sigma(key, np.zeros_like(values)) * settings.noise_factor
            offset = rng.normal(size=values.shape) * sigma if settings.noise else np.zeros_like(values)
            q[rows], held = held_in_contact(lambda Q: true_readings(Q)[1], planned.q[rows], offset, robot.kinematics.limits)
            keep[rows] &= held
        else:
            values, readable, recorded = device.simulated_readings(key, values, poses, pd, settings, rng)
            keep[rows] &= readable  # e.g. the noise carried a reading at the edge out of range
            for name, column in recorded.items():
                readings.setdefault(name, np.full(count, np.nan))[rows] = column
            for c, channel in enumerate(device.channels(key)):
                readings[channel.name][rows] = values[:, c]
        if not keep[rows].all():
            lost["-".join(str(k) for k in key if k)] = int((~keep[rows]).sum())
        if target is None:
            q[rows] = np.nan  # not a robot pose: no joint readings
    measured = Measurements(
        keys=tuple(keys[keep]),
        q=q[keep],
        readings={name: column[keep] for name, column in readings.items() if not name.startswith("rod_")},
        extras={**{name: value[keep] for name, value in extras.items()}, **{n: c[keep] for n, c in readings.items() if n.startswith("rod_")}},
    )
    return measured, lost


def _true_readings(robot: TrueRobot, device: DeviceModel, key, pd: np.ndarray, extras: dict):
    """Q (N, n) -> the target's true poses and the true instrument's noise-free readings of ``key`` (its effects included)."""
    target, effects = device.target(key), robot.effects

    def read(Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        poses = robot.target_poses(target, Q, extras) if target else np.repeat(np.eye(4)[None], len(Q), 0)
        values = device.evaluate(key, poses, pd)
        return poses, np.array(effects.reading_function(device.channels(key)).map(len(Q))(values.T, effects.values())).T

    return read
