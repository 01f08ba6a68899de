"""A measuring plan: which key (target, pivot/sphere, station) is read at which joint configuration."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armcal.devices.base import Key


@dataclass(frozen=True)
class Plan:
    """Planned samples, in measuring order, and how many planned poses were dropped and why."""

    keys: tuple[Key, ...]
    q: np.ndarray  # (N, n) joint readings, mm / rad
    dropped: dict[str, int] = field(default_factory=dict)
    where: dict[str, list[str]] = field(default_factory=dict)  # per reason, the planned points dropped (e.g. "lat 20: lon 0, 30")

    def __len__(self) -> int:
        return len(self.keys)

    @staticmethod
    def join(plans: list["Plan"]) -> "Plan":
        """Concatenate plans, adding up their drop counts."""
        dropped: dict[str, int] = {}
        where: dict[str, list[str]] = {}
        for plan in plans:
            for reason, count in plan.dropped.items():
                dropped[reason] = dropped.get(reason, 0) + count
            for reason, points in plan.where.items():
                where[reason] = where.get(reason, []) + points
        q = np.concatenate([p.q for p in plans]) if plans else np.zeros((0, 0))
        return Plan(tuple(k for p in plans for k in p.keys), q, dropped, where)


def sweep(low: float, high: float, count: int, revolute: bool) -> np.ndarray:
    """``count`` joint values spread uniformly over a joint's limits (one turn at most for revolute joints)."""
    span = high - low
    if revolute and span >= 2 * np.pi:
        centre = (low + high) / 2
        return centre - np.pi + 2 * np.pi * np.arange(count) / count
    margin = 0.01 * span
    return np.linspace(low + margin, high - margin, count)
