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
        q = ik.solve_from_starts(kinematics, np.concatenate([points, axis], axis=1), frame=pairing.sphere, seed=seed)
        ok = ~np.isnan(q).any(axis=1)
        reachable = np.zeros(len(points), dtype=bool)
        reachable[ok] = device.visible(key, kinematics.target_poses(pairing.sphere, q[ok]))
        dropped = {f"{pairing.pivot}-{pairing.sphere} unreachable": int((~reachable).sum())} if (~reachable).any() else {}
        plans.append(Plan(tuple([key] * int(reachable.sum())), q[reachable], dropped))
    return Plan.join(plans)
