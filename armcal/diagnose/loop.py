"""The diagnosis after a fit: test every missing effect, add the strongest that holds out, refit, repeat.

All candidates live in one problem with their parameters fixed at zero; adding
one frees its parameters. The base set is decided once, at the design point (the
start of the first fit): a candidate's parameters join it only where the geometry
cannot absorb them there (identifiability.extend), and every refit and k-fold fold
keeps that set. No point is evaluated twice: a trial's fit starts with the score
tests' residuals and Jacobian, each fold's fit with its rows of the full fit's at its
solution (FitResult.at_solution); the folds' problems are built once per way of folding,
and the held-out errors of an accepted effect are the next round's before its trials.

A round ranks the candidates significant after Holm's correction by strength (the
-log p-value of their score statistic, which compares statistics of different
degrees of freedom) and tries them in that order, at most MAX_TRIALS, until one
holds out: its held-out error must fall by more than its own sampling noise. The
held-out errors are those of k-fold cross-validation over the calibration poses
(``diagnose.holdout: kfold``, the default: the validation set stays untouched until
the final figures) or of the validation set (``holdout: validation``, whose figures
are then no longer independent); the test is one-sided and paired over poses: the
mean change of a pose's squared weighted error must be below -HOLDS_OUT standard
errors. The loop ends when nothing is significant, nothing holds out, or the round
limit is reached. An accepted effect whose refit still fails the noise check while a
candidate of the same kind on the same joint (or instrument part) stays significant
is "partly explained". The result is ``unexplained`` whenever the final fit's
residuals exceed the noise model.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.devices.base import DeviceModel
from armcal.diagnose.candidates import candidates
from armcal.diagnose.score import Test, holm, score_tests
from armcal.effects.library import EffectSpec
from armcal.effects.measurement import EffectSet
from armcal.identify.fit import FitResult, fit, fit_theta
from armcal.identify.heldout import held_out
from armcal.identify.identifiability import Identifiability, analyse, extend, triangular
from armcal.identify.problem import Problem, build_problem, rows_within
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.params import ParameterSet
from armcal.spec.sections import Diagnose, Fit


RIVAL = 0.95  # a candidate whose strength is this close to the accepted one's explains the data about as well
MAX_TRIALS = 8  # candidates tried per round, strongest first, before the round gives up
HOLDS_OUT = 2.0  # standard errors by which the held-out error must fall (one-sided, about 2.3 % by chance)


@dataclass(frozen=True)
class Round:
    tests: list[Test]
    accepted: EffectSpec | None
    theta_before: np.ndarray
    theta_after: np.ndarray
    note: str  # why the round ended as it did
    partly_explained: bool = False  # the accepted effect left part of its signature (module docstring)


@dataclass(frozen=True)
class Diagnosis:
    rounds: list[Round]
    added: list[EffectSpec]
    in_model: list[EffectSpec]  # declared and added
    unexplained: bool
    problem: Problem  # calibration data, all candidates
    validation: Problem | None
    fit: FitResult  # the final fit
    chosen_on: str  # the data that judged the candidates: kfold (calibration poses) or validation
    context: Context | None = None  # the folds that judged the effects, for the learned residual model after them


@dataclass(frozen=True)
class FoldFit:
    """One fold of the k-fold cross-validation: its calibration samples (test), the others' (training), the two
    problems and the training fit's parameters."""

    rows: np.ndarray
    train_rows: np.ndarray
    train: Problem
    test: Problem
    theta: np.ndarray


def with_free(problem: Problem, names: set[str], free: bool = True) -> Problem:
    """The problem with the named parameters freed (or fixed)."""
    entries = tuple(replace(e, free=free) if e.name in names else e for e in problem.parameters.entries)
    return replace(problem, parameters=ParameterSet(entries))


