"""The noise of each group of readings estimated from the data: Foerstner's iterative variance component estimation.

Readings fall into groups (the device's ``noise_group``: the noise field that
declares them - positions, orientations, angles, lengths, ranges - split further
by target, station, ball-bar pairing or microphone as the spec's ``noise_groups``
asks). Each group g has a variance factor s_g^2 on its noise model sigma_i
(the declared sigma, or 1 mm / 1 rad for ``auto``), so a reading's sigma is
s_g sigma_i. With the current factors the problem is fitted; then, per group
(Foerstner 1979; Koch 1999, Parameter Estimation and Hypothesis Testing, 3.6.3),

    r_g = n_g - trace(W_g J_g (J^T W J)^-1 J_g^T)     the group's redundancy
    s_g^2 <- s_g^2 (v_g^T W_g v_g) / r_g              W_g = diag(1 / (s_g sigma_i)^2)

with J the Jacobian of the identified (base) parameters, the design's base set
kept in every refit (fit.py). The redundancies add up to M - p, and at the fixed
point each group's weighted residuals have mean square 1 on its redundancy. The
iteration starts from the declared sigmas; an ``auto`` group starts from the RMS
of its residuals at the fit's start (the nominal model, the instrument registered),
a first fit then sets the ratio of the groups. It stops when no factor changes by
more than TOLERANCE (relative) in a round, after at most MAX_ROUNDS rounds.

Each estimate carries its standard deviation sigma_g / sqrt(2 r_g) (Var s^2 =
2 s^4 / r for normal residuals) and a 95 % interval from the chi-square
distribution on r_g degrees of freedom. Where the spec also declares the sigma,
the estimate is tested against it: T = r_g (sigma_g / sigma_declared)^2 follows
chi^2(r_g) under the declared noise (the chi-square test of a variance factor,
Koch 4.2.4; F(r_g, infinity) = T / r_g), two-sided at NOISE_CHECK_LEVEL.
A robust loss's weights (Huber, Cauchy) enter W as they enter the fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import chdtr, chdtrc, chdtri

from armcal.devices.base import DeviceModel
from armcal.support.errors import UserError
from armcal.identify.fit import FitResult, fit
from armcal.identify.identifiability import Identifiability
from armcal.identify.problem import Problem, reweighted
from armcal.identify.uncertainty import NOISE_CHECK_LEVEL
from armcal.spec.sections import Fit

METHOD = "Foerstner's iterative variance component estimation (Foerstner 1979; Koch 1999, 3.6.3)"
TOLERANCE = 1e-4  # relative change of every variance factor in a round, below which the iteration has converged
MAX_ROUNDS = 30  # safety net; well-determined groups converge in a few rounds
MIN_REDUNDANCY = 1.0  # a group with less redundancy than this has no estimable noise
INTERVAL = 0.95  # coverage of the reported interval of each estimated sigma


@dataclass(frozen=True)
class VarianceTest:
    """An estimated sigma against the declared one: chi-square on the group's redundancy, two-sided."""

    statistic: float  # T = r_g (sigma / declared)^2 ~ chi^2(r_g) under the declared noise
    dof: float  # r_g
    p_value: float  # two-sided
    verdict: str  # consistent | declared_too_small | declared_too_large (at NOISE_CHECK_LEVEL)

    @property
    def rejected(self) -> bool:
        return self.verdict != "consistent"


@dataclass(frozen=True)
class GroupNoise:
    """One group's estimated noise (internal units: mm or rad)."""

    group: str  # e.g. "position", "orientation, target tmac", "angle, station t1", "length, pairing c1-s2"
    field: str  # the spec's noise field: noise, orientation_noise
    kind: str  # unit kind of sigma: length | angle
    readings: int  # n_g
    redundancy: float  # r_g
    sigma: float  # estimated sigma (the RMS over the group where the model varies by reading, as Stone's 7.9 does)
    std: float  # sigma / sqrt(2 r_g)
    interval: tuple[float, float]  # INTERVAL chi-square interval of sigma
    declared: float | None  # the spec's sigma (RMS over the group), None for auto
    factor: float  # sigma / the noise model's sigma: the weights' scale
    test: VarianceTest | None  # against the declared sigma


