"""Lumped masses on links: the gravity torques of compliance (Stone's model leaves
gravity out; the elastostatic form is in effects/measurement.py)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LumpedMass:
    """A point mass riding on a link."""

    link: int
    mass: float  # kg
    centre: tuple[float, float, float]  # mm, in the link frame
