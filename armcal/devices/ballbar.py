"""Telescopic ball-bar: centre-to-centre length from a fixed pivot to a sphere on the robot (Goswami).

A key is (pivot, sphere, extension rod or None). The instrument reports its
nominal length plus the LVDT displacement, so a bar whose true length differs
from the nominal by delta reads the distance minus delta: y = |s - p| + L0 - L.
Only lengths within the LVDT travel around the bar's mid-travel length are readable.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.devices.base import Channel, DeviceModel, Key, declared
from armcal.kinematics.params import ParameterSet, parameter_entry, pose_entries
from armcal.spec.device import BallBar


class BallBarModel(DeviceModel):
    type = "ballbar"

    def __init__(self, spec: BallBar):
        self.spec = spec
        entries = []
        for name, point in spec.pivots.items():
            entries += pose_entries(f"pivot.{name}", point, ("x", "y", "z"))
        entries.append(parameter_entry("bar.length", "length", spec.length))
        self.parameters = ParameterSet(tuple(entries))

    def channels(self, key: Key) -> tuple[Channel, ...]:
        return (Channel("length", "length"),)

    def target(self, key: Key) -> str | None:
        return key[1]

    def extension(self, key: Key) -> float:
        """Length of the extension rod of a key (0 without one)."""
        return self.spec.extension_rods[key[2]] if key[2] else 0.0

    def mid_travel_length(self, key: Key) -> float:
        """Nominal centre-to-centre length at mid-travel, with the key's extension rod."""
        return self.spec.length.value + self.extension(key)

    def readings(self, key: Key, pose: ca.SX, sym: dict) -> ca.SX:
        centre = ca.vertcat(*(sym[f"pivot.{key[0]}.{c}"] for c in "xyz"))
        return ca.norm_2(pose[:3, 3] - centre) + self.spec.length.value - sym["bar.length"]

    def noise_sigma(self, key: Key, readings: np.ndarray) -> np.ndarray:
        return np.full(np.shape(np.atleast_2d(readings)), declared(self.spec.noise))

    def noise_keys(self, key: Key, channel: str) -> dict[str, str]:
        pairing = f"{key[0]}-{key[1]}" + (f"+{key[2]}" if key[2] else "")
        return {"target": key[1], "pairing": pairing}

    def measurable(self, key: Key, readings: np.ndarray) -> np.ndarray:
        """Within the LVDT travel: |length - mid-travel length| <= travel / 2."""
        readings = np.atleast_2d(readings)
        return np.abs(readings[:, 0] - self.mid_travel_length(key)) <= self.spec.travel / 2
