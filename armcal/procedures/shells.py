"""Goswami's hemispherical shells: a ball-bar around each pivot at mid-travel (Fig. 2, "Data Collection").

For each pivot/sphere pairing, goal points lie at the intersections of
latitude and longitude lines of the hemisphere of radius R (bar length at
mid-travel with its extension rod, unless the procedure gives one) above the
pivot. Each is solved with inverse kinematics of the nominal model, the sphere
at the point and the end effector's z axis halfway between straight down and
the pivot (the bar then clears the fixture and more of the hemisphere is
reachable than facing the pivot squarely; an arm that holds that axis at fewer than half the points of a shell,
one of fewer than six axes or a wrist that cannot turn the sphere's frame so, is sent to the other points alone:
the reading is the sphere centre's distance from the pivot whatever its axis); poses that do not converge,
leave the joint limits, or read outside the LVDT travel are dropped, each counted
under its reason (DROP_REASONS) with the latitude and longitude of the point.
"""

from __future__ import annotations

import numpy as np

from armcal.devices.base import DeviceModel
from armcal.kinematics import ik
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import on_sphere
from armcal.procedures.plan import Plan
from armcal.spec.procedure import Shells
from armcal.support.units import from_internal

REACH_SAMPLES = 4096  # random configurations that measure how far the sphere gets from the base

# why a shell point is dropped: the reason's words in the plan, and the spec keys that decide it
DROP_REASONS = {
    "pivot out of reach": "device.pivots (move the chuck nearer the robot), device.length / procedure.radius",
    "beyond the arm's reach": "procedure.latitudes, device.pivots, device.length / procedure.radius",
    "no inverse kinematics": "the sphere's orientation there (robot.targets, its link), procedure.latitudes",
    "joint limit": "robot.joints[].limits (the joints named), procedure.latitudes / longitudes",
    "bar travel": "device.travel, device.length (the reading must stay within travel/2 of mid-travel)",
}


def shell_points(centre: np.ndarray, radius: float, latitudes: list[float], longitudes: int) -> np.ndarray:
    """Points (M, 3) on the hemisphere above ``centre``: each latitude ring, ``longitudes`` points per ring."""
    lat = np.repeat(np.asarray(latitudes, dtype=float), longitudes)
    lon = np.tile(2 * np.pi * np.arange(longitudes) / longitudes, len(latitudes))
    return on_sphere(centre, radius, lat, lon)


def reach(kinematics: KinematicModel, sphere: str, seed: int = 0) -> tuple[np.ndarray, float]:
    """The base origin and the farthest the sphere gets from it over random configurations within the limits."""
    rng = np.random.default_rng(seed)
    Q = rng.uniform(kinematics.limits[:, 0], kinematics.limits[:, 1], (REACH_SAMPLES, kinematics.dof))
    origin = kinematics.link_frames(np.mean(kinematics.limits, axis=1))[0][:3, 3]
    points = kinematics.target_poses(sphere, Q)[:, :3, 3]
    return origin, float(np.max(np.linalg.norm(points - origin, axis=1)))


def plan_shells(procedure: Shells, kinematics: KinematicModel, device: DeviceModel, seed: int = 0, angle_unit: str = "deg") -> Plan:
    values = device.parameters.values(device.parameters.nominal)
    plans = []
    for pairing in procedure.pairings:
        key = (pairing.pivot, pairing.sphere, procedure.extension)
        centre = device.centre(key, values)
        radius = procedure.radius or device.reach(key)
        points = shell_points(centre, radius, procedure.latitudes, procedure.longitudes)
        inward = (centre - points) / radius
        axis = inward + [0.0, 0.0, -1.0]
        axis /= np.linalg.norm(axis, axis=1, keepdims=True)
        q, outcome, blocking = ik.solve_pointing_where_held(kinematics, points, axis, pairing.sphere, seed)
        ok = outcome == ik.SOLVED
        reachable = np.zeros(len(points), dtype=bool)
        reachable[ok] = device.visible(key, kinematics.target_poses(pairing.sphere, q[ok]))
        why = _reasons(kinematics, pairing.sphere, points, centre, radius, outcome, blocking, ok & ~reachable)
        label = f"{pairing.pivot}-{pairing.sphere}"
        dropped, where = {}, {}
        for reason in dict.fromkeys(r for r in why if r):
            rows = [i for i, r in enumerate(why) if r == reason]
            dropped[f"{label}: {reason}"] = len(rows)
            where[f"{label}: {reason}"] = _where(rows, procedure, angle_unit)
        plans.append(Plan(tuple([key] * int(reachable.sum())), q[reachable], dropped, where))
    return Plan.join(plans)


def _reasons(kinematics, sphere, points, centre, radius, outcome, blocking, travel) -> list[str]:
    """Per point: '' (kept) or why it is dropped (a DROP_REASONS key, a joint limit naming the blocking joints)."""
    names = kinematics.joint_names
    unsolved = outcome == ik.UNSOLVED
    far = np.zeros(len(points), dtype=bool)
    pivot_far = False
    if unsolved.any():
        origin, farthest = reach(kinematics, sphere)
        far = np.linalg.norm(points - origin, axis=1) > farthest
        pivot_far = bool(far.all()) and np.linalg.norm(centre - origin) - radius > farthest
    out = []
    for i in range(len(points)):
        if unsolved[i]:
            out.append("pivot out of reach" if pivot_far else "beyond the arm's reach" if far[i] else "no inverse kinematics")
        elif outcome[i] == ik.OUTSIDE_LIMITS:
            out.append(f"joint limit ({', '.join(names[j] for j in blocking[i])})")
        elif travel[i]:
            out.append("bar travel")
        else:
            out.append("")
    return out


def _where(rows: list[int], procedure: Shells, unit: str) -> list[str]:
    """'lat 20: lon 0, 30, 60' per latitude ring of the dropped points, in the spec's angle unit."""
    n = procedure.longitudes
    rings: dict[int, list[int]] = {}
    for i in rows:
        rings.setdefault(i // n, []).append(i % n)
    show = lambda v: f"{from_internal(v, 'angle', unit):g}"  # noqa: E731
    return [f"lat {show(procedure.latitudes[r])}: lon " + ", ".join(show(2 * np.pi * k / n) for k in lons) for r, lons in rings.items()]
