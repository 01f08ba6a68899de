"""Independent simulation of joint coupling and of gravity compliance from a mass layout: a test oracle.

Nothing here imports armcal. It builds on tests/independent_sim.py (standard DH
chains, the tracker of docs/devices/tracker.md) and adds the physics the effects
of docs/effects.md describe, written from the physics rather than from armcal's
formulas:

- coupling: joint ``from`` drives joint ``joint`` too, q_joint -> q_joint + c q_from;
- compliance: joint j deflects by C_j tau_j, tau_j the gravity torque about its
  axis (z of F_(j-1), through o_(j-1)) of real lumped masses: each link k >= j
  carries a mass m_k at a centre s_k of its own frame, g = (0, 0, -9.81) m/s^2
  along -z of the base frame. No mass moment, no regrouping: the masses themselves;
- bending: the links beyond joint j turn about o_(j-1) by the rotation vector
  K_j (I - z z^T) sum_(k >= j) (c_k - o_(j-1)) x m_k g (the moment of their weight
  there, without its part along the axis), an exact rotation (Rodrigues).

    info = write_campaign(folder, "puma560", [coupling(3, 2)], seed=3, sigmas=3.0)

writes folder/spec.yaml (the plain spec of independent_sim, no effect declared),
calibration.csv and validation.csv, and returns the hidden effects with the values
that give each one the RMS signature of ``sigmas`` noise sigmas on its own.
"""

from __future__ import annotations

import pathlib

import numpy as np
from independent_sim import DEG, G, TRACKER, frames, sample_configurations, spec_text, true_geometry, write_csv

# A PUMA-like layout unlike any default (Armstrong, Khatib & Burdick 1986 give masses of this size): a heavy upper
# arm whose centre lies back towards the shoulder and off the link's line, a forearm with its wrist motors, a light
# wrist and a 2.5 kg payload held well off the flange's axis. link: (kg, centre in the link's DH frame, mm)
PUMA_LAYOUT = {
    2: (17.4, (-250.0, 6.0, 40.0)),
    3: (4.8, (10.0, -20.0, 180.0)),
    4: (0.8, (0.0, 15.0, -10.0)),
    5: (0.4, (0.0, 0.0, 10.0)),
    6: (2.5, (70.0, -45.0, 110.0)),
}


def coupling(joint: int, source: int, coefficient: float | None = None) -> dict:
    """Joint ``source`` drives joint ``joint``: q_joint + coefficient q_source (None: scaled to ``sigmas``)."""
    return {"type": "joint_coupling", "joint": joint, "from": source, "value": coefficient}


def compliance(joint: int, layout: dict = PUMA_LAYOUT, value: float | None = None) -> dict:
    """Joint ``joint`` deflects by C tau, tau from ``layout`` (C in rad / (N m); None: scaled to ``sigmas``)."""
    return {"type": "joint_compliance", "joint": joint, "layout": layout, "value": value}


def bending(joint: int, layout: dict = PUMA_LAYOUT, value: float | None = None) -> dict:
    """The links beyond joint ``joint`` tilt by K times the moment of their weight about o_(joint-1) square to the
    axis (K in rad / (N m); None: scaled to ``sigmas``)."""
    return {"type": "joint_bending", "joint": joint, "layout": layout, "value": value}


def gravity_moment(F: np.ndarray, j: int, layout: dict) -> np.ndarray:
    """(N, 3) moment (N m) about o_(j-1) of the weights of links k >= j, base frame."""
    o = F[j - 1][:, :3, 3]
    moment = np.zeros((F.shape[1], 3))
    for k, (mass, centre) in layout.items():
        if k >= j:
            c = F[k][:, :3, 3] + F[k][:, :3, :3] @ np.asarray(centre, float)
            moment += np.cross((c - o) / 1000.0, mass * G)
    return moment