class Context:
    """What every round needs: the model, the data, the settings, and the data that judge a candidate."""

    def __init__(self, kinematics, device, calibration, validation, effects, fit_settings, settings, instrument_moved):
        self.kinematics, self.device, self.calibration = kinematics, device, calibration
        self.effects, self.fit_settings, self.settings = effects, fit_settings, settings
        self.functions = {}  # the keys' compiled functions, shared by every problem of the diagnosis (build_problem)
        self._built = {}  # the last along asked for -> its folds' samples and problems (_fold_problems)
        self.validation = None
        if validation is not None:
            self.validation = held_out(kinematics, device, validation, effects, instrument_moved)
        self.judge = "validation" if settings.holdout == "validation" and self.validation is not None else "kfold"
        poses, self.pose = np.unique(np.round(np.nan_to_num(calibration.q), 9), axis=0, return_inverse=True)
        self.pose = self.pose.ravel()
        folds = settings.folds
        self.folds = {None: np.arange(len(poses)) % folds}  # interleaved; per joint: contiguous ranges of its angle
        for joint in range(kinematics.dof):
            self.folds[joint + 1] = contiguous_folds(poses[:, joint], folds)

    def held_out_errors(
        self, problem: Problem, result: FitResult, free: set[str], along: int | None = None
    ) -> np.ndarray:
        """Each held-out pose's sum of squared weighted residuals: of the validation set's samples, or of the
        calibration poses, each predicted by a fit (on the full fit's base set) of the folds without it. ``result``:
        the fit of ``problem``. ``along`` a joint, each fold is a contiguous range of that joint's values
        (EffectSpec.followed_joint)."""
        theta = result.theta
        if self.judge == "validation":
            r, _ = self.validation.evaluate(theta)
            return np.bincount(self.validation.residuals.sample[self.validation.residuals.sample >= 0], r[self.validation.residuals.sample >= 0] ** 2)
        errors = np.zeros(self.pose.max() + 1)
        for fold in self.fold_fits(problem, theta, free, result.identifiability, along, result.at_solution):
            r, _ = fold.test.evaluate(fold.theta, columns=np.arange(0))
            sample = fold.test.residuals.sample
            np.add.at(errors, self.pose[fold.rows[sample[sample >= 0]]], r[sample >= 0] ** 2)
        return errors

    def fold_fits(
        self, problem: Problem, theta: np.ndarray, free: set[str], identifiability: Identifiability, along: int | None = None,
        at: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> Iterator[FoldFit]:
        """The k-fold fits of the calibration poses, fold by fold: the problems of the folds without it (training) and of
        the fold (test), and the fit of the training folds from ``theta`` on the full fit's base set. ``along`` a joint,
        each fold is a contiguous range of that joint's values (EffectSpec.followed_joint). ``at``: ``problem``'s (r, J
        over the base columns) at ``theta`` (FitResult.at_solution), whose rows start each training fit instead of
        an evaluation. The effects' held-out errors and the learned residual model's (residual_model.py) come from
        these same fits."""
        for rows, train_rows, train, test, within in self._fold_problems(along, problem):
            train, test = self._like(train, problem, free), self._like(test, problem, free)
            initial = None if at is None else (at[0][within], np.asfortranarray(at[1][within]))
            yield FoldFit(rows, train_rows, train, test, fit_theta(train, self.fit_settings, theta, identifiability, initial))

    def _fold_problems(self, along: int | None, whole: Problem) -> list[tuple[np.ndarray, np.ndarray, Problem, Problem, np.ndarray]]:
        """Each fold's calibration samples and those of the others, their problems, and the rows of ``whole`` (a
        problem of all the calibration data) that the training problem's are; kept for the last ``along`` asked for
        only (they hold about the data twice over per way of folding; building them again costs milliseconds)."""
        if along not in self._built:
            fold = self.folds[along][self.pose]
            built = []
            for k in range(self.settings.folds):
                rows, train_rows = np.flatnonzero(fold == k), np.flatnonzero(fold != k)
                train, test = (build_problem(self.kinematics, self.device, self.calibration.subset(r), self.effects, functions=self.functions)
                               for r in (train_rows, rows))
                built.append((rows, train_rows, train, test, rows_within(train, train_rows, whole)))
            self._built = {along: built}
        return self._built[along]

    @staticmethod
    def _like(problem: Problem, like: Problem, free: set[str]) -> Problem:
        """``problem`` with the parameters of ``like``, the ``free`` ones freed."""
        return with_free(replace(problem, parameters=like.parameters), free) if free else replace(problem, parameters=like.parameters)


def contiguous_folds(values: np.ndarray, folds: int) -> np.ndarray:
    """Fold of each pose: contiguous ranges of one joint's ``values``, equal in size; interleaved where the joint sits
    at one value in more than a fold's share of the poses (a circle-point campaign moves one joint at a time, and
    ranges of a still joint would split the poses by the other joints instead)."""
    _, counts = np.unique(values, return_counts=True)
    if counts.max() > len(values) / folds:
        return np.arange(len(values)) % folds
    return np.argsort(np.argsort(values, kind="stable")) * folds // len(values)


def holds_out(before: np.ndarray, after: np.ndarray) -> tuple[bool, float]:
    """A paired one-sided test over held-out poses: does the squared error fall by more than HOLDS_OUT standard
    errors of its mean change? Returns (it does, the change in standard errors)."""
    change = after - before
    spread = float(np.std(change, ddof=1)) / np.sqrt(len(change)) if len(change) > 1 else 0.0
    z = float(np.mean(change)) / spread if spread > 0 else (-np.inf if np.mean(change) < 0 else 0.0)
    return bool(z < -HOLDS_OUT), z


def strength(test: Test) -> float:
    """-log of a test's p-value, which compares statistics of different degrees of freedom, computed where the
    p-value itself underflows from the upper tail of chi^2: log Q(a, y) ~ (a-1) log y - y - log Gamma(a) + log(1 + (a-1)/y + ...)."""
    if test.p_value > 1e-300:
        return -math.log(test.p_value)
    a, y = max(test.dof, 1) / 2, test.statistic / 2
    series = 1 + (a - 1) / y + (a - 1) * (a - 2) / y**2 + (a - 1) * (a - 2) * (a - 3) / y**3
    return -((a - 1) * math.log(y) - y - math.lgamma(a) + math.log(series))


def _kind(effect: EffectSpec) -> tuple:
    """What a further candidate of the same kind shares with an effect: its type and what it acts on (not an order)."""
    return (effect.type, effect.joint, effect.part)


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
    context = Context(kinematics, device, calibration, validation, effects, fit_settings, settings, instrument_moved)
    problem = build_problem(kinematics, device, calibration, effects, functions=context.functions)
    theta0 = problem.parameters.nominal.copy()
    if start is not None:
        theta0[: len(start)] = start
    J_design = problem.design_jacobian(theta0)
    design = analyse(J_design, problem.parameters, problem.parameters.free)
    R_design = triangular(J_design)  # what extend needs of J_design (J^T J = R^T R), once for every trial
    result = fit(problem, fit_settings, start=theta0, identifiability=design)
    rounds, added, remaining = [], [], list(pool)
    before: dict[int | None, np.ndarray] = {}  # the model's held-out errors, by the joint its folds follow
    for _ in range(settings.max_rounds):
        r, J = problem.evaluate(result.theta)  # of every column: the score tests', and where each trial's fit starts
        tests = _tests(problem, r, J, result, remaining, settings.alpha)
        significant = sorted((t for t in tests if t.significant), key=strength, reverse=True)
        if not significant:
            rounds.append(Round(tests, None, result.theta, result.theta, "no candidate is significant"))
            break
        _mark_partly_explained(rounds, significant, result)
        accepted, tried = None, []
        for test in significant[:MAX_TRIALS]:
            names = [p.name for p in test.effect.parameters()]
            trial_problem = with_free(problem, set(names))
            trial_base = extend(result.identifiability, R_design, problem.parameters, names)
            initial = (r, np.asfortranarray(J[:, [problem.parameters.index(n) for n in trial_base.base]]))
            trial = fit(trial_problem, fit_settings, result.theta, trial_base, initial)
            along = test.effect.followed_joint
            if along not in before:
                before[along] = context.held_out_errors(problem, result, set(), along)
            after = context.held_out_errors(trial_problem, trial, set(names), along)
            ok, z = holds_out(before[along], after)
            tried.append(f"{test.effect.id} (held-out change {z:+.1f} standard errors)")
            if ok:
                accepted = (test, trial_problem, trial, {along: after})  # the next round's model: its errors so folded
                break
        if accepted is None:
            rounds.append(Round(tests, None, result.theta, result.theta, f"nothing held out: {'; '.join(tried)}"))
            break
        test, trial_problem, trial, before = accepted
        top = strength(test)
        rivals = [t.effect.id for t in significant if t is not test and strength(t) >= RIVAL * top]
        note = f"{test.effect.id} added" + (f" after {'; '.join(tried[:-1])}" if len(tried) > 1 else "")
        note += f"; {', '.join(rivals)} would explain the data almost as well" if rivals else ""
        rounds.append(Round(tests, test.effect, result.theta, trial.theta, note))
        problem, result = trial_problem, trial
        added.append(test.effect)
        remaining = [c for c in remaining if c.id != test.effect.id]
    else:
        if rounds and rounds[-1].accepted is not None:  # the round limit: one more look at what the last refit left
            r, J = problem.evaluate(result.theta)
            _mark_partly_explained(rounds, [t for t in _tests(problem, r, J, result, remaining, settings.alpha) if t.significant], result)
    unexplained = result.uncertainty.p_value < NOISE_CHECK_LEVEL
    validation_problem = replace(context.validation, parameters=problem.parameters) if context.validation else None
    return Diagnosis(rounds, added, list(declared) + added, unexplained, problem, validation_problem, result, context.judge, context)


def _tests(problem: Problem, r: np.ndarray, J: np.ndarray, result: FitResult, remaining: list[EffectSpec], alpha: float) -> list[Test]:
    """Score tests of the remaining candidates at the fit, Holm-corrected; (r, J): ``problem``'s at it, every column."""
    columns = [J[:, [problem.parameters.index(p.name) for p in c.parameters()]] for c in remaining]
    return holm(score_tests(r, J[:, result.base], columns, remaining), alpha)


def _mark_partly_explained(rounds: list[Round], significant: list[Test], result: FitResult) -> None:
    """The last accepted effect left part of its signature: the refit still fails the noise check and a candidate
    of the same kind stays significant."""
    if not rounds or rounds[-1].accepted is None or result.uncertainty.p_value >= NOISE_CHECK_LEVEL:
        return
    if any(_kind(t.effect) == _kind(rounds[-1].accepted) for t in significant):
        rounds[-1] = replace(rounds[-1], partly_explained=True)
