"""Stone's feature-based S-Model identification (4.3): planes, circles and lines of the joints.

Each joint i is swept with joints 1..i-1 at the signature while the sensor
measures target i (on link i). A revolute joint's target traces a circle: its
plane-of-rotation (eigenvector method (4.15)-(4.18), or repeated linear least
squares (4.19)-(4.32)) and centre-of-rotation (repeated least squares
(4.33)-(4.43)) give the joint axis; a prismatic joint's target traces a line
(principal axis, (4.44)-(4.47)). The axes define the S-Model frames (4.48)-(4.50),
from which the S-Model and pseudo-DH parameters follow ((4.51)-(4.57), 4.3.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armcal.kinematics.smodel import DHRow, PseudoDH, pseudo_dh_from_frames

CONVERGED = 1e-13


@dataclass(frozen=True)
class JointFeatures:
    """The features of one joint and the accuracy Stone's formulas give them (6.11)-(6.13)."""

    joint: int  # 1-based
    revolute: bool
    axis: np.ndarray  # unit normal of the plane-of-rotation / direction of the line, positive joint sense
    centre: np.ndarray  # centre-of-rotation / a point on the line-of-translation
    radius: float  # nominal target radius (0 for prismatic)
    first: np.ndarray  # the first measured target position (sets the frame's x axis, 4.50)
    normal_residuals: np.ndarray  # distances to the plane (or line)
    radial_residuals: np.ndarray  # distances to the circle in the plane
    range_deg: float  # X: the swept range of motion
    sigma_plane: float  # rad, (6.11) / (6.12)
    sigma_centre: float  # mm, (6.13)


