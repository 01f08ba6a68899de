"""The optional learned residual model (``diagnose.residual_model: gp``, issue 35): what the physical model leaves,
learned on the joint values by Gaussian processes, and kept only where it holds out as an effect must.

One scikit-learn GaussianProcessRegressor per learned coordinate, each on the joint values (rad for a revolute
joint, mm for a prismatic one) with the kernel C * RBF(l_1..l_n) + White: one length scale per joint (ARD), bounded
below at SHORTEST (per joint type), and a noise level bounded below at (NOISE_FLOOR * sigma)^2, sigma the
coordinate's median declared (or estimated) sigma, and the signal variance bounded above at 1e3 times the targets'
variance and at half the noise floor / NOISE_RATIO (within what a stored model may have: spec/learned.py); hyperparameters by the marginal likelihood (a fixed
random_state, one restart for the model on all the data, none for a fold's). Above MAX_TRAINING readings per
coordinate a spread subset of that many trains it (farthest-point selection in joint space): the subset-of-data
approximation, O(MAX_TRAINING^3) whatever the size.

The learned coordinates: a point read in x, y, z (a tracker's target) is learned as its error in the robot's base
frame (base_x, base_y, base_z), so that what is learned at one station or instrument placement holds at another: the
error is turned from the instrument frame it is read in by that frame's rotation: the rigid registration (Kabsch) of
the points the model predicts with every instrument frame set to the base frame onto the points it predicts (the
same points, turned and shifted; a station with fewer than 3 points takes the rotation the training data had there), and each correction is turned back into the frame it is
applied in. Every other channel (a ball-bar's length, a theodolite's angles, a tracker's orientation) is a
coordinate of its own, as read. A coordinate is learned where it is read (``at``): a point's base coordinates per
target (two reflectors on the flange err differently when the flange turns), another channel per key, the target,
pivot, station or plane its readings are taken on (a ball-bar's length at two pivots, an azimuth at two stations
are two functions of the joints). At most MAX_COORDINATES are learned, those with the most readings. Readings at
no pose, or at joint values not all known, are none of its data.

It enters after the physical loop has finished, never instead of an effect, and is judged on the loop's k-fold
folds (loop.Context.fold_fits: each fold's physical fit of the other folds, as every effect's held-out errors) with
the loop's paired test (loop.holds_out, HOLDS_OUT standard errors): per held-out pose the squared weighted error of
the physical fit against that of the physical fit plus the model trained on the other folds' residuals. The folds
are contiguous ranges of the joint the model varies most along (its largest range / length scale, from the fit
on all the calibration data), as an effect's are of the joint it follows; the validation data stay untouched.

A prediction whose predictive standard deviation (of the learned function, without the noise term) exceeds
OUTSIDE of the prior's is outside the calibrated region: it is not applied, and it is counted (a point's per base
coordinate: its other coordinates still apply). A coordinate whose learned function's prior standard deviation is below NEGLIGIBLE
of its noise term's learned nothing: no correction of it reaches a tenth of a reading's noise anywhere, so it has no
region to leave and none of its predictions is counted.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace

import numpy as np

from armcal.dataio.measurements import Measurements
from armcal.diagnose.loop import Context, holds_out
from armcal.identify.fit import FitResult
from armcal.identify.heldout import FRAME_PREFIXES
from armcal.identify.problem import Problem
from armcal.kinematics.transforms import rigid_registration
from armcal.spec.learned import BASE, MAX_COORDINATES, MAX_TRAINING, NOISE_RATIO, ResidualModelSection

SHORTEST = {"revolute": 0.2, "prismatic": 20.0}  # rad, mm: no faster variation along a joint than this is learned
# (0.2 rad turns a point 100 mm from the axis by 20 mm: the slide's length scale is bounded as that point's motion)
POINT = ("x", "y", "z")  # the coordinates of a point read in an instrument frame
NOISE_FLOOR = 0.5  # the noise term's standard deviation is at least this fraction of the declared sigma
OUTSIDE = 0.5  # predictive std / prior std above which a prediction is outside the calibrated region
NEGLIGIBLE = 0.1  # prior std / noise std below which a coordinate's model learned nothing (never outside)
RANDOM_STATE = 0
PREDICT_BLOCK = 4096  # rows predicted at once: (rows x MAX_TRAINING) arrays of 26 MB, whatever the rows (compensate's targets)
CARRIED = (
    "The learned model is carried by results.json, calibrated.yaml (its residual_model section), export --format json (its training "
    "inputs and hyperparameters) and compensate (a point's base-frame correction, applied to the target's position where it is "
    "inside the calibrated region); the other export formats carry the physical model only"
)
IN_RESULTS_ONLY = (  # CARRIED where calibrated.yaml could not hold the model (results/calibrated.py: calibrated_text)
    "The learned model is carried by results.json, and from the run's folder by export --format json and compensate (a point's "
    "base-frame correction, applied to the target's position where it is inside the calibrated region), which read results.json's; "
    "not by calibrated.yaml alone ({why}); the other export formats carry the physical model only"
)
RESTARTS = 1  # random restarts of the marginal likelihood's optimizer for the model on all the calibration data
FOLD_RESTARTS = 0  # and for each fold's model: a restart costs 2-3.5x a fit, and a fold model less well fitted only
# makes the test harder to pass (the k-fold test is conservative); no fold model starts from the all-data model's
# hyperparameters, which have seen the fold


@dataclass(frozen=True)
class CoordinateModel:
    """One coordinate's Gaussian process: its training inputs (joint values, rad or mm) and targets (measured -
    predicted, internal units), the hyperparameters, and the fitted regressor."""

    channel: str
    at: str  # where it is read: a point's target, else the key of its readings (key_label)
    q: np.ndarray
    y: np.ndarray
    constant: float  # prior variance of the learned function
    length_scales: np.ndarray  # one per joint, in its unit (rad or mm)
    noise: float  # variance of the noise term
    regressor: object = field(repr=False, compare=False)
    outside: float = OUTSIDE  # the fraction of the prior's standard deviation above which a prediction is outside

    def carried(self) -> dict:
        """What reproduces the model's predictions elsewhere (results.json, calibrated.yaml, ``export --format json``;
        stored_model reads it back): the training inputs and targets and the hyperparameters of C * RBF(l) + White,
        fitted no more."""
        return {"coordinate": self.channel, "at": self.at, "inputs": self.q.tolist(), "targets": self.y.tolist(),
                "signal_variance": self.constant, "length_scales": self.length_scales.tolist(), "noise_variance": self.noise}

    def predict(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The learned correction (measured - predicted) at joint values ``q``, its standard deviation (the
        function's, without the noise term) and whether it is inside the calibrated region."""
        parts = [self.regressor.predict(q[start : start + PREDICT_BLOCK], return_std=True) for start in range(0, len(q), PREDICT_BLOCK)]
        mean, std = (np.concatenate([np.zeros(0), *(part[k] for part in parts)]) for k in (0, 1))
        latent = np.sqrt(np.maximum(std**2 - self.noise, 0.0))
        return mean, latent, (latent <= self.outside * np.sqrt(self.constant)) | self.learned_nothing

    @property
    def learned_nothing(self) -> bool:
        return self.constant < NEGLIGIBLE**2 * self.noise


