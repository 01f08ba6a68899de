"""Goswami's hemispherical shells: a ball-bar around each pivot at mid-travel (Fig. 2, "Data Collection").

For each pivot/sphere pairing, goal points lie at the intersections of
latitude and longitude lines of the hemisphere of radius R (bar length at
mid-travel with its extension rod, unless the procedure gives one) above the
pivot. Each is solved with inverse kinematics of the nominal model, the sphere
at the point and the end effector's z axis halfway between straight down and
the pivot (the bar then clears the fixture and more of the hemisphere is
reachable than facing the pivot squarely); poses that do not converge,
leave the joint limits, or read outside the LVDT travel are dropped.
"""

from __future__ import annotations

import numpy as np

from armcal.devices.ballbar import BallBarModel
from armcal.kinematics import ik
from armcal.kinematics.compiler import KinematicModel
from armcal.procedures.plan import Plan
from armcal.spec.procedure import Shells

SEEDS = 12  # random starts per goal, besides the middle of the limits


def shell_points(centre: np.ndarray, radius: float, latitudes: list[float], longitudes: int) -> np.ndarray:
    """Points (M, 3) on the hemisphere above ``centre``: each latitude ring, ``longitudes`` points per ring."""
    lat = np.repeat(np.asarray(latitudes, dtype=float), longitudes)
    lon = np.tile(2 * np.pi * np.arange(longitudes) / longitudes, len(latitudes))
    ring = np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=1)
    return centre + radius * ring


def plan_shells(procedure: Shells, kinematics: KinematicModel, device: BallBarModel, seed: int = 0) -> Plan:
    values = device.parameters.values(device.parameters.nominal)
    plans = []
    for pairing in procedure.pairings:
        key = (pairing.pivot, pairing.sphere, procedure.extension)
        centre = np.array([values[f"pivot.{pairing.pivot}.{c}"] for c in "xyz"])
        radius = procedure.radius or device.mid_travel_length(key)
        points = shell_points(centre, radius, procedure.latitudes, procedure.longitudes)
        inward = (centre - points) / radius
        axis = inward + [0.0, 0.0, -1.0]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        q = _solve(kinematics, pairing.sphere, np.concatenate([points, axis], axis=1), seed)
        ok = ~np.isnan(q).any(axis=1)
        reachable = np.zeros(len(points), dtype=bool)
        reachable[ok] = device.visible(key, kinematics.target_poses(pairing.sphere, q[ok]))
        dropped = {f"{pairing.pivot}-{pairing.sphere} unreachable": int((~reachable).sum())} if (~reachable).any() else {}
        plans.append(Plan(tuple([key] * int(reachable.sum())), q[reachable], dropped))
    return Plan.join(plans)


def _solve(kinematics: KinematicModel, frame: str, goals: np.ndarray, seed: int) -> np.ndarray:
    """Configurations (M, n) for M goals; NaN rows where no start reached the goal within the limits.

    Every goal is tried from the middle of the limits and SEEDS random starts; of
    the solutions within limits, the one closest to the middle is kept, so that
    neighbouring points share one arm configuration.
    """
    rng = np.random.default_rng(seed)
    low, high = kinematics.limits[:, 0], kinematics.limits[:, 1]
    middle = (low + high) / 2
    starts = np.vstack([middle, rng.uniform(low, high, (SEEDS, kinematics.dof))])
    count = len(goals)
    result = ik.solve(
        kinematics,
        np.repeat(goals, len(starts), axis=0),
        np.tile(starts, (count, 1)),
        frame=frame,
        tol_position=1e-4,
        tol_rotation=1e-6,
    )
    Q = _wrap_into_limits(kinematics, result.q)
    good = result.converged & ik.within_limits(kinematics, Q)
    distance = np.where(good, np.linalg.norm((Q - middle) / (high - low), axis=1), np.inf).reshape(count, len(starts))
    best = distance.argmin(axis=1)
    chosen = Q.reshape(count, len(starts), -1)[np.arange(count), best]
    chosen[~np.isfinite(distance.min(axis=1))] = np.nan
    return chosen


def _wrap_into_limits(kinematics: KinematicModel, Q: np.ndarray) -> np.ndarray:
    """Revolute joint values shifted by whole turns into their limits where possible."""
    Q = Q.copy()
    for i, kind in enumerate(kinematics.joint_types):
        if kind == "revolute":
            low = kinematics.limits[i, 0]
            Q[:, i] = low + np.mod(Q[:, i] - low, 2 * np.pi)
    return Q
