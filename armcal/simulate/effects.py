"""Hidden effects of a simulated robot and instrument, in numpy (the vocabulary of ARCHITECTURE.md).

Joint-side effects change the true joint angle seen by the chain; thermal drift
scales the chain's lengths; instrument-side effects change the readings or the
instrument's true geometry. Amplitudes are the effect parameters' values.
"""

from __future__ import annotations

import numpy as np

from armcal.spec import sections as fx

GRAVITY = np.array([0.0, 0.0, -9.81])  # m/s^2 in the robot base frame (z up)
DEFAULT_LINK_MASS = 5.0  # kg at each link frame's origin, when an effect names no masses


def joint_deviation(effects: list, Q: np.ndarray, extras: dict, frames: np.ndarray) -> np.ndarray:
    """True minus read joint values (N, n) from joint-side effects; frames (N, n+1, 4, 4) for gravity."""
    delta = np.zeros_like(Q)
    for effect in effects:
        if not isinstance(effect, fx.JointEffect):
            continue
        j = effect.joint - 1
        if isinstance(effect, fx.EncoderScale):
            delta[:, j] += effect.scale.value * Q[:, j]
        elif isinstance(effect, fx.GearHarmonic):
            phase = effect.order * effect.ratio * Q[:, j]
            delta[:, j] += effect.sin.value * np.sin(phase) + effect.cos.value * np.cos(phase)
        elif isinstance(effect, fx.Backlash):
            delta[:, j] += effect.half_width.value * extras["dir"][:, j]
        elif isinstance(effect, fx.JointCompliance):
            delta[:, j] += effect.compliance * gravity_torque(frames, effect.joint, effect.masses)
    return delta


def gravity_torque(frames: np.ndarray, joint: int, masses: list) -> np.ndarray:
    """Torque (N m) of gravity about joint ``joint``'s axis (z of F_{joint-1}) from lumped link masses."""
    n = frames.shape[1] - 1
    masses = masses or [fx.LinkMass(link=k, mass=DEFAULT_LINK_MASS) for k in range(joint, n + 1)]
    axis = frames[:, joint - 1, :3, 2]
    origin = frames[:, joint - 1, :3, 3]
    torque = np.zeros(len(frames))
    for mass in masses:
        if mass.link < joint:
            continue
        centre = np.einsum("nij,j->ni", frames[:, mass.link], [mass.x, mass.y, mass.z, 1.0])[:, :3]
        lever = (centre - origin) / 1000.0  # m
        torque += np.einsum("ni,ni->n", axis, np.cross(lever, mass.mass * GRAVITY))
    return torque


def length_scale(effects: list, extras: dict, count: int) -> np.ndarray:
    """Factor (N,) on every length of the chain from thermal drift."""
    scale = np.ones(count)
    for effect in effects:
        if isinstance(effect, fx.ThermalDrift):
            if effect.source == "temperature":
                scale *= 1.0 + effect.coefficient * (extras["temperature"] - effect.reference_temperature)
            else:
                scale *= 1.0 + effect.coefficient * extras["t"]
    return scale


def needs(effects: list) -> set[str]:
    """Extra data columns the effects need: dir, temperature, t."""
    out = set()
    for effect in effects:
        if isinstance(effect, fx.Backlash):
            out.add("dir")
        if isinstance(effect, fx.ThermalDrift):
            out.add(effect.source if effect.source == "temperature" else "t")
    return out