def regressor_of(q: np.ndarray, y: np.ndarray, constant: float, length_scales: np.ndarray, noise: float):
    """The Gaussian process C * RBF(l) + White with these hyperparameters, conditioned on (q, y), fitted no more."""
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    kernel = ConstantKernel(constant, "fixed") * RBF(length_scales, "fixed") + WhiteKernel(noise, "fixed")
    return GaussianProcessRegressor(kernel, optimizer=None).fit(q, y)


def stored_model(section: ResidualModelSection) -> "ResidualModel":
    """The model a spec's residual_model section stores (CoordinateModel.carried, as calibrated.yaml writes it)."""
    coordinates = {}
    for entry in section.coordinates:
        q, y, scales = np.array(entry.inputs, dtype=float), np.array(entry.targets, dtype=float), np.array(entry.length_scales, dtype=float)
        regressor = regressor_of(q, y, entry.signal_variance, scales, entry.noise_variance)
        coordinates[entry.coordinate, entry.at] = CoordinateModel(entry.coordinate, entry.at, q, y, entry.signal_variance, scales,
                                                                  entry.noise_variance, regressor, section.outside_fraction)
    return ResidualModel(coordinates)


def key_label(key: tuple) -> str:
    """Where a reading is taken, as a learned coordinate's ``at``: its key's names joined by '/' (e.g. t1/ball)."""
    return "/".join(str(part) for part in key if part is not None)


