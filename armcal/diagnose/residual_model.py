"""The optional learned residual model (``diagnose.residual_model: gp``, issue 35): what the physical model leaves,
learned on the joint angles by Gaussian processes, and kept only where it holds out as an effect must.

One scikit-learn GaussianProcessRegressor per measured coordinate (a channel: a tracker's x, y, z, a ball-bar's
length), each on the joint angles (rad) with the kernel C * RBF(l_1..l_n) + White: one length scale per joint (ARD),
bounded below at MIN_LENGTH_SCALE, and a noise level bounded below at (NOISE_FLOOR * sigma)^2, sigma the
coordinate's median declared (or estimated) sigma; hyperparameters by the marginal likelihood (a fixed
random_state, one restart for the model on all the data, none for a fold's). Above MAX_TRAINING readings per coordinate a spread subset of that many trains it
(farthest-point selection in joint space): the subset-of-data approximation, O(MAX_TRAINING^3) whatever the size.

It enters after the physical loop has finished, never instead of an effect, and is judged on the loop's k-fold
folds (loop.Context.fold_fits: each fold's physical fit of the other folds, as every effect's held-out errors) with
the loop's paired test (loop.holds_out, HOLDS_OUT standard errors): per held-out pose the squared weighted error of
the physical fit against that of the physical fit plus the model trained on the other folds' residuals. The folds
are contiguous ranges of the joint the model varies most along (its largest range / length scale, from the fit
on all the calibration data), as an effect's are of the joint it follows; the validation data stay untouched.

A prediction whose predictive standard deviation (of the learned function, without the noise term) exceeds
OUTSIDE of the prior's is outside the calibrated region: it is not applied, and it is counted. A coordinate whose
learned function's prior standard deviation is below NEGLIGIBLE of its noise term's learned nothing: no correction of
it reaches a tenth of a reading's noise anywhere, so it has no region to leave and none of its predictions is counted.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np

from armcal.diagnose.loop import Context, holds_out
from armcal.identify.fit import FitResult
from armcal.identify.problem import Problem

MIN_LENGTH_SCALE = 0.2  # rad: no faster variation along a joint than this is learned
NOISE_FLOOR = 0.5  # the noise term's standard deviation is at least this fraction of the declared sigma
MAX_TRAINING = 800  # readings per coordinate that train a model at most (a spread subset above)
OUTSIDE = 0.5  # predictive std / prior std above which a prediction is outside the calibrated region
NEGLIGIBLE = 0.1  # prior std / noise std below which a coordinate's model learned nothing (never outside)
RANDOM_STATE = 0
NOT_CARRIED = (
    "The learned model is carried by results.json and export --format json (its training inputs and hyperparameters); "
    "calibrated.yaml, the other export formats and compensate carry the physical model only"
)
RESTARTS = 1  # random restarts of the marginal likelihood's optimizer for the model on all the calibration data
FOLD_RESTARTS = 0  # and for each fold's model: a restart costs 2-3.5x a fit, and a fold model less well fitted only
# makes the test harder to pass (the k-fold test is conservative); no fold model starts from the all-data model's
# hyperparameters, which have seen the fold


@dataclass(frozen=True)
class CoordinateModel:
    """One coordinate's Gaussian process: its training inputs (rad) and targets (measured - predicted, internal
    units), the hyperparameters, and the fitted regressor."""

    channel: str
    q: np.ndarray
    y: np.ndarray
    constant: float  # prior variance of the learned function
    length_scales: np.ndarray  # rad, one per joint
    noise: float  # variance of the noise term
    regressor: object = field(repr=False, compare=False)

    def carried(self) -> dict:
        """What reproduces the model's predictions elsewhere (results.json, ``export --format json``): the training
        inputs and targets and the hyperparameters of C * RBF(l) + White, fitted no more."""
        return {"coordinate": self.channel, "inputs_rad": self.q.tolist(), "targets": self.y.tolist(),
                "signal_variance": self.constant, "length_scales_rad": self.length_scales.tolist(), "noise_variance": self.noise}

    def predict(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The learned correction (measured - predicted) at joint angles ``q`` (rad), its standard deviation (the
        function's, without the noise term) and whether it is inside the calibrated region."""
        mean, std = self.regressor.predict(q, return_std=True)
        latent = np.sqrt(np.maximum(std**2 - self.noise, 0.0))
        return mean, latent, (latent <= OUTSIDE * np.sqrt(self.constant)) | self.learned_nothing

    @property
    def learned_nothing(self) -> bool:
        return self.constant < NEGLIGIBLE**2 * self.noise