@dataclass(frozen=True)
class NoiseEstimates:
    """Every estimated group, and how the iteration went."""

    method: str
    groups: tuple[GroupNoise, ...]
    rounds: int
    converged: bool
    change: float  # largest relative change of a variance factor in the last round

    @property
    def scale(self) -> dict[str, float]:
        """Group -> factor on the device's noise model: what the device uses for the rest of the run."""
        return {g.group: g.factor for g in self.groups}

    @property
    def rejected(self) -> tuple[GroupNoise, ...]:
        """Groups whose declared sigma the data reject."""
        return tuple(g for g in self.groups if g.test is not None and g.test.rejected)

    def spec_values(self) -> dict[str, tuple[float, str]] | None:
        """Noise field -> (estimated sigma in internal units, unit kind), where each field is one group (noise_groups:
        [kind]); None otherwise (a calibrated spec then keeps estimating)."""
        fields = [g.field for g in self.groups]
        if len(set(fields)) != len(fields):
            return None
        return {g.field: (float(g.sigma), g.kind) for g in self.groups}


def readings_groups(device: DeviceModel, problem: Problem) -> list[str | None]:
    """The noise group of each residual of ``problem`` (None: not a reading of the instrument's noise)."""
    residuals = problem.residuals
    cache: dict[tuple, str | None] = {}
    out = []
    for key, channel in zip(residuals.key, residuals.channel):
        if (key, channel) not in cache:
            cache[(key, channel)] = device.noise_group(key, channel)
        out.append(cache[(key, channel)])
    return out


def estimated_groups(device: DeviceModel, problem: Problem) -> dict[str, tuple[str, str]]:
    """Group -> (noise field, unit kind) of the groups the spec asks to estimate (auto, or estimate_noise), in order."""
    fields = set(device.spec.estimated_fields())
    residuals = problem.residuals
    out: dict[str, tuple[str, str]] = {}
    for key, channel, kind, group in zip(residuals.key, residuals.channel, residuals.kind, readings_groups(device, problem)):
        field = device.noise_field(key, channel)
        if group is not None and field in fields and group not in out:
            out[group] = (field, kind)
    return out


def wants_estimation(device: DeviceModel) -> bool:
    """Does the spec ask for any noise to be estimated from the data?"""
    return bool(device.spec.estimated_fields())


def provisional_scale(device: DeviceModel, problem: Problem, theta: np.ndarray) -> dict[str, float]:
    """Where the iteration starts: the declared sigmas, and for an auto group the RMS of its residuals at ``theta``
    (its readings in units of its noise model's shape)."""
    groups = np.array(readings_groups(device, problem), dtype=object)
    r, _ = problem.evaluate(theta)
    shape = problem.residuals.sigma / _factors(device.noise_scale, groups)
    scale = {}
    for group, (field, _) in estimated_groups(device, problem).items():
        if getattr(device.spec, field) == "auto":
            rows = groups == group
            rms = float(np.sqrt(np.mean((r[rows] * problem.residuals.sigma[rows] / shape[rows]) ** 2)))
            scale[group] = rms if np.isfinite(rms) and rms > 0 else 1.0
        else:
            scale[group] = 1.0
    return scale


def _factors(scale, groups: np.ndarray) -> np.ndarray:
    return np.array([scale.get(g, 1.0) if g is not None else 1.0 for g in groups])


def rescaled(problem: Problem, groups: list[str | None], old: dict[str, float], new: dict[str, float]) -> Problem:
    """``problem`` with each group's sigmas moved from factor ``old`` to factor ``new`` (other readings kept)."""
    groups = np.array(groups, dtype=object)
    ratio = _factors(new, groups) / _factors(old, groups)
    return reweighted(problem, problem.residuals.sigma * ratio)


def redundancy_numbers(J: np.ndarray) -> np.ndarray:
    """r_i = 1 - h_i, h_i the leverage of residual i: the diagonal of J (J^T J)^-1 J^T, from a thin QR of J."""
    Q, _ = np.linalg.qr(J, mode="reduced")
    return 1.0 - np.einsum("ij,ij->i", Q, Q)


