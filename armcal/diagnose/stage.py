"""The identification stage of a run: fit (with the declared effects), then diagnose what is missing."""

from __future__ import annotations

from dataclasses import dataclass

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.diagnose.loop import Diagnosis, run_diagnosis
from armcal.effects.library import from_spec
from armcal.effects.model import EffectSet
from armcal.identify.methods import Identified, identify_parameters
from armcal.identify.problem import Problem, build_problem
from armcal.kinematics.compiler import KinematicModel
from armcal.spec.model import Spec


@dataclass(frozen=True)
class Calibration:
    problem: Problem
    validation: Problem | None
    identified: Identified
    diagnosis: Diagnosis | None  # None when the spec turns it off or uses Stone's feature method


def identify_and_diagnose(
    spec: Spec, kinematics: KinematicModel, device: DeviceModel, raw: Measurements, calibration: Measurements, validation: Measurements | None
) -> Calibration:
    declared = [from_spec(e) for e in spec.effects]
    settings = spec.diagnose
    if settings.enabled and settings.max_rounds > 0 and spec.fit.method == "least_squares":
        diagnosis = run_diagnosis(kinematics, device, calibration, validation, declared, spec.fit, settings)
        result = diagnosis.fit
        return Calibration(diagnosis.problem, diagnosis.validation, Identified(result.theta, result.std, result), diagnosis)
    effects = EffectSet(tuple(declared))
    problem = build_problem(kinematics, device, calibration, effects)
    validation_problem = build_problem(kinematics, device, validation, effects) if validation is not None else None
    return Calibration(problem, validation_problem, identify_parameters(spec, problem, raw), None)
