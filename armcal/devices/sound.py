"""Speed of sound for the sonic digitizer: the physics and Stone's compensation (App. E).

The instrument converts a time of flight t* to a range with its internal speed
S*: s = S* t*. With the speed varying linearly along the line of sight from v_T
at the target to v_M at the microphone (assumption B-3), dx/dt = v_T + mu x
(E.2), so a true distance L takes t* = ln(1 + mu L / v_T) / mu and, conversely,
L = v_T (exp(mu t*) - 1) / mu (E.3) with mu = (v_M - v_T) / L (E.4).
"""

from __future__ import annotations

import numpy as np

ZERO_CELSIUS_SPEED = 331_450.0  # mm/s in dry air at 0 degC
ROD_NEAR = 300.0  # mm from a calibration rod's microphone to its near sparker


def speed_of_sound(temperature_c: np.ndarray | float) -> np.ndarray:
    """Speed of sound in air (mm/s) at a temperature in degC (ideal gas, ~0.6 m/s per degC)."""
    return ZERO_CELSIUS_SPEED * np.sqrt(1.0 + np.asarray(temperature_c, dtype=float) / 273.15)


def raw_range(distance: np.ndarray, v_target: np.ndarray, v_microphone: np.ndarray, internal_speed: float) -> np.ndarray:
    """What the instrument reads for a true distance: S* t*, with t* from integrating (E.2)."""
    distance, v_target, v_microphone = np.broadcast_arrays(distance, v_target, v_microphone)
    mu = (v_microphone - v_target) / distance
    with np.errstate(divide="ignore", invalid="ignore"):
        time = np.where(np.abs(mu) > 1e-12, np.log1p(mu * distance / v_target) / mu, distance / v_target)
    return internal_speed * time


def rod_ratio(near: np.ndarray, far: np.ndarray, rod_length: float) -> np.ndarray:
    """f = D / (s_far - s_near): true over internal speed of sound at a rod's microphone (E.1)."""
    return rod_length / (np.asarray(far) - np.asarray(near))


def true_range(raw: np.ndarray, f_target: np.ndarray, f_microphone: np.ndarray, iterations: int = 50) -> np.ndarray:
    """Solve (E.3)-(E.4) for L by Jacobi (fixed-point) iteration, speeds as ratios f = v / S*.

    With t* = s / S*, (E.3) reads L = f_T s (exp(mu' s) - 1) / (mu' s) with
    mu' = (f_M - f_T) / L; the iteration starts from L = f_T s.
    """
    raw, f_target, f_microphone = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (raw, f_target, f_microphone)))
    length = f_target * raw
    for _ in range(iterations):
        x = (f_microphone - f_target) / length * raw  # mu' s
        factor = np.where(np.abs(x) > 1e-12, np.expm1(x) / np.where(x == 0, 1.0, x), 1.0 + x / 2)
        updated = f_target * raw * factor
        if np.allclose(updated, length, rtol=0.0, atol=1e-9):
            return updated
        length = updated
    return length


def vertical(microphones: dict[str, np.ndarray]) -> np.ndarray:
    """Unit 'up' in the sensor frame: in the sensor plane, across A-C (which is level) towards B (6.3.1)."""
    a, b, c = (np.asarray(microphones[m], dtype=float) for m in ("A", "B", "C"))
    level = (a - c) / np.linalg.norm(a - c)
    up = (b - c) - np.dot(b - c, level) * level
    return up / np.linalg.norm(up)


def ratio_at(height: np.ndarray, heights: tuple[float, float], ratios: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Speed ratio linearly interpolated in height between two rods (B-3)."""
    (h1, h2), (f1, f2) = heights, ratios
    return f1 + (np.asarray(height) - h1) * (f2 - f1) / (h2 - h1)


def compensate(
    raw: dict[str, np.ndarray],
    rods: dict[str, np.ndarray],
    microphones: dict[str, np.ndarray],
) -> dict[str, np.ndarray]:
    """Stone's slant range compensation (App. E.2): raw ranges -> true ranges per microphone.

    ``raw``: readings per primary microphone (A, B, C); ``rods``: speed ratio f per
    rod microphone (E.1), one or two of them; ``microphones``: nominal positions.
    Overall correction by the mean ratio (E.5) gives a first triangulation whose
    height sets the ratio at the target; each range is then solved from (E.3).
    """
    from armcal.devices.sonic import PRIMARY, microphone_distances, triangulate

    up = vertical(microphones)
    names = list(rods)
    if len(names) == 1:
        names = names * 2
    heights = tuple(float(np.dot(microphones[m], up)) for m in names)
    ratios = tuple(rods[m] for m in names)
    if heights[0] == heights[1]:
        heights = (heights[0], heights[0] + 1.0)  # one level: a uniform ratio
    f_average = (ratios[0] + ratios[1]) / 2  # (E.5)
    w = microphone_distances(microphones)
    first = np.stack(triangulate(*(f_average * raw[m] for m in PRIMARY), *w), axis=-1)
    f_target = ratio_at(first @ up, heights, ratios)
    return {
        m: true_range(raw[m], f_target, ratio_at(float(np.dot(microphones[m], up)), heights, ratios)) for m in raw
    }
