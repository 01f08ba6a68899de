"""The identification stage of a run: the noise from the data where the spec asks, fit (with the declared
effects), then diagnose what is missing.

Where a noise is ``auto`` or ``estimate_noise`` is true, the variance components
are estimated on the calibration data with the declared effects (identify/variance.py)
and the instrument's sigmas are replaced by the estimates for the rest of the run:
every problem built later (the diagnosis' refits and k-fold folds, the validation
data) is weighted by them. When the diagnosis adds effects, the estimation is
repeated with the final model from its fit, and that fit is the result: the
reported sigmas, the covariance and the noise check all belong to the final model
(the rounds were judged with the first estimates). With estimated sigmas the noise
check holds by construction; the result is ``unexplained`` where the estimates
reject a declared sigma as too small (or readings not estimated fail the check).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.diagnose.loop import Diagnosis, run_diagnosis
from armcal.diagnose.residual_model import Figures, Judgement, applied, judge
from armcal.effects.library import from_spec
from armcal.support.errors import UserError
from armcal.effects.measurement import EffectSet
from armcal.identify.fit import design_identifiability, fit
from armcal.identify.methods import Identified, identify_parameters
from armcal.identify.problem import Problem, build_problem
from armcal.identify.heldout import MovedInstrument, NewStations, held_out
from armcal.identify.starting_values import starting_values
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.identify.variance import NoiseEstimates, estimate_noise, provisional_scale, readings_groups, rescaled, unit_scale, wants_estimation
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.document import Spec


@dataclass(frozen=True)
class Calibration:
    problem: Problem
    validation: Problem | None
    identified: Identified
    diagnosis: Diagnosis | None  # None when the spec turns it off or uses Stone's feature method
    start: np.ndarray  # the nominal model, with a free instrument-to-base transform registered: "before"
    noise: NoiseEstimates | None = None  # the noise estimated from the data, where the spec asks for it
    residual: Judgement | None = None  # the learned residual model's test (diagnose.residual_model: gp)
    residual_validation: Figures | None = None  # the validation data without and with it (the final figures)


def calibration_problem(
    spec: Spec, kinematics: KinematicModel, device: DeviceModel, calibration: Measurements, functions: dict | None = None
) -> tuple[Problem, np.ndarray]:
    """The calibration data's problem with the spec's declared effects, and where the fit starts; ``functions``: the
    compiled functions of this model from earlier problems (build_problem)."""
    effects = EffectSet(tuple(from_spec(e) for e in spec.effects))
    problem = build_problem(kinematics, device, calibration, effects, functions=functions)
    free = int(problem.parameters.free.sum())
    readings, distinct = len(problem.residuals.sample), distinct_readings(problem, calibration)
    if distinct <= free:
        repeated = f" ({readings} readings, but only {distinct} of them at distinct poses)" if distinct < readings else ""
        raise UserError(
            f"{calibration.origin}: {distinct} readings cannot determine {free} free parameters{repeated}; "
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
    noise = None
    if wants_estimation(device):
        noise, device = noise_from_data(spec, kinematics, device, calibration)
        if validation is not None:
            _validation_groups_estimated(spec, device, noise, validation)
    problem, start = calibration_problem(spec, kinematics, device, calibration)
    if settings.enabled and settings.max_rounds > 0 and spec.fit.method == "least_squares":
        moved = spec.data is not None and spec.data.instrument_moved
        diagnosis = run_diagnosis(kinematics, device, calibration, validation, declared, spec.fit, settings, start, moved)
        if noise is not None:
            diagnosis, noise = _final_noise(diagnosis, device, spec, noise)
        result = diagnosis.fit
        padded = diagnosis.problem.parameters.nominal.copy()
        padded[: len(start)] = start
        residual = figures = None
        if settings.residual_model == "gp":  # after the physical loop, on its folds (residual_model.py)
            residual = judge(diagnosis.context, diagnosis.problem, result)
            if diagnosis.validation is not None:
                figures = applied(residual, diagnosis.validation, result.theta, validation, device, _registered_anew(diagnosis, moved))
        identified = Identified(result.theta, result.std, result)
        return Calibration(diagnosis.problem, diagnosis.validation, identified, diagnosis, padded, noise, residual, figures)
    validation_problem = None
    if validation is not None:
        moved = spec.data is not None and spec.data.instrument_moved
        validation_problem = held_out(kinematics, device, validation, effects, moved)
    return Calibration(problem, validation_problem, identify_parameters(spec, problem, raw, start), None, start, noise)


def _registered_anew(diagnosis: Diagnosis, moved: bool):
    """None when the validation problem keeps the calibrated frames, else what builds it again from other data (its
    frames registered anew from them), with the final problem's parameters."""
    if not isinstance(diagnosis.validation, (MovedInstrument, NewStations)):
        return None
    context = diagnosis.context
    return lambda data: replace(held_out(context.kinematics, context.device, data, context.effects, moved), parameters=diagnosis.problem.parameters)