def rotation(phi: np.ndarray) -> np.ndarray:
    """(N, 3, 3) exact rotations by rotation vectors phi (N, 3) (Rodrigues)."""
    angle = np.linalg.norm(phi, axis=1)
    axis = phi / np.where(angle > 0, angle, 1.0)[:, None]
    K = np.zeros((len(phi), 3, 3))
    K[:, 0, 1], K[:, 0, 2], K[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    K -= K.transpose(0, 2, 1)
    s, c = np.sin(angle)[:, None, None], (1 - np.cos(angle))[:, None, None]
    return np.eye(3) + s * K + c * K @ K


def gravity_torque(F: np.ndarray, j: int, layout: dict) -> np.ndarray:
    """tau_j (N m) = z_(j-1) . sum_(k >= j) (c_k - o_(j-1)) x m_k g, c_k = o_k + R_k s_k, at frames F (n+1, N, 4, 4)."""
    z, o = F[j - 1][:, :3, 2], F[j - 1][:, :3, 3]
    tau = np.zeros(len(z))
    for k, (mass, centre) in layout.items():
        if k < j:
            continue
        c = F[k][:, :3, 3] + F[k][:, :3, :3] @ np.asarray(centre, float)
        tau += np.einsum("ij,ij->i", z, np.cross((c - o) / 1000.0, mass * G))
    return tau


def deviations(geom: dict, q: np.ndarray, effects: list[dict]) -> np.ndarray:
    """Joint angles (rad) the true chain sees for readings q (N, n) in rad: every effect's deviation added.
    Torques are taken at the readings' configuration of the true chain (the deflections are micro-radians)."""
    out = q.copy()
    F = None
    for effect in effects:
        j = effect["joint"]
        if effect["type"] == "joint_coupling":
            out[:, j - 1] += effect["value"] * q[:, effect["from"] - 1]
        elif effect["type"] == "joint_compliance":
            F = frames(geom, q) if F is None else F
            out[:, j - 1] += effect["value"] * gravity_torque(F, j, effect["layout"])
    return out


def tracker_readings(geom: dict, q: np.ndarray, effects: list[dict] = ()) -> np.ndarray:
    """The tracker's x, y, z (mm) of the reflector, flattened row by row, for readings q (N, n) in rad."""
    F = frames(geom, deviations(geom, q, list(effects)))
    p = (F[-1] @ np.append(geom["targets"]["smr"], 1.0))[:, :3]
    for effect in sorted((e for e in effects if e["type"] == "joint_bending"), key=lambda e: -e["joint"]):
        j = effect["joint"]  # outermost first: each tilt about its joint where the inner ones leave it
        z, o = F[j - 1][:, :3, 2], F[j - 1][:, :3, 3]
        moment = gravity_moment(F, j, effect["layout"])
        phi = effect["value"] * (moment - z * np.einsum("ni,ni->n", z, moment)[:, None])
        p = o + np.einsum("nij,nj->ni", rotation(phi), p - o)
    p = np.column_stack([p, np.ones(len(p))])
    return (p @ geom["robot_base"].T)[:, :3].ravel()


def write_campaign(folder: pathlib.Path, robot: str, hidden: list[dict], seed: int, sigmas: float = 3.0,
                   counts: tuple[int, int] = (200, 100)) -> dict:
    """Simulate a tracker campaign with the ``hidden`` effects into ``folder``; return {"spec", "effects", "truth"}.

    Each effect whose value is None is scaled so that its own signature (readings with it minus readings without
    it, over the calibration poses) has an RMS of ``sigmas`` noise sigmas; then Gaussian noise of the tracker
    (0.02 mm per coordinate) is added to the readings of all effects together."""
    rng = np.random.default_rng(seed)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    geom, truth = true_geometry(robot, "tracker", rng)
    sets = [sample_configurations(robot, count, rng) for count in counts]
    noise = TRACKER["noise"]
    q_cal = sets[0] * DEG
    base = tracker_readings(geom, q_cal)
    effects = []
    for effect in hidden:
        effect = dict(effect)
        if effect["value"] is None:
            effect["value"] = 1e-6
            for _ in range(3):  # the signature is linear in the value to first order
                signature = tracker_readings(geom, q_cal, [effect]) - base
                effect["value"] *= sigmas * noise / np.sqrt(np.mean(signature**2))
        effect["rms_signature"] = float(np.sqrt(np.mean((tracker_readings(geom, q_cal, [effect]) - base) ** 2)))
        effects.append(effect)
    for name, q in zip(("calibration.csv", "validation.csv"), sets):
        y = tracker_readings(geom, q * DEG, effects)
        write_csv(folder / name, "tracker", q, [("smr",)] * len(q), y + rng.normal(0, noise, y.shape))
    spec = folder / "spec.yaml"
    spec.write_text(spec_text(robot, "tracker"))
    return {"spec": spec, "effects": effects, "truth": truth, "geom": geom, "noise": noise}
