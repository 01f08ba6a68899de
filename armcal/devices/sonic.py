"""Sonic digitizer: slant ranges from a sparker to each microphone, Stone 6.3.

Readings are either the slant ranges themselves (``s_A, s_B, ...``) or the
target's position triangulated by the instrument in the sensor frame
(``x, y, z``, (6.1)-(6.6), general non-right triangle). The sensor frame has its
origin at microphone C, y towards B and z out of the plane of A, B, C.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.devices.base import Channel, DeviceModel, Key, transform_point
from armcal.kinematics.compiler import pose_from_symbols
from armcal.kinematics.params import ParameterSet, parameter_entry, pose_entries
from armcal.devices.sound import ROD_NEAR
from armcal.kinematics.transforms import xyz_zyx
from armcal.errors import UserError
from armcal.spec.device import AUTO, SonicDigitizer

PRIMARY = ("A", "B", "C")  # microphones used to triangulate (s_1, s_2, s_3 of 6.1-6.6)


def triangulate(s1, s2, s3, w_ab, w_bc, w_ac):
    """Target (x, y, z) in the sensor frame from slant ranges to A, B, C, Stone (6.1)-(6.6).

    Works on numpy arrays and CasADi symbols alike. cos(theta) (6.5) is the angle
    at C between CA and CB; r (6.4) the projection of the target on CA.
    """
    sqrt = ca.sqrt if isinstance(s1, (ca.SX, ca.MX)) else np.sqrt
    cos_t = (w_ac**2 + w_bc**2 - w_ab**2) / (2 * w_ac * w_bc)  # (6.5)
    sin_t = sqrt(1 - cos_t**2)  # (6.6), as tan(theta) = sin/cos
    r = (w_ac**2 + s3**2 - s1**2) / (2 * w_ac)  # (6.4)
    y = (w_bc**2 + s3**2 - s2**2) / (2 * w_bc)  # (6.2)
    x = (r - y * cos_t) / sin_t  # (6.1), rearranged
    z_squared = s3**2 - x**2 - y**2  # (6.3)
    z = sqrt(ca.fmax(z_squared, 0) if isinstance(s1, (ca.SX, ca.MX)) else np.maximum(z_squared, 0))
    return x, y, z


def microphone_distances(microphones: dict[str, np.ndarray]) -> tuple[float, float, float]:
    """w_AB, w_BC, w_AC from microphone positions."""
    a, b, c = (np.asarray(microphones[m], dtype=float) for m in PRIMARY)
    return float(np.linalg.norm(a - b)), float(np.linalg.norm(b - c)), float(np.linalg.norm(a - c))


class SonicModel(DeviceModel):
    """Slant ranges scale * |P x - mic| (P = robot base in the sensor frame, 4.48), or their triangulation."""

    type = "sonic_digitizer"

    def __init__(self, spec: SonicDigitizer, averaging: int = 1, mode: str = "ranges"):
        if mode not in ("ranges", "points"):
            raise ValueError(f"mode must be 'ranges' or 'points', not {mode!r}")
        self.spec = spec
        self.mode = mode
        self.averaging = averaging
        self.microphones = tuple(spec.microphones)
        entries = pose_entries("robot_base", spec.robot_base)
        for name, point in spec.microphones.items():
            entries += pose_entries(f"mic.{name}", point, ("x", "y", "z"))
        entries.append(parameter_entry("sonic.scale", "scale", spec.scale))
        self.parameters = ParameterSet(tuple(entries))
        nominal = dict(zip(self.parameters.names, self.parameters.nominal))
        self.nominal_microphones = {m: np.array([nominal[f"mic.{m}.{c}"] for c in "xyz"]) for m in self.microphones}

    def channels(self, key: Key) -> tuple[Channel, ...]:
        if self.mode == "points":
            return tuple(Channel(c, "length") for c in "xyz")
        return tuple(Channel(f"s_{m}", "length") for m in self.microphones)

    def target(self, key: Key) -> str | None:
        return key[0]

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        point = transform_point(pose_from_symbols(sym, "robot_base"), pose[:3, 3])
        ranges = {
            m: sym["sonic.scale"] * ca.norm_2(point - ca.vertcat(*(sym[f"mic.{m}.{c}"] for c in "xyz")))
            for m in self.microphones
        }
        if self.mode == "ranges":
            return ca.vertcat(*ranges.values())
        w = microphone_distances(self.nominal_microphones)  # the instrument triangulates with its nominal geometry
        return ca.vertcat(*triangulate(*(ranges[m] for m in PRIMARY), *w))

    def range_sigma(self, ranges: np.ndarray) -> np.ndarray:
        """sigma = a * range + b (7.9), reduced by averaging N_avg readings.

        With calibration rods, a compensated range L = f s also carries the rod
        ratio's noise (E.1): sigma_f / f = sqrt(sigma(s_near)^2 + sigma(s_far)^2) / D.
        With ``noise: auto``, 1 mm: each group's sigma is estimated from the data.
        """
        noise = self.spec.noise
        if noise == AUTO:
            return np.ones(np.shape(ranges))
        sigma = (noise.a * ranges + noise.b) / np.sqrt(self.averaging)
        if self.spec.calibration_rods:
            rod = self.spec.calibration_rods[0].length
            near, far = (noise.a * d + noise.b for d in (ROD_NEAR, ROD_NEAR + rod))
            relative = np.hypot(near, far) / np.sqrt(self.averaging) / rod
            sigma = np.hypot(sigma, relative * ranges)
        return sigma

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        readings = np.atleast_2d(readings)
        if self.mode == "ranges":
            return self.range_sigma(readings)
        return self._point_sigma(readings)

    def noise_kind(self, field: str) -> str:
        return "range" if self.mode == "ranges" else "point"

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        keys = {"target": key[0]}
        if self.mode == "ranges":
            keys["microphone"] = channel.removeprefix("s_")
        elif "microphone" in self.spec.noise_groups:
            raise UserError("noise_groups: microphone needs the slant ranges; these data hold triangulated points")
        return keys

    def _point_sigma(self, points: np.ndarray) -> np.ndarray:
        """Per-coordinate sigma of triangulated points, propagating the range noise (correlations dropped)."""
        w = microphone_distances(self.nominal_microphones)
        s = ca.SX.sym("s", 3)
        jacobian = ca.Function("J", [s], [ca.jacobian(ca.vertcat(*triangulate(s[0], s[1], s[2], *w)), s)])
        mics = np.array([self.nominal_microphones[m] for m in PRIMARY])
        ranges = np.linalg.norm(points[:, None, :] - mics[None, :, :], axis=2)  # (N, 3)
        sigma_s = self.range_sigma(ranges)
        J = np.array(jacobian.map(len(points))(ranges.T)).T.reshape(len(points), 3, 3).transpose(0, 2, 1)
        return np.sqrt(np.einsum("nij,nj->ni", J**2, sigma_s**2))

    def prepare(self, measurements):
        """Raw slant ranges -> compensated ranges (App. E, when rod ranges were recorded) -> points if fitted so."""
        from dataclasses import replace

        from armcal.devices.sound import compensate, rod_ratio

        readings = dict(measurements.readings)
        ranges = {m: readings[f"s_{m}"] for m in self.microphones if f"s_{m}" in readings}
        if not ranges:
            return measurements  # the file holds triangulated points already
        rods = {
            rod.microphone: rod_ratio(measurements.extras[f"rod_{rod.microphone}_1"], measurements.extras[f"rod_{rod.microphone}_2"], rod.length)
            for rod in self.spec.calibration_rods
            if f"rod_{rod.microphone}_1" in measurements.extras
        }
        if rods:
            ranges = compensate(ranges, rods, self.nominal_microphones)
        if self.mode == "points":
            w = microphone_distances(self.nominal_microphones)
            readings = dict(zip("xyz", triangulate(*(ranges[m] for m in PRIMARY), *w)))
        else:
            readings.update({f"s_{m}": value for m, value in ranges.items()})
            for m in self.microphones:  # a microphone without a column (s_D is optional): no readings
                readings.setdefault(f"s_{m}", np.full(len(measurements.q), np.nan))
        return replace(measurements, readings=readings)

    def measurable(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Ranges within the instrument's range limits (ranges mode; points are always readable)."""
        if self.mode != "ranges":
            return np.ones(len(readings), dtype=bool)
        low, high = self.spec.range_limits
        return np.all(((readings >= low) & (readings <= high)) | np.isnan(readings), axis=1)

    def visible(self, key: Key, poses: np.ndarray, pd: np.ndarray | None = None) -> np.ndarray:
        """In front of the microphone plane (z > 0 in the sensor frame) and within the range limits."""
        ranges_model = SonicModel(self.spec, self.averaging, mode="ranges") if self.mode != "ranges" else self
        points = ranges_model._sensor_points(poses, pd)
        return (points[:, 2] > 0) & ranges_model.measurable(key, ranges_model.evaluate(key, poses, pd))

    def _sensor_points(self, poses: np.ndarray, pd: np.ndarray | None) -> np.ndarray:
        values = self.parameters.values(self.parameters.nominal if pd is None else pd)
        base = xyz_zyx(*(values[f"robot_base.{f}"] for f in ("x", "y", "z", "rz", "ry", "rx")))
        return np.einsum("ij,nj->ni", base[:3, :3], np.asarray(poses)[:, :3, 3]) + base[:3, 3]