def estimate_noise(
    device: DeviceModel,
    problem: Problem,
    settings: Fit,
    start: np.ndarray,
    identifiability: Identifiability,
) -> tuple[NoiseEstimates, FitResult]:
    """Foerstner's iteration on ``problem``, built with ``device`` (whose noise_scale are the starting factors).

    Returns the estimates and the last fit (with the factors before the last update, within TOLERANCE of them).
    """
    groups = readings_groups(device, problem)
    wanted = estimated_groups(device, problem)
    if not wanted:  # no reading of an estimated kind in these data
        return NoiseEstimates(METHOD, (), 0, True, 0.0), fit(problem, settings, start=start, identifiability=identifiability)
    labels = np.array(groups, dtype=object)
    members = {g: np.flatnonzero(labels == g) for g in wanted}
    scale = {g: float(device.noise_scale.get(g, 1.0)) for g in wanted}
    current, theta = problem, np.asarray(start, dtype=float)
    change, rounds = np.inf, 0
    while rounds < MAX_ROUNDS:
        rounds += 1
        result = fit(current, settings, start=theta, identifiability=identifiability)
        theta = result.theta
        quadratic, redundancy = _group_statistics(current, result, members)
        thin = [g for g in wanted if redundancy[g] < MIN_REDUNDANCY]
        if thin:
            raise UserError(
                f"the noise of {', '.join(repr(g) for g in thin)} cannot be estimated: the fit absorbs its readings "
                f"(redundancy {', '.join(f'{redundancy[g]:.2g}' for g in thin)} < {MIN_REDUNDANCY:g}); declare it, or group more coarsely"
            )
        updated = {g: scale[g] * np.sqrt(quadratic[g] / redundancy[g]) for g in wanted}
        change = max(abs(updated[g] ** 2 / scale[g] ** 2 - 1) for g in wanted)
        current = rescaled(current, groups, scale, updated)
        scale = updated
        if change < TOLERANCE:
            break
    estimates = _report(device, problem, labels, members, wanted, scale, redundancy, rounds, change < TOLERANCE, change)
    return estimates, result


def _group_statistics(problem: Problem, result: FitResult, members: dict[str, np.ndarray]) -> tuple[dict, dict]:
    """v_g^T W_g v_g and r_g of every group at a fit (the robust loss's weights included)."""
    r, J = problem.evaluate(result.theta)
    w = result.solver.weights
    Jw = J[:, result.base] * np.sqrt(w)[:, None]
    numbers = redundancy_numbers(Jw) if Jw.shape[1] else np.ones(len(r))
    quadratic = {g: float(np.sum(w[rows] * r[rows] ** 2)) for g, rows in members.items()}
    redundancy = {g: float(np.sum(numbers[rows])) for g, rows in members.items()}
    return quadratic, redundancy


def _report(device, problem, labels, members, wanted, scale, redundancy, rounds, converged, change) -> NoiseEstimates:
    shape = problem.residuals.sigma / _factors(device.noise_scale, labels)  # the noise model's sigma of every reading
    out = []
    for g, (field, kind) in wanted.items():
        rows = members[g]
        model = float(np.sqrt(np.mean(shape[rows] ** 2)))
        sigma, r = scale[g] * model, redundancy[g]
        declared = None if getattr(device.spec, field) == "auto" else model
        low, high = (sigma * np.sqrt(r / chdtri(r, q)) for q in ((1 - INTERVAL) / 2, (1 + INTERVAL) / 2))
        test = variance_test(sigma, declared, r) if declared is not None else None
        sigma, r = float(sigma), float(r)
        interval = (float(low), float(high))
        out.append(GroupNoise(g, field, kind, len(rows), r, sigma, sigma / np.sqrt(2 * r), interval, declared, float(scale[g]), test))
    return NoiseEstimates(METHOD, tuple(out), rounds, converged, float(change))


def variance_test(sigma: float, declared: float, redundancy: float) -> VarianceTest:
    """Chi-square test of an estimated sigma against the declared one on the group's redundancy, two-sided."""
    statistic = redundancy * (sigma / declared) ** 2
    lower, upper = float(chdtr(redundancy, statistic)), float(chdtrc(redundancy, statistic))
    p_value = min(1.0, 2 * min(lower, upper))
    verdict = "consistent" if p_value >= NOISE_CHECK_LEVEL else "declared_too_small" if upper < lower else "declared_too_large"
    return VarianceTest(float(statistic), float(redundancy), p_value, verdict)


def unit_scale(device: DeviceModel, keys) -> DeviceModel:
    """``device`` with every group of ``keys``' readings at factor 1, so a problem can be built before any estimate
    (an auto sigma is then the unit of its kind, 1 mm or 1 rad)."""
    groups = {device.noise_group(key, c.name) for key in keys for c in device.channels(key)}
    return device.with_noise_scale({g: 1.0 for g in groups if g is not None})