@dataclass(frozen=True)
class Layout:
    """Where a problem's readings go in the learned model: per (channel, key_label) the rows of its readings that
    are a coordinate as read; the points, rows (n, 3) of the x, y, z of one sample and key, and each one's target;
    the turn (n, 3, 3) of each point from the robot's base frame into the instrument frame it is read in, and the
    turn of each station (None: the instrument's one placement)."""

    channels: dict[tuple[str, str], np.ndarray]
    points: np.ndarray
    targets: np.ndarray
    turn: np.ndarray
    turns: dict


def layout(problem: Problem, r: np.ndarray, q: np.ndarray, theta: np.ndarray, device, known: dict | None = None) -> Layout:
    """The layout of ``problem``'s readings (weighted residuals ``r`` at ``theta``; ``q`` the joint values of its
    samples), each station's turn registered from its points, or taken from ``known`` where they are fewer than 3."""
    res = problem.residuals
    posed = res.sample >= 0
    posed[posed] = np.all(np.isfinite(q[res.sample[posed]]), axis=1)
    channel = np.asarray(res.channel)
    read_as_point = np.isin(channel, POINT) & np.array([device.target(k) is not None for k in res.key], dtype=bool)
    points: dict[tuple, dict[str, int]] = {}
    for i in np.flatnonzero(posed & read_as_point):
        points.setdefault((int(res.sample[i]), res.key[i]), {})[channel[i]] = int(i)
    whole = {at: [p[c] for c in POINT] for at, p in points.items() if len(p) == 3}
    rows = np.array(list(whole.values()), dtype=int).reshape(-1, 3)
    keys = [key for _, key in whole]
    stations = [device.station(key) for key in keys]
    turns = dict(known or {})
    if len(rows):
        framed = np.array([name.startswith(FRAME_PREFIXES) for name in problem.parameters.names])
        r_base, _ = Problem.evaluate(problem, np.where(framed, 0.0, theta))  # every instrument frame the base frame, none registered
        base = res.measured[rows] + r_base[rows] * res.sigma[rows]  # the predicted points in the robot's base frame
    for station in dict.fromkeys(stations):
        mine = np.flatnonzero([s == station for s in stations])
        if len(mine) >= 3:
            at = rows[mine]
            turns[station] = rigid_registration(base[mine].reshape(-1, 3), (res.measured[at] + r[at] * res.sigma[at]).reshape(-1, 3))[:3, :3]
    have = np.array([s in turns for s in stations], dtype=bool)
    rows = rows[have]
    targets = np.array([device.target(key) for key, h in zip(keys, have) if h], dtype=object)
    turn = np.array([turns[s] for s, h in zip(stations, have) if h]).reshape(-1, 3, 3)
    where = np.array([key_label(key) for key in res.key], dtype=object)
    found: dict[tuple[str, str], list[int]] = {}
    for i in np.flatnonzero(posed & ~read_as_point):
        found.setdefault((channel[i], where[i]), []).append(int(i))
    return Layout({read: np.array(at) for read, at in found.items()}, rows, targets, turn, turns)