@dataclass(frozen=True)
class ResidualModel:
    coordinates: dict[str, CoordinateModel]

    def correction(self, problem: Problem, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per reading of ``problem`` (samples at joint angles ``q``, rad): the weighted change of its residual
        (predicted - measured) / sigma where the model applies, zero elsewhere, and whether it is outside the
        calibrated region (readings of a coordinate without a model are neither)."""
        res = problem.residuals
        change, outside = np.zeros(len(res.sigma)), np.zeros(len(res.sigma), dtype=bool)
        channel = np.asarray(res.channel)
        for name, model in self.coordinates.items():
            at = np.flatnonzero((channel == name) & (res.sample >= 0))
            if not len(at):
                continue
            mean, _, inside = model.predict(q[res.sample[at]])
            change[at] = np.where(inside, mean / res.sigma[at], 0.0)
            outside[at] = ~inside
        return change, outside


@dataclass(frozen=True)
class Figures:
    """Held-out errors with and without the learned model (internal units: mm for lengths)."""

    rms_physical: dict[str, float]  # RMS per coordinate, physical model
    rms_learned: dict[str, float]  # physical model + learned model
    rms_3d: tuple[float, float] | None  # RMS of the 3D distance (tracker x, y, z), physical and learned
    outside: int  # readings whose prediction was outside the calibrated region (not applied)
    readings: int


@dataclass(frozen=True)
class Judgement:
    """The learned model's test on the k-fold folds and the model trained on all the calibration data."""

    accepted: bool
    z: float  # the paired test's change of the held-out squared error, in standard errors
    along: int | None  # the joint whose contiguous ranges were the folds
    held_out: Figures  # of the k-fold folds, each fold predicted by the others' fit and model
    model: ResidualModel
    seconds: float


def _coordinates(residuals) -> dict[str, np.ndarray]:
    """Per measured coordinate (channel) the indices of its readings taken at a pose (sample >= 0); a channel read at
    none (a theodolite's certified distance between targets) is no coordinate of the model."""
    channel = np.asarray(residuals.channel)
    found = {name: np.flatnonzero((channel == name) & (residuals.sample >= 0)) for name in dict.fromkeys(residuals.channel)}
    return {name: at for name, at in found.items() if len(at)}


def _coordinate_data(problem: Problem, r: np.ndarray, q: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, float]]:
    """Per coordinate: the joint angles of its readings, measured - predicted (internal units), its median sigma."""
    res = problem.residuals
    return {name: (q[res.sample[at]], -r[at] * res.sigma[at], float(np.median(res.sigma[at]))) for name, at in _coordinates(res).items()}


def spread_subset(q: np.ndarray, count: int) -> np.ndarray:
    """Indices of ``count`` rows of ``q`` spread over joint space (farthest-point selection from the first row);
    all rows when there are no more."""
    if len(q) <= count:
        return np.arange(len(q))
    chosen = [0]
    distance = np.sum((q - q[0]) ** 2, axis=1)
    for _ in range(count - 1):
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.sum((q - q[chosen[-1]]) ** 2, axis=1))
    return np.sort(np.asarray(chosen))


def fit_coordinate(channel: str, q: np.ndarray, y: np.ndarray, sigma: float, restarts: int = RESTARTS) -> CoordinateModel:
    """One coordinate's Gaussian process, hyperparameters by the marginal likelihood (module docstring)."""
    from sklearn.exceptions import ConvergenceWarning  # scikit-learn only when a spec asks for the model
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    keep = spread_subset(q, MAX_TRAINING)
    q, y = q[keep], y[keep]
    floor = (NOISE_FLOOR * sigma) ** 2
    scale = max(float(np.var(y)), floor)
    kernel = ConstantKernel(scale, (scale * 1e-6, scale * 1e3)) * RBF(
        np.ones(q.shape[1]), (MIN_LENGTH_SCALE, 1e3)
    ) + WhiteKernel(max(sigma**2, floor), (floor, max(sigma**2, floor) * 1e4))
    regressor = GaussianProcessRegressor(kernel, n_restarts_optimizer=restarts, random_state=RANDOM_STATE)
    with warnings.catch_warnings():  # a hyperparameter at its bound is an answer here (no variation: a long scale)
        warnings.simplefilter("ignore", ConvergenceWarning)
        regressor.fit(q, y)
    fitted = regressor.kernel_
    return CoordinateModel(
        channel, q, y, float(fitted.k1.k1.constant_value), np.atleast_1d(fitted.k1.k2.length_scale).astype(float),
        float(fitted.k2.noise_level), regressor,
    )


