"""The identification stage of a run: fit (with the declared effects), then diagnose what is missing."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.diagnose.loop import Diagnosis, run_diagnosis
from armcal.effects.library import from_spec
from armcal.errors import UserError
from armcal.effects.model import EffectSet
from armcal.identify.methods import Identified, identify_parameters
from armcal.identify.problem import Problem, build_problem
from armcal.identify.heldout import held_out
from armcal.identify.start import starting_values
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.model import Spec


@dataclass(frozen=True)
class Calibration:
    problem: Problem
    validation: Problem | None
    identified: Identified
    diagnosis: Diagnosis | None  # None when the spec turns it off or uses Stone's feature method
    start: np.ndarray  # the nominal model, with a free instrument-to-base transform registered: "before"


def calibration_problem(spec: Spec, kinematics: KinematicModel, device: DeviceModel, calibration: Measurements) -> tuple[Problem, np.ndarray]:
    """The calibration data's problem with the spec's declared effects, and where the fit starts."""
    effects = EffectSet(tuple(from_spec(e) for e in spec.effects))
    problem = build_problem(kinematics, device, calibration, effects)
    free = int(problem.parameters.free.sum())
    readings, distinct = len(problem.residuals.sample), distinct_readings(problem, calibration)
    if distinct <= free:
        repeated = f" ({readings} readings, but only {distinct} of them at distinct poses)" if distinct < readings else ""
        raise UserError(
            f"{calibration.source}: {distinct} readings cannot determine {free} free parameters{repeated}; "
            "measure more poses or fix parameters in the spec"
        )
    return problem, starting_values(problem, kinematics, device, calibration)


def distinct_readings(problem: Problem, data: Measurements) -> int:
    """Readings that differ in what was read or where (key, channel, joint readings): repeats add no information."""
    q = np.round(np.nan_to_num(data.q), 9)
    where = lambda sample: q[sample].tobytes() if sample >= 0 else b""  # noqa: E731  (-1: a pseudo-observation)
    residuals = problem.residuals
    return len({(str(key), channel, where(sample)) for key, channel, sample in zip(residuals.key, residuals.channel, residuals.sample)})


def identify_and_diagnose(
    spec: Spec, kinematics: KinematicModel, device: DeviceModel, raw: Measurements, calibration: Measurements, validation: Measurements | None
) -> Calibration:
    declared = [from_spec(e) for e in spec.effects]
    settings = spec.diagnose
    effects = EffectSet(tuple(declared))
    problem, start = calibration_problem(spec, kinematics, device, calibration)
    if settings.enabled and settings.max_rounds > 0 and spec.fit.method == "least_squares":
        moved = spec.data is not None and spec.data.instrument_moved
        diagnosis = run_diagnosis(kinematics, device, calibration, validation, declared, spec.fit, settings, start, moved)
        result = diagnosis.fit
        padded = diagnosis.problem.parameters.nominal.copy()
        padded[: len(start)] = start
        return Calibration(diagnosis.problem, diagnosis.validation, Identified(result.theta, result.std, result), diagnosis, padded)
    validation_problem = None
    if validation is not None:
        moved = spec.data is not None and spec.data.instrument_moved
        validation_problem = held_out(build_problem(kinematics, device, validation, effects), kinematics, validation, moved)
    return Calibration(problem, validation_problem, identify_parameters(spec, problem, raw, start), None, start)