@dataclass(frozen=True)
class ResidualModel:
    coordinates: dict[str, CoordinateModel]

    def correction(self, problem: Problem, placed: Layout, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per reading of ``problem`` (its layout ``placed``; ``q`` its samples' joint values): the weighted change
        of its residual (predicted - measured) / sigma where the model applies, zero elsewhere, and whether it is
        outside the calibrated region (readings of a coordinate without a model are neither)."""
        res = problem.residuals
        change, outside = np.zeros(len(res.sigma)), np.zeros(len(res.sigma), dtype=bool)
        for read, at in placed.channels.items():
            if read in self.coordinates:
                mean, _, inside = self.coordinates[read].predict(q[res.sample[at]])
                change[at] = np.where(inside, mean / res.sigma[at], 0.0)
                outside[at] = ~inside
        for target in self.point_targets():
            mine = placed.targets == target
            at = placed.points[mine]
            shift, inside, _ = self.point_shift(q[res.sample[at[:, 0]]], target)
            change[at] = np.einsum("nij,nj->ni", placed.turn[mine], shift) / res.sigma[at]
            outside[at] = ~inside  # counted per base coordinate, three to a point
        return change, outside

    def outside_fraction(self) -> float:
        """The fraction of the prior's standard deviation above which a prediction is outside the calibrated region."""
        return next(iter(self.coordinates.values())).outside

    def point_targets(self) -> list[str]:
        """The targets whose point errors the model holds in the robot's base frame (base_x, base_y and base_z)."""
        return [at for (name, at) in self.coordinates if name == BASE[0] and all((b, at) in self.coordinates for b in BASE)]

    def point_shift(self, q: np.ndarray, target: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(shift (N, 3), inside (N, 3), std (N, 3)): the learned error of ``target``'s measured point (measured -
        predicted, the robot's base frame) at joint values ``q``, zero in a base coordinate outside the calibrated
        region, where it is inside, and each coordinate's predictive standard deviation (``target`` one of
        point_targets)."""
        predicted = [self.coordinates[name, target].predict(q) for name in BASE]
        inside = np.stack([p[2] for p in predicted], axis=1)
        return np.where(inside, np.stack([p[0] for p in predicted], axis=1), 0.0), inside, np.stack([p[1] for p in predicted], axis=1)


@dataclass(frozen=True)
class Figures:
    """Held-out errors with and without the learned model (internal units: mm for lengths)."""

    rms_physical: dict[str, float]  # RMS per coordinate as read, physical model
    rms_learned: dict[str, float]  # physical model + learned model
    rms_3d: tuple[float, float] | None  # RMS of the 3D distance (points read in x, y, z), physical and learned
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
    turns: dict  # each station's turn from the robot's base frame on the calibration data (Layout.turns)
    seconds: float


def _coordinates(residuals) -> dict[str, np.ndarray]:
    """Per channel as read the indices of its readings taken at a pose (sample >= 0); a channel read at none (a
    theodolite's certified distance between targets) has no figures."""
    channel = np.asarray(residuals.channel)
    found = {name: np.flatnonzero((channel == name) & (residuals.sample >= 0)) for name in dict.fromkeys(residuals.channel)}
    return {name: at for name, at in found.items() if len(at)}


def _coordinate_data(problem: Problem, r: np.ndarray, placed: Layout, q: np.ndarray) -> dict[tuple[str, str], tuple[np.ndarray, np.ndarray, float]]:
    """Per learned coordinate (channel, at): the joint values of its readings, measured - predicted (internal units;
    a point's turned into the robot's base frame), its median sigma. At most MAX_COORDINATES: a channel at a key, or a
    target's three base coordinates together, those with the most readings first (the order of the readings breaks
    a tie)."""
    res = problem.residuals
    groups = [{read: (q[res.sample[at]], -r[at] * res.sigma[at], float(np.median(res.sigma[at])))} for read, at in placed.channels.items()]
    base = np.einsum("nji,nj->ni", placed.turn, -r[placed.points] * res.sigma[placed.points])  # R' e: the error in the base frame
    for target in dict.fromkeys(placed.targets):
        mine = placed.targets == target
        at = placed.points[mine]
        groups.append({(name, target): (q[res.sample[at[:, 0]]], base[mine, k], float(np.median(res.sigma[at]))) for k, name in enumerate(BASE)})
    data: dict = {}
    for group in sorted(groups, key=lambda g: -len(next(iter(g.values()))[1])):
        if len(data) + len(group) <= MAX_COORDINATES:
            data.update(group)
    return data


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


def shortest_scales(kinematics) -> np.ndarray:
    """Each joint's shortest length scale (SHORTEST of its type, rad or mm)."""
    return np.array([SHORTEST[kind] for kind in kinematics.joint_types])


def fit_coordinate(channel: str, at: str, q: np.ndarray, y: np.ndarray, sigma: float, shortest: np.ndarray, restarts: int = RESTARTS) -> CoordinateModel:
    """One coordinate's Gaussian process, hyperparameters by the marginal likelihood (module docstring); length
    scales from ``shortest`` (one per joint) up."""
    from sklearn.exceptions import ConvergenceWarning  # scikit-learn only when a spec asks for the model
    from sklearn.gaussian_process import GaussianProcessRegressor
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

    keep = spread_subset(q, MAX_TRAINING)
    q, y = q[keep], y[keep]
    floor = (NOISE_FLOOR * sigma) ** 2
    ceiling = 0.5 * floor / NOISE_RATIO  # within the signal variance a stored model may have over its noise (spec/learned.py):
    # half, so that the bounds' round trip through logarithms in the optimizer never crosses it
    scale = min(max(float(np.var(y)), floor), ceiling)
    kernel = ConstantKernel(scale, (scale * 1e-6, min(scale * 1e3, ceiling))) * RBF(
        5.0 * shortest, np.stack([shortest, 5e3 * shortest], axis=1)
    ) + WhiteKernel(max(sigma**2, floor), (floor, max(sigma**2, floor) * 1e4))
    regressor = GaussianProcessRegressor(kernel, n_restarts_optimizer=restarts, random_state=RANDOM_STATE)
    with warnings.catch_warnings():  # a hyperparameter at its bound is an answer here (no variation: a long scale)
        warnings.simplefilter("ignore", ConvergenceWarning)
        regressor.fit(q, y)
    fitted = regressor.kernel_
    return CoordinateModel(
        channel, at, q, y, float(fitted.k1.k1.constant_value), np.atleast_1d(fitted.k1.k2.length_scale).astype(float),
        float(fitted.k2.noise_level), regressor,
    )


def fit_model(problem: Problem, r: np.ndarray, placed: Layout, q: np.ndarray, shortest: np.ndarray, restarts: int = RESTARTS) -> ResidualModel:
    """The learned model of ``problem``'s weighted residuals ``r`` (its layout ``placed``; ``q``: the joint values of
    its samples)."""
    data = _coordinate_data(problem, r, placed, q)
    return ResidualModel({read: fit_coordinate(*read, *values, shortest, restarts) for read, values in data.items()})


def _along(model: ResidualModel, q: np.ndarray) -> int | None:
    """The joint the model varies most along: the largest range of its values over its length scale (1-based)."""
    span = np.ptp(np.nan_to_num(q), axis=0)
    ratio = np.max([span / m.length_scales for m in model.coordinates.values()], axis=0)
    return int(np.argmax(ratio)) + 1 if np.any(ratio > 0) else None


def judge(context: Context, problem: Problem, result: FitResult) -> Judgement:
    """Train the model on all the calibration data, then test it on the loop's folds (module docstring)."""
    started = time.perf_counter()
    kinematics, device, q = context.kinematics, context.device, context.calibration.q
    shortest = shortest_scales(kinematics)
    r, _ = problem.evaluate(result.theta)
    placed = layout(problem, r, q, result.theta, device)
    model = fit_model(problem, r, placed, q, shortest)
    along = _along(model, q)
    before, after = np.zeros(context.pose.max() + 1), np.zeros(context.pose.max() + 1)
    parts = []
    for fold in context.fold_fits(problem, result.theta, set(), result.identifiability, along):
        r_train, _ = fold.train.evaluate(fold.theta)
        trained = layout(fold.train, r_train, q[fold.train_rows], fold.theta, device, placed.turns)
        fold_model = fit_model(fold.train, r_train, trained, q[fold.train_rows], shortest, FOLD_RESTARTS)
        r, _ = fold.test.evaluate(fold.theta)
        tested = layout(fold.test, r, q[fold.rows], fold.theta, device, trained.turns)
        change, outside = fold_model.correction(fold.test, tested, q[fold.rows])
        ok = fold.test.residuals.sample >= 0
        pose = context.pose[fold.rows[fold.test.residuals.sample[ok]]]
        np.add.at(before, pose, r[ok] ** 2)
        np.add.at(after, pose, (r[ok] + change[ok]) ** 2)
        parts.append((fold.test, r, change, outside, tested))
    accepted, z = holds_out(before, after)
    return Judgement(accepted, z, along, summary(parts), model, placed.turns, time.perf_counter() - started)


def applied(judgement: Judgement, problem: Problem, theta: np.ndarray, data: Measurements, device, registered_anew=None) -> Figures:
    """The errors of ``problem`` (the held-out ``data``) at ``theta`` without and with the judged model; a station the
    calibration data had keeps their turn where it has fewer than 3 points. A problem whose frames are registered
    anew from the data (a moved instrument, a new station) is rebuilt by ``registered_anew`` from the data less the
    learned correction, so that each frame is registered on the model it is judged with (physical + learned)."""
    r, _ = problem.evaluate(theta)
    placed = layout(problem, r, data.q, theta, device, judgement.turns)
    change, outside = judgement.model.correction(problem, placed, data.q)
    if registered_anew is not None:
        learned, _ = registered_anew(corrected(judgement.model, data, placed.turns, device)).evaluate(theta)
        change = learned - r  # the same readings, the same order: r + change, the residuals of physical + learned
    return summary([(problem, r, change, outside, placed)])


def corrected(model: ResidualModel, data: Measurements, turns: dict, device) -> Measurements:
    """``data`` with each reading less the learned correction (measured - predicted) where it is inside the calibrated
    region: a point's turned into its station's frame (``turns``; a station without one is left as read)."""
    readings = {name: values.copy() for name, values in data.readings.items()}
    known = np.all(np.isfinite(data.q), axis=1)
    where = np.array([key_label(key) for key in data.keys], dtype=object)
    for (name, at), coordinate in model.coordinates.items():
        if name in readings:
            rows = np.flatnonzero(known & (where == at))
            mean, _, inside = coordinate.predict(data.q[rows])
            readings[name][rows] -= np.where(inside, mean, 0.0)
    stations = [device.station(key) for key in data.keys]
    targets = np.array([device.target(key) for key in data.keys], dtype=object)
    placed = np.array([s in turns for s in stations], dtype=bool)
    for target in model.point_targets() if set(POINT) <= set(readings) else ():
        rows = np.flatnonzero(known & placed & (targets == target))
        shift, _, _ = model.point_shift(data.q[rows], target)
        turned = np.einsum("nij,nj->ni", np.array([turns[stations[i]] for i in rows]).reshape(-1, 3, 3), shift)
        for k, name in enumerate(POINT):
            readings[name][rows] -= turned[:, k]
    return replace(data, readings=readings)


def summary(parts: list[tuple[Problem, np.ndarray, np.ndarray, np.ndarray, Layout]]) -> Figures:
    """RMS per coordinate as read and 3D (of the points), without and with the model's change, over (problem,
    weighted residuals, change, outside, layout) parts."""
    physical: dict[str, list[np.ndarray]] = {}
    learned: dict[str, list[np.ndarray]] = {}
    distances, outside, readings = [], 0, 0
    for problem, r, change, out, placed in parts:
        res = problem.residuals
        ok = res.sample >= 0
        for name, at in _coordinates(res).items():
            physical.setdefault(name, []).append(r[at] * res.sigma[at])
            learned.setdefault(name, []).append((r[at] + change[at]) * res.sigma[at])
        at = placed.points
        distances.append(np.linalg.norm(np.stack([r[at], r[at] + change[at]]) * res.sigma[at], axis=2))
        outside, readings = outside + int(out[ok].sum()), readings + int(ok.sum())
    rms = lambda values: {name: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for name, v in values.items()}  # noqa: E731
    both = np.concatenate(distances, axis=1) if distances else np.zeros((2, 0))
    rms_3d = (float(np.sqrt(np.mean(both[0] ** 2))), float(np.sqrt(np.mean(both[1] ** 2)))) if both.shape[1] else None
    return Figures(rms(physical), rms(learned), rms_3d, outside, readings)
