"""Evidence for a person: where the residuals come from, before and after the diagnosis.

Each sample's residual magnitude (the RMS over its readings, in the
instrument's unit; for a ball-bar the absolute length residual) binned against
each joint angle, against the gravity torque about each joint, against time and
temperature, and per key (target, pivot pairing, station); the histogram of the
final signed residuals beside the Gaussian of the noise model (Goswami Figs.
3-4). The fit before the diagnosis is shown with the magnitude of the predicted
contribution of each effect the diagnosis added, so the curve can be seen to
follow the residuals.
"""

from __future__ import annotations

import math

import numpy as np

from armcal.effects.measurement import DEFAULT_LINK_MASS, gravity_torque_function
from armcal.evaluate.residuals import ARCSEC, residual_unit
from armcal.kinematics.params import joint_kind
from armcal.support.units import factor

BINS = 18


def _binned(x: np.ndarray, values: dict[str, np.ndarray], bins: int = BINS) -> dict:
    """Mean of each series in equal-width bins of x (empty bins left out, and the samples without an x: a theodolite's
    scale-bar readings are taken at no pose of the robot)."""
    known = np.isfinite(x)
    x, values = x[known], {name: series[known] for name, series in values.items()}
    if not len(x):
        return {"x": [], **{name: [] for name in values}, "count": []}
    edges = np.linspace(np.min(x), np.max(x), bins + 1)
    which = np.clip(np.digitize(x, edges) - 1, 0, bins - 1)
    out: dict = {"x": [], **{name: [] for name in values}, "count": []}
    for b in range(bins):
        inside = which == b
        if inside.any():
            out["x"].append(float((edges[b] + edges[b + 1]) / 2))
            out["count"].append(int(inside.sum()))
            for name, series in values.items():
                out[name].append(float(np.mean(series[inside])))
    return out


def evidence(loaded, kinematics, device, calibration, data) -> dict:
    """The evidence block of results.json (angles in the spec's unit)."""
    spec = loaded.spec
    kind, unit = residual_unit(spec.device.reading_kind)
    problem = calibration.problem
    final = calibration.identified.theta
    diagnosis = calibration.diagnosis
    start = diagnosis.rounds[0].theta_before if diagnosis and diagnosis.rounds else final
    r_final, _ = problem.evaluate(final)
    r_start, J_start = problem.evaluate(start)
    r_design, _ = problem.evaluate(calibration.start)
    residuals = problem.residuals
    chosen = (np.array(residuals.kind) == kind) & (residuals.sample >= 0)
    to_unit = (lambda v: v / ARCSEC) if unit == "arcsec" else (lambda v: v)
    sigma = residuals.sigma[chosen]
    after = to_unit(r_final[chosen] * sigma)
    before = to_unit(r_start[chosen] * sigma)
    design = to_unit(r_design[chosen] * sigma)
    samples, slot = np.unique(residuals.sample[chosen], return_inverse=True)
    magnitude = lambda v: np.sqrt(np.bincount(slot, v**2) / np.bincount(slot))  # noqa: E731
    series = {"before": magnitude(before), "after": magnitude(after)}
    for effect in diagnosis.added if diagnosis else []:
        columns = [problem.parameters.index(p.name) for p in effect.parameters()]
        contribution = J_start[:, columns] @ (final[columns] - start[columns])
        series[effect.id] = magnitude(to_unit(contribution[chosen] * sigma))
    q = data.q[samples]
    torque = np.array(gravity_torque_function(kinematics).map(len(q))(np.nan_to_num(q).T, final[: problem.n_robot])).T
    posed = np.isfinite(q).all(axis=1)
    torque[~posed] = np.nan  # no pose, no torque
    spread = np.ptp(torque[posed], axis=0) if posed.any() else np.zeros(kinematics.dof)
    block = {
        "unit": unit,
        "joints": [{"joint": j + 1, **_binned(q[:, j] / factor(joint_kind(kind), spec.robot.units.of(joint_kind(kind))), series)}
                   for j, kind in enumerate(kinematics.joint_types)],
        "joint_axes": [_joint_axis(kind, spec) for kind in kinematics.joint_types],
        "torque_masses": "the robot's declared masses (robot.masses)" if kinematics.masses else
        f"{DEFAULT_LINK_MASS:g} kg at each link frame's origin beyond the joint (assumed: the spec declares no masses)",
        "gravity_torque": [
            {"joint": j + 1, **_binned(torque[:, j], series)}
            for j in range(kinematics.dof)
            if spread[j] > 0.01 * np.max(spread)  # a vertical axis carries no gravity torque
        ],
        "keys": _per_key(residuals, chosen, design, after),
        "magnitude": "RMS over each sample's readings",
        "histogram": _histogram(after, sigma if unit != "arcsec" else sigma / ARCSEC),
    }
    for name in ("t", "temperature"):
        if name in data.extras:
            block[name] = _binned(data.extras[name][samples], series)
    longitudes = _longitudes(kinematics, device, problem, final, data, samples)
    if longitudes is not None:  # Goswami Fig. 3: residuals along the shells' longitudes
        block["longitude"] = _binned(longitudes, series)
    return block


def _joint_axis(joint_type: str, spec) -> str:
    """The x axis of a joint's panel: an angle for a revolute joint, a position for a prismatic one."""
    kind = joint_kind(joint_type)
    return f"joint {'angle' if kind == 'angle' else 'position'} ({spec.robot.units.of(kind)})"


def _longitudes(kinematics, device, problem, theta, data, samples) -> np.ndarray | None:
    """Longitude (deg) of each sample's target around the fixed point its reading is taken from (a ball-bar's
    pivot), from the calibrated model; None for an instrument with no such point."""
    values = problem.parameters.values(theta)
    out = np.empty(len(samples))
    for i, sample in enumerate(samples):
        key = data.keys[sample]
        centre = device.centre(key, values)
        if centre is None:
            return None
        position = kinematics.target_poses(device.target(key), data.q[sample][None], theta[: problem.n_robot])[0, :3, 3]
        out[i] = math.degrees(math.atan2(position[1] - centre[1], position[0] - centre[0]))
    return out


def _per_key(residuals, chosen: np.ndarray, before: np.ndarray, after: np.ndarray) -> list[dict]:
    """RMS per key with the design model (before calibration) and after it."""
    keys = [residuals.key[i] for i in np.flatnonzero(chosen)]
    out = []
    for key in dict.fromkeys(keys):
        inside = np.array([k == key for k in keys])
        name = "/".join(str(k) for k in key if k)
        rms = lambda v: float(np.sqrt(np.mean(v[inside] ** 2)))  # noqa: E731
        out.append({"key": name, "n": int(inside.sum()), "rms_before": rms(before), "rms_after": rms(after)})
    return out


def _histogram(values: np.ndarray, sigma: np.ndarray, bins: int = 25) -> dict:
    """Counts of the residuals and the counts the noise model's Gaussian (mean 0, its RMS sigma) expects."""
    noise = float(np.sqrt(np.mean(sigma**2)))
    limit = max(4 * noise, float(np.max(np.abs(values))))
    edges = np.linspace(-limit, limit, bins + 1)
    counts, _ = np.histogram(values, edges)
    cdf = np.array([0.5 * (1 + math.erf(e / (noise * math.sqrt(2)))) for e in edges])
    return {
        "edges": edges.tolist(),
        "counts": counts.tolist(),
        "expected": (len(values) * np.diff(cdf)).tolist(),
        "noise_sigma": noise,
        "mean": float(np.mean(values)),
        "std": float(np.std(values)),
    }
