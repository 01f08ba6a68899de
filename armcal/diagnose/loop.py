"""The diagnosis after a fit: test every missing effect, add the strongest that holds out, refit, repeat.

All candidates live in one problem with their parameters fixed at zero; adding
one frees its parameters. The base set is decided once, at the design point (the
start of the first fit): a candidate's parameters join it only where the geometry
cannot absorb them there (identifiability.extend), and every refit and k-fold fold
keeps that set. A round accepts the candidate with the largest score
statistic among those significant after Holm's correction only if the error on
data the fit did not see improves (the validation set, else k-fold cross
validation). The loop ends when nothing is significant, the held-out error does
not improve, or the round limit is reached. When the residuals still exceed the
noise model and nothing explains them, the result is flagged ``unexplained``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.diagnose.candidates import candidates
from armcal.diagnose.score import Test, holm, score_tests
from armcal.effects.library import EffectSpec
from armcal.effects.model import EffectSet
from armcal.identify.fit import FitResult, fit
from armcal.identify.heldout import held_out
from armcal.identify.identifiability import Identifiability, analyse, extend
from armcal.identify.problem import Problem, build_problem
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet
from armcal.spec.sections import Diagnose, Fit


RIVAL = 0.95  # a candidate whose statistic is this close to the best's explains the data about as well


@dataclass(frozen=True)
class Round:
    tests: list[Test]
    accepted: EffectSpec | None
    theta_before: np.ndarray
    theta_after: np.ndarray
    note: str  # why the round ended as it did


@dataclass(frozen=True)
class Diagnosis:
    rounds: list[Round]
    added: list[EffectSpec]
    in_model: list[EffectSpec]  # declared and added
    unexplained: bool
    problem: Problem  # calibration data, all candidates
    validation: Problem | None
    fit: FitResult  # the final fit


def with_free(problem: Problem, names: set[str], free: bool = True) -> Problem:
    """The problem with the named parameters freed (or fixed)."""
    entries = tuple(replace(e, free=free) if e.name in names else e for e in problem.parameters.entries)
    return replace(problem, parameters=ParameterSet(entries))


def weighted_rms(problem: Problem, theta: np.ndarray) -> float:
    r, _ = problem.evaluate(theta)
    return float(np.sqrt(np.mean(r**2)))


class _Context:
    """What every round needs: the model, the data and the settings."""

    def __init__(self, kinematics, device, calibration, validation, effects, fit_settings, settings, instrument_moved):
        self.kinematics, self.device, self.calibration = kinematics, device, calibration
        self.effects, self.fit_settings, self.settings = effects, fit_settings, settings
        self.validation = None
        if validation is not None:
            problem = build_problem(kinematics, device, validation, effects)
            self.validation = held_out(problem, kinematics, validation, instrument_moved)

    def held_out_error(self, problem: Problem, theta: np.ndarray, free: set[str], identifiability: Identifiability) -> float:
        """Weighted RMS on the validation set, else over k folds each fitted without its own samples
        (on the full fit's base set)."""
        if self.validation is not None:
            return weighted_rms(self.validation, theta)
        folds = self.settings.folds
        fold = np.arange(len(self.calibration)) % folds
        squares, count = 0.0, 0
        for k in range(folds):
            train = self._problem(self.calibration.subset(np.flatnonzero(fold != k)), problem, free)
            test = self._problem(self.calibration.subset(np.flatnonzero(fold == k)), problem, free)
            r, _ = test.evaluate(fit(train, self.fit_settings, start=theta, identifiability=identifiability).theta)
            squares, count = squares + float(r @ r), count + len(r)
        return float(np.sqrt(squares / count))

    def _problem(self, data: Measurements, like: Problem, free: set[str]) -> Problem:
        problem = build_problem(self.kinematics, self.device, data, self.effects)
        return with_free(replace(problem, parameters=like.parameters), free) if free else replace(problem, parameters=like.parameters)


def run_diagnosis(
    kinematics: KinematicModel,
    device: DeviceModel,
    calibration: Measurements,
    validation: Measurements | None,
    declared: list[EffectSpec],
    fit_settings: Fit,
    settings: Diagnose,
    start: np.ndarray | None = None,
    instrument_moved: bool = False,
) -> Diagnosis:
    """Fit, then diagnose round by round (see the module's docstring)."""
    pool = candidates(kinematics, device, calibration, declared, settings)
    effects = EffectSet(tuple(declared) + tuple(replace(c, free=False) for c in pool))
    context = _Context(kinematics, device, calibration, validation, effects, fit_settings, settings, instrument_moved)
    problem = build_problem(kinematics, device, calibration, effects)
    theta0 = problem.parameters.nominal.copy()
    if start is not None:
        theta0[: len(start)] = start
    _, J_design = problem.evaluate(theta0)
    design = analyse(J_design, problem.parameters, problem.parameters.free)
    result = fit(problem, fit_settings, start=theta0, identifiability=design)
    rounds, added, remaining = [], [], list(pool)
    for _ in range(settings.max_rounds):
        r, J = problem.evaluate(result.theta)
        columns = [J[:, [problem.parameters.index(p.name) for p in c.parameters()]] for c in remaining]
        tests = holm(score_tests(r, J[:, result.base], columns, remaining), settings.alpha)
        significant = [t for t in tests if t.significant]
        if not significant:
            rounds.append(Round(tests, None, result.theta, result.theta, "no candidate is significant"))
            break
        best = max(significant, key=lambda t: t.statistic).effect
        names = {p.name for p in best.parameters()}
        trial_problem = with_free(problem, names)
        trial_base = extend(result.identifiability, J_design, problem.parameters, [p.name for p in best.parameters()])
        trial = fit(trial_problem, fit_settings, start=result.theta, identifiability=trial_base)
        before = context.held_out_error(problem, result.theta, set(), result.identifiability)
        after = context.held_out_error(trial_problem, trial.theta, names, trial_base)
        if not after < before:
            rounds.append(Round(tests, None, result.theta, result.theta, f"{best.id} did not lower the held-out error"))
            break
        rivals = [t.effect.id for t in significant if t.effect.id != best.id and t.statistic >= RIVAL * max(t.statistic for t in significant)]
        note = f"{best.id} added" + (f"; {', '.join(rivals)} would explain the data almost as well" if rivals else "")
        rounds.append(Round(tests, best, result.theta, trial.theta, note))
        problem, result = trial_problem, trial
        added.append(best)
        remaining = [c for c in remaining if c.id != best.id]
    noise_rejected = result.uncertainty.p_value < NOISE_CHECK_LEVEL
    unexplained = noise_rejected and (not rounds or rounds[-1].accepted is None)
    validation_problem = replace(context.validation, parameters=problem.parameters) if context.validation else None
    return Diagnosis(rounds, added, list(declared) + added, unexplained, problem, validation_problem, result)