def noise_from_data(spec: Spec, kinematics: KinematicModel, device: DeviceModel, calibration: Measurements) -> tuple[NoiseEstimates, DeviceModel]:
    """The noise groups the spec asks for, estimated on the calibration data with the declared effects, and the
    instrument weighted by them for the rest of the run."""
    unit = unit_scale(device, calibration.groups())
    problem, start = calibration_problem(spec, kinematics, unit, calibration)
    first = provisional_scale(unit, problem, start)
    provisional = device.with_noise_scale({**unit.noise_scale, **first})
    problem = rescaled(problem, readings_groups(unit, problem), unit.noise_scale, provisional.noise_scale)
    estimates, _ = estimate_noise(provisional, problem, spec.fit, start, design_identifiability(problem, start, hold_weak=False))
    return estimates, device.with_noise_scale({**unit.noise_scale, **estimates.scale})


def _validation_groups_estimated(spec: Spec, device: DeviceModel, noise: NoiseEstimates, validation: Measurements) -> None:
    """Every validation reading whose noise is estimated belongs to a group the calibration data estimated."""
    estimated = {g.group for g in noise.groups}
    fields = set(spec.device.estimated_fields())
    for key in validation.groups():
        for channel in device.channels(key):
            group = device.noise_group(key, channel.name)
            if group is not None and device.noise_field(key, channel.name) in fields and group not in estimated:
                where = spec.data.validation if spec.data is not None else "the validation data"
                raise UserError(
                    f"{where}: readings of noise group {group!r}, which the calibration data do not have: its noise cannot "
                    "be estimated; declare its sigma, or group more coarsely (device.noise_groups)"
                )


def _final_noise(diagnosis: Diagnosis, device: DeviceModel, spec: Spec, noise: NoiseEstimates) -> tuple[Diagnosis, NoiseEstimates]:
    """The noise re-estimated with the effects the diagnosis added, the final fit weighted by it, and whether the
    result is unexplained: the readings not estimated fail the noise check, or the data reject a declared sigma as too small."""
    if diagnosis.added:
        problem, base = diagnosis.problem, diagnosis.fit.identifiability
        noise, last = estimate_noise(device, problem, spec.fit, diagnosis.fit.theta, base)
        scale = {**device.noise_scale, **noise.scale}
        problem = rescaled(problem, readings_groups(device, problem), device.noise_scale, scale)
        validation = diagnosis.validation
        if validation is not None:
            validation = rescaled(validation, readings_groups(device, validation), device.noise_scale, scale)
        diagnosis = replace(diagnosis, problem=problem, validation=validation, fit=fit(problem, spec.fit, start=last.theta, identifiability=base))
    too_small = any(g.test is not None and g.test.verdict == "declared_too_small" for g in noise.groups)
    unexplained = diagnosis.fit.uncertainty.p_value < NOISE_CHECK_LEVEL or too_small
    return replace(diagnosis, unexplained=unexplained), noise