def fit_model(problem: Problem, theta: np.ndarray, q: np.ndarray, restarts: int = RESTARTS) -> ResidualModel:
    """The learned model of ``problem``'s residuals at ``theta`` (``q``: the joint angles of its samples, rad)."""
    r, _ = problem.evaluate(theta)
    return ResidualModel({name: fit_coordinate(name, *data, restarts) for name, data in _coordinate_data(problem, r, q).items()})


def _along(model: ResidualModel, q: np.ndarray) -> int | None:
    """The joint the model varies most along: the largest range of its angle over its length scale (1-based)."""
    span = np.ptp(q, axis=0)
    ratio = np.max([span / m.length_scales for m in model.coordinates.values()], axis=0)
    return int(np.argmax(ratio)) + 1 if np.any(ratio > 0) else None


def judge(context: Context, problem: Problem, result: FitResult) -> Judgement:
    """Train the model on all the calibration data, then test it on the loop's folds (module docstring)."""
    started = time.perf_counter()
    q = np.nan_to_num(context.calibration.q)
    model = fit_model(problem, result.theta, q)
    along = _along(model, q)
    before, after = np.zeros(context.pose.max() + 1), np.zeros(context.pose.max() + 1)
    parts = []
    for fold in context.fold_fits(problem, result.theta, set(), result.identifiability, along):
        r, _ = fold.test.evaluate(fold.theta)
        fold_model = fit_model(fold.train, fold.theta, q[fold.train_rows], FOLD_RESTARTS)
        change, outside = fold_model.correction(fold.test, q[fold.rows])
        ok = fold.test.residuals.sample >= 0
        pose = context.pose[fold.rows[fold.test.residuals.sample[ok]]]
        np.add.at(before, pose, r[ok] ** 2)
        np.add.at(after, pose, (r[ok] + change[ok]) ** 2)
        parts.append((fold.test, r, change, outside))
    accepted, z = holds_out(before, after)
    return Judgement(accepted, z, along, summary(parts), model, time.perf_counter() - started)


def applied(model: ResidualModel, problem: Problem, theta: np.ndarray, q: np.ndarray) -> Figures:
    """The errors of ``problem`` (e.g. the validation data; ``q`` its samples' joint angles, rad) at ``theta`` without
    and with the model."""
    r, _ = problem.evaluate(theta)
    change, outside = model.correction(problem, q)
    return summary([(problem, r, change, outside)])


def summary(parts: list[tuple[Problem, np.ndarray, np.ndarray, np.ndarray]]) -> Figures:
    """RMS per coordinate and 3D, without and with the model's change, over (problem, weighted residuals, change,
    outside) parts."""
    physical: dict[str, list[np.ndarray]] = {}
    learned: dict[str, list[np.ndarray]] = {}
    distances, outside, readings = [], 0, 0
    for problem, r, change, out in parts:
        res = problem.residuals
        ok = res.sample >= 0
        for name, at in _coordinates(res).items():
            physical.setdefault(name, []).append(r[at] * res.sigma[at])
            learned.setdefault(name, []).append((r[at] + change[at]) * res.sigma[at])
        distances.append(_distances(problem, r, change))
        outside, readings = outside + int(out[ok].sum()), readings + int(ok.sum())
    rms = lambda values: {name: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for name, v in values.items()}  # noqa: E731
    rms_3d = None
    if distances and all(d is not None for d in distances):
        both = np.concatenate(distances, axis=1)
        rms_3d = (float(np.sqrt(np.mean(both[0] ** 2))), float(np.sqrt(np.mean(both[1] ** 2))))
    return Figures(rms(physical), rms(learned), rms_3d, outside, readings)


def _distances(problem: Problem, r: np.ndarray, change: np.ndarray) -> np.ndarray | None:
    """The 3D error of each (sample, key) read in x, y and z (internal units), physical and learned (2, n);
    None when the readings are not points."""
    res = problem.residuals
    if not {"x", "y", "z"} <= set(res.channel):
        return None
    points: dict[tuple, dict[str, tuple[float, float]]] = {}
    for i, (sample, key, channel) in enumerate(zip(res.sample, res.key, res.channel)):
        if sample >= 0 and channel in ("x", "y", "z"):
            points.setdefault((int(sample), str(key)), {})[channel] = (r[i] * res.sigma[i], (r[i] + change[i]) * res.sigma[i])
    whole = [p for p in points.values() if len(p) == 3]
    if not whole:
        return None
    values = np.array([[p[c] for c in ("x", "y", "z")] for p in whole])  # (n, 3, 2)
    return np.sqrt(np.sum(values**2, axis=1)).T