def plane_by_eigenvector(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit normal (A, B, C) and D of the plane minimising perpendicular distances, (4.15)-(4.18)."""
    mean = points.mean(axis=0)
    centred = points - mean
    values, vectors = np.linalg.eigh(centred.T @ centred)  # (4.18)
    normal = vectors[:, 0]  # the smallest eigenvalue's eigenvector
    return normal, -float(normal @ mean)  # (4.17)


def _frame_with_z(z: np.ndarray) -> np.ndarray:
    """Rows n, o, a of a rotation whose z axis is ``z`` (n and o arbitrary, 4.34)."""
    helper = np.eye(3)[np.argmin(np.abs(z))]
    n = np.cross(helper, z)
    n /= np.linalg.norm(n)
    return np.array([n, np.cross(z, n), z])


def plane_by_repeated_least_squares(points: np.ndarray, max_iterations: int = 20) -> tuple[np.ndarray, float]:
    """Plane by repeated regression z = E x + F y + G in rotated frames, (4.19)-(4.32).

    The first frame C_0 comes from three measurements far apart in the sweep
    (4.26)-(4.29); each later one has its z axis along the previous normal.
    """
    k, l, m = 0, len(points) // 2, len(points) - 1
    n = points[l] - points[k]
    a = np.cross(points[l] - points[k], points[m] - points[k])  # (4.28)
    n, a = n / np.linalg.norm(n), a / np.linalg.norm(a)  # (4.27)
    R = np.array([n, np.cross(a, n), a])  # (4.26), (4.29)
    normal = a
    for _ in range(max_iterations):
        local = points @ R.T  # (4.30)
        Phi = np.c_[local[:, 0], local[:, 1], np.ones(len(points))]  # (4.20), (4.24)
        E, F, G = np.linalg.lstsq(Phi, local[:, 2], rcond=None)[0]  # (4.23)
        updated = R.T @ np.array([-E, -F, 1.0])
        updated /= np.linalg.norm(updated)  # (4.31), (4.32)
        done = np.linalg.norm(updated - normal) < CONVERGED
        normal = updated
        R = _frame_with_z(normal)
        if done:
            break
    return normal, -float(normal @ points.mean(axis=0))


def circle_centre(points: np.ndarray, normal: np.ndarray, max_iterations: int = 50) -> tuple[np.ndarray, float]:
    """Centre and radius of the circle through the points projected on their plane, (4.33)-(4.43)."""
    R = _frame_with_z(normal)  # (4.34)
    local = points @ R.T  # (4.35)
    z_centre = float(local[:, 2].mean())  # (4.36): the plane's offset along its normal
    g = h = 0.0
    for _ in range(max_iterations):
        x, y = local[:, 0] - g, local[:, 1] - h  # (4.41), (4.42)
        Phi = np.c_[x, y, np.ones(len(points))]  # (4.38)
        A, B, C = np.linalg.lstsq(Phi, x**2 + y**2, rcond=None)[0]  # (4.37), (4.40)
        g, h = g + A / 2, h + B / 2
        if np.hypot(A, B) < CONVERGED * max(1.0, abs(C)):
            break
    centre = R.T @ np.array([g, h, z_centre])  # (4.43)
    radius = float(np.mean(np.hypot(local[:, 0] - g, local[:, 1] - h)))
    return centre, radius


def line_of_translation(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Direction (positive travel) and mean point of the line through the points, (4.44)-(4.47)."""
    mean = points.mean(axis=0)  # (4.45)
    values, vectors = np.linalg.eigh(np.cov((points - mean).T))
    direction = vectors[:, -1]  # the largest eigenvalue's eigenvector (4.46)
    if direction @ (points[-1] - points[0]) < 0:  # (4.47)
        direction = -direction
    return direction, mean


def feature_accuracy(sigma_n: float, sigma_r: float, radius: float, count: int, range_deg: float) -> tuple[float, float]:
    """sigma of the plane's orientation (rad) and of the centre (mm), Stone (6.11)-(6.13)."""
    if range_deg >= 360.0:
        plane = np.sqrt(2.0 * sigma_n**2 / (radius**2 * count))  # (6.11)
    else:
        plane = np.sqrt(sigma_n**2 / (radius**2 * count * (0.00244 * range_deg - 0.344)))  # (6.12)
    centre = np.sqrt(sigma_r**2 / (count * (0.00229 * range_deg - 0.313)))  # (6.13)
    return float(plane), float(centre)


def joint_features(joint: int, revolute: bool, points: np.ndarray, q: np.ndarray, plane: str = "eigenvector") -> JointFeatures:
    """Features of one joint from its target's measured positions, ordered by joint value."""
    order = np.argsort(q)
    points, q = points[order], q[order]
    range_deg = float(np.degrees(q[-1] - q[0])) if revolute else 0.0
    if not revolute:
        direction, mean = line_of_translation(points)
        along = (points - mean) @ direction
        off = points - mean - np.outer(along, direction)
        distance = np.linalg.norm(off, axis=1)
        return JointFeatures(joint, False, direction, mean, 0.0, points[0], distance, np.zeros(len(points)), 0.0, np.nan, np.nan)
    fit_plane = plane_by_eigenvector if plane == "eigenvector" else plane_by_repeated_least_squares
    normal, D = fit_plane(points)
    centre, radius = circle_centre(points, normal)
    sense = np.sum(np.cross(points[:-1] - centre, points[1:] - centre), axis=0)
    if normal @ sense < 0:  # the axis points along positive rotation (4.3.3)
        normal, D = -normal, -D
    normal_residuals = points @ normal + D
    in_plane = points - centre - np.outer((points - centre) @ normal, normal)
    radial_residuals = np.linalg.norm(in_plane, axis=1) - radius
    sigma_plane, sigma_centre = feature_accuracy(
        float(np.std(normal_residuals, ddof=3)), float(np.std(radial_residuals, ddof=3)), radius, len(points), range_deg
    )
    return JointFeatures(
        joint, True, normal, centre, radius, points[0], normal_residuals, radial_residuals, range_deg, sigma_plane, sigma_centre
    )


def frame(feature: JointFeatures, turn: float = 0.0) -> np.ndarray:
    """S-Model frame on a joint's axis (4.49): z the axis, x towards the first target position (4.50)
    turned by ``turn`` about the axis: towards where the target is at the signature configuration."""
    z = feature.axis
    if feature.revolute:
        x = feature.first - feature.centre
        x -= (x @ z) * z
        x = x * np.cos(turn) + np.cross(z, x) * np.sin(turn)
    else:
        x = _frame_with_z(z)[0]
    x /= np.linalg.norm(x)
    T = np.eye(4)
    T[:3, 0], T[:3, 1], T[:3, 2], T[:3, 3] = x, np.cross(z, x), z, feature.centre
    return T


@dataclass(frozen=True)
class FeatureIdentification:
    features: tuple[JointFeatures, ...]
    pseudo_dh: PseudoDH  # in the sensor frame: base = S_0 seen by the sensor


def identify(
    sweeps: list[tuple[np.ndarray, np.ndarray]],
    joint_types: tuple[str, ...],
    q_signature: np.ndarray,
    reference: list[DHRow] | None = None,
    plane: str = "eigenvector",
    last_azimuth: float = 0.0,
) -> FeatureIdentification:
    """From each joint's sweep (target positions (m, 3) in the sensor frame, joint values (m,)), Stone 4.3.

    ``last_azimuth``: the design's angle of the last target about joint n's axis, atan2(y, x) in
    link n's frame; the last frame's x axis is set so that the target keeps it.
    """
    features = tuple(
        joint_features(i + 1, kind == "revolute", points, q, plane)
        for i, ((points, q), kind) in enumerate(zip(sweeps, joint_types))
    )
    # S_0 .. S_{n-1} (4.48); x towards the target at the signature, so that the last frame (whose
    # x no later axis fixes) turns with joint n as the design's does: its zero is the signature's
    turns = [q_signature[i] - q[0] for i, (_, q) in enumerate(sweeps)]
    turns[-1] -= last_azimuth
    frames = [frame(f, turn) for f, turn in zip(features, turns)]
    return FeatureIdentification(features, pseudo_dh_from_frames(frames, joint_types, q_signature, reference))
