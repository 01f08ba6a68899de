"""What the benchmarks share: timing, the table, and the baseline - numpy forward models written here
independently of armcal, fitted by scipy.optimize.least_squares(method="lm") with finite differences.

The numpy models read only the spec (conventions, instrument geometry, noise) and the data; their
weighted residuals come in armcal's order (key by key, channel by channel) so each benchmark can
assert that both sides see the same model before it times anything.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("ARMCAL_COMPILE", "now")  # armcal's side is timed in machine code, each library built before its timing

import armcal  # noqa: E402, F401  (first: its single-threaded BLAS setting then holds for both sides)
import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from armcal.devices.sonic import ROD_NEAR  # noqa: E402
from armcal.effects.measurement import DEFAULT_LINK_MASS, GRAVITY  # noqa: E402

REPEATS = 15
HEADER = f"{'case':44s} {'armcal ms':>9s} {'baseline ms':>10s} {'ratio':>7s} {'cost A':>11s} {'cost B':>11s} {'val A':>8s} {'val B':>8s}"
LEGEND = "cost: 1/2 sum of squared weighted residuals; val: RMS of validation residuals in noise sigmas; A armcal, B baseline"


def median_time(function, repeats=REPEATS):
    """(median seconds, last result) of ``repeats`` calls."""
    times, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - started)
    return statistics.median(times), result


def cost(problem, theta) -> float:
    """1/2 sum of squared weighted residuals."""
    r = problem.evaluate(theta)[0]
    return 0.5 * float(r @ r)


def rms(problem, theta) -> float | None:
    """RMS of weighted residuals (None without the problem)."""
    return None if problem is None else float(np.sqrt(np.mean(problem.evaluate(theta)[0] ** 2)))


def row(case: str, seconds_a: float, seconds_b: float, costs, validation) -> str:
    """One line of the table; a missing validation RMS prints as '-'."""
    val = lambda x: f"{'-':>8s}" if x is None else f"{x:8.4f}"  # noqa: E731
    return (
        f"{case:44s} {seconds_a * 1000:9.1f} {seconds_b * 1000:10.1f} {seconds_b / seconds_a:7.1f}"
        f" {costs[0]:11.2f} {costs[1]:11.2f} {val(validation[0])} {val(validation[1])}"
    )


def print_table(lines: list[str], legend: str = LEGEND) -> None:
    print(HEADER)
    print("-" * len(HEADER))
    for line in lines:
        print(line)
    print(legend)


def assert_same_model(model, problem, theta, what: str = "") -> None:
    """The numpy residuals equal armcal's weighted residuals at theta (to 1e-6 sigma)."""
    difference = np.abs(model.residuals(theta) - problem.evaluate(theta)[0]).max()
    assert difference < 1e-6, f"the baseline's model{what} differs from armcal's by {difference}"


def scipy_lm_fd(model, start: np.ndarray, free: np.ndarray):
    """The baseline fit: scipy LM with finite differences on ``free``; (theta, residual evaluations incl. differences)."""
    calls = [0]

    def residuals(x):
        calls[0] += 1
        p = start.copy()
        p[free] = x
        return model.residuals(p)

    solution = least_squares(residuals, start[free], method="lm", x_scale="jac")
    theta = start.copy()
    theta[free] = solution.x
    return theta, calls[0]


# --- numpy forward models ---------------------------------------------------------------------


def _identity(shape: tuple) -> np.ndarray:
    out = np.zeros(shape + (4, 4))
    out[..., range(4), range(4)] = 1.0
    return out


def _rotation(angle, i: int, j: int) -> np.ndarray:
    """Homogeneous rotation (..., 4, 4) turning axis i towards axis j by ``angle`` (a scalar or (N,))."""
    angle = np.asarray(angle, dtype=float)
    out = _identity(angle.shape)
    c, s = np.cos(angle), np.sin(angle)
    out[..., i, i], out[..., j, j], out[..., i, j], out[..., j, i] = c, c, -s, s
    return out


def rot_x(angle):
    return _rotation(angle, 1, 2)


def rot_y(angle):
    return _rotation(angle, 2, 0)


def rot_z(angle):
    return _rotation(angle, 0, 1)


def trans(x, y, z) -> np.ndarray:
    """Homogeneous translation (..., 4, 4) by scalars or (N,) arrays."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, z)))
    out = _identity(x.shape)
    out[..., 0, 3], out[..., 1, 3], out[..., 2, 3] = x, y, z
    return out


def pose(v: dict, prefix: str, factor=1.0, angles=("rz", "ry", "rx")) -> np.ndarray:
    """Trans(x, y, z) Rot(z) Rot(y) Rot(x) from the values ``prefix.field`` (absent ones 0), lengths times ``factor``."""
    get = lambda field: v.get(f"{prefix}.{field}", 0.0)  # noqa: E731
    return trans(*(factor * get(f) for f in "xyz")) @ rot_z(get(angles[0])) @ rot_y(get(angles[1])) @ rot_x(get(angles[2]))


class NumpyRobot:
    """Frames F_0..F_n and target poses of a spec robot: DH (Stone 2.9, with Hayati's Rot(y, beta) where the spec has it) or
    Goswami's six-parameter chain (2), (3)."""

    def __init__(self, robot):
        assert robot.convention in ("dh", "six_parameter") and all(j.type == "revolute" for j in robot.joints)
        self.six = robot.convention == "six_parameter"
        self.joints = robot.joint_names()
        self.links = {name: target.link for name, target in robot.targets.items()}

    def frames(self, v: dict, joints: np.ndarray, factor=1.0) -> list[np.ndarray]:
        """F_0..F_n for joint values (N, n); every length times ``factor`` (a scalar or (N,), thermal drift)."""
        six_link = lambda i: pose(v, f"L{i}", factor, ("alpha", "beta", "gamma"))  # noqa: E731
        frames = [pose(v, "base", factor) @ six_link(1)] if self.six else [pose(v, "base", factor)]
        for i, name in enumerate(self.joints):
            if self.six:
                link = rot_z(v[f"{name}.theta0"] + v[f"{name}.k"] * joints[:, i]) @ six_link(i + 2)
            else:
                offset = trans(factor * v[f"{name}.a"], 0.0, factor * v[f"{name}.d"]) @ rot_x(v[f"{name}.alpha"])
                offset = offset @ rot_y(v.get(f"{name}.beta", 0.0))  # Hayati's tilt on a nominally parallel axis
                link = rot_z(v[f"{name}.theta"] + joints[:, i]) @ offset
            frames.append(frames[-1] @ link)
        return frames

    def target(self, v: dict, name: str, joints: np.ndarray, factor=1.0) -> np.ndarray:
        """Pose (N, 4, 4) of a target on its link."""
        return self.frames(v, joints, factor)[self.links[name]] @ pose(v, name, factor)


def gravity_torque(frames: list[np.ndarray], joint: int) -> np.ndarray:
    """Torque (N m) about joint ``joint``'s axis from the default lumped masses at the origins of F_joint..F_n."""
    axis, origin = frames[joint - 1][..., :3, 2], frames[joint - 1][..., :3, 3]
    weight = DEFAULT_LINK_MASS * np.array(GRAVITY)
    levers = sum(frame[..., :3, 3] - origin for frame in frames[joint:]) / 1000.0  # m
    return np.sum(axis * np.cross(levers, weight), axis=-1)


def moment_regressor(frames: list[np.ndarray], joint: int, term: str) -> np.ndarray:
    """Deflection of joint ``joint`` per unit of the product m<c><k>: axis c of F_k . (g_hat x z_(joint-1)); w (a
    prismatic joint): z_(joint-1) . g_hat."""
    down = np.array(GRAVITY) / np.linalg.norm(GRAVITY)
    axis = frames[joint - 1][..., :3, 2]
    if term == "w":
        return axis @ down
    link, c = int(term[2:]), "xyz".index(term[1])
    return np.sum(frames[link][..., :3, c] * np.cross(down, axis), axis=-1)


class NumpyCampaign:
    """Weighted residuals (predicted - measured) / sigma of one data set, with joint-side effects and a sensor scale.

    Effects (armcal's candidate descriptions, parameters named ``<id>.<field>``): encoder scale s q, gear harmonic
    A sin(h r q) + B cos(h r q), compliance c tau_g(q) or its mass-moment products, a coupling c q_i, thermal drift of every length by 1 + k t, sensor scale.
    """

    def __init__(self, robot, device, names: list[str], data, effects=()):
        self.robot, self.device, self.names, self.effects = NumpyRobot(robot), device, names, tuple(effects)
        blocks = []
        for key, rows in data.groups().items():
            measured = np.stack([data.readings[c][rows] for c, _ in device.channels(key)], axis=1)
            t = data.extras["t"][rows] if "t" in data.extras else np.zeros(len(rows))
            blocks.append((key, data.q[rows], t, measured))
        blocks += [(key, None, None, measured) for key, measured in device.pseudo_observations()]
        angles = lambda key: np.array([angle for _, angle in device.channels(key)])  # noqa: E731
        self.blocks = [(key, q, t, measured, device.sigma(key, measured), angles(key)) for key, q, t, measured in blocks]

    def residuals(self, p: np.ndarray) -> np.ndarray:
        v = dict(zip(self.names, p))
        scale = 1.0 + sum(v[f"{e.id}.scale"] for e in self.effects if e.type == "sensor_scale")
        out = []
        for key, q, t, measured, sigma, angles in self.blocks:
            target = self.device.target(key)
            seen = self.robot.target(v, target, *self._joints(v, q, t)) if target else None
            difference = self.device.readings(v, key, seen) * np.where(angles, 1.0, scale) - measured
            difference[:, angles] = np.arctan2(np.sin(difference[:, angles]), np.cos(difference[:, angles]))
            out.append((difference / sigma).T.ravel())
        return np.concatenate(out)

    def _joints(self, v: dict, q: np.ndarray, t: np.ndarray):
        """Joint values the chain sees and the lengths' thermal factor."""
        joints, factor, frames = q.copy(), 1.0, None
        for e in self.effects:
            j, value = e.joint - 1 if e.joint else None, lambda field, e=e: v[f"{e.id}.{field}"]  # noqa: E731
            if e.type == "encoder_scale":
                joints[:, j] += value("scale") * q[:, j]
            elif e.type == "gear_harmonic":
                joints[:, j] += value("sin") * np.sin(e.order * e.ratio * q[:, j]) + value("cos") * np.cos(e.order * e.ratio * q[:, j])
            elif e.type == "joint_compliance" and e.terms:
                frames = self.robot.frames(v, q) if frames is None else frames
                joints[:, j] += sum(value(term) * moment_regressor(frames, e.joint, term) for term in e.terms)
            elif e.type == "joint_compliance" and not e.masses:
                frames = self.robot.frames(v, q) if frames is None else frames
                joints[:, j] += value("compliance") * gravity_torque(frames, e.joint)
            elif e.type == "joint_coupling":
                joints[:, j] += value("coefficient") * q[:, e.source_joint - 1]
            elif e.type == "thermal_drift" and e.source == "time":
                factor = factor + value("coefficient") * t
            elif e.type != "sensor_scale":
                raise NotImplementedError(e.id)
        return joints, factor


class NumpyDevice:
    """A measuring instrument: channels (name, is angle), the robot target of a key, readings, noise."""

    def __init__(self, spec):
        self.spec = spec

    def target(self, key):
        return key[0]

    def pseudo_observations(self) -> list:
        return []

    def sigma(self, key, measured: np.ndarray) -> np.ndarray:
        return np.full(measured.shape, self.spec.noise)


class BallBar(NumpyDevice):
    """Goswami's bar: |sphere - pivot| + L0 - L."""

    def channels(self, key):
        return [("length", False)]

    def target(self, key):
        return key[1]

    def readings(self, v, key, seen):
        centre = np.array([v[f"pivot.{key[0]}.{c}"] for c in "xyz"])
        return (np.linalg.norm(seen[:, :3, 3] - centre, axis=1) + self.spec.length.value - v["bar.length"])[:, None]


class Sonic(NumpyDevice):
    """Stone's slant ranges scale |P x - mic| (4.48), sigma (a s + b) / sqrt(N_avg) with the rods' ratio noise (7.9, E.1)."""

    def __init__(self, spec, averaging: int):
        super().__init__(spec)
        self.averaging = averaging

    def channels(self, key):
        return [(f"s_{m}", False) for m in self.spec.microphones]

    def readings(self, v, key, seen):
        point = np.einsum("ij,nj->ni", pose(v, "robot_base"), seen[:, :, 3])[:, :3]
        mics = np.array([[v[f"mic.{m}.{c}"] for c in "xyz"] for m in self.spec.microphones])
        return v["sonic.scale"] * np.linalg.norm(point[:, None, :] - mics[None], axis=2)

    def sigma(self, key, measured):
        a, b = self.spec.noise.a, self.spec.noise.b
        sigma = (a * measured + b) / np.sqrt(self.averaging)
        if self.spec.calibration_rods:
            rod = self.spec.calibration_rods[0].length
            ratio = np.hypot(a * ROD_NEAR + b, a * (ROD_NEAR + rod) + b) / np.sqrt(self.averaging) / rod
            sigma = np.hypot(sigma, ratio * measured)
        return sigma


class Theodolite(NumpyDevice):
    """Azimuth atan2(y, x) and elevation atan2(z, |(x, y)|) in each station's frame; the scale bar's marks and length."""

    BAR = ("scale_bar",)

    def channels(self, key):
        return [("length", False)] if key == self.BAR else [("azimuth", True), ("elevation", True)]

    def target(self, key):
        return None if key == self.BAR or key[1].startswith("scale_bar.") else key[1]

    def pseudo_observations(self):
        return [(self.BAR, np.array([[self.spec.scale_bar.length]]))] if self.spec.scale_bar else []

    def readings(self, v, key, seen):
        mark = lambda name: np.array([[v[f"{name}.{c}"] for c in "xyz"]])  # noqa: E731
        if key == self.BAR:
            return np.linalg.norm(mark("scale_bar.end2") - mark("scale_bar.end1"), axis=1)[:, None]
        station, target = key
        world = mark(target) if seen is None else np.einsum("ij,nj->ni", pose(v, "robot_base"), seen[:, :, 3])[:, :3]
        frame = pose(v, f"station.{station}")
        local = (world - frame[:3, 3]) @ frame[:3, :3]
        return np.stack([np.arctan2(local[:, 1], local[:, 0]), np.arctan2(local[:, 2], np.hypot(local[:, 0], local[:, 1]))], axis=1)

    def sigma(self, key, measured):
        return np.full(measured.shape, self.spec.scale_bar.noise if key == self.BAR else self.spec.noise)


class Tracker(NumpyDevice):
    """Position scale (P x) and, with a 6-DOF probe, intrinsic XYZ Euler angles of P T."""

    def channels(self, key):
        return [(c, False) for c in "xyz"] + ([(c, True) for c in ("rx", "ry", "rz")] if self.spec.orientation else [])

    def readings(self, v, key, seen):
        seen = pose(v, "robot_base") @ seen
        out = [v["tracker.scale"] * seen[:, :3, 3]]
        if self.spec.orientation:
            R = seen[:, :3, :3]
            rx, ry, rz = np.arctan2(-R[:, 1, 2], R[:, 2, 2]), np.arcsin(np.clip(R[:, 0, 2], -1, 1)), np.arctan2(-R[:, 0, 1], R[:, 0, 0])
            out.append(np.stack([rx, ry, rz], axis=1))
        return np.concatenate(out, axis=1)

    def sigma(self, key, measured):
        sigma = np.full(measured.shape, self.spec.noise)
        if self.spec.orientation:
            sigma[:, 3:] = self.spec.orientation_noise or self.spec.noise / 1000.0
        return sigma


def numpy_device(spec) -> NumpyDevice:
    """The numpy model of a spec's instrument (sonic digitizer in raw-range mode)."""
    device = spec.device
    if device.type == "sonic_digitizer":
        return Sonic(device, spec.procedure.averaging)
    return {"ballbar": BallBar, "theodolite": Theodolite, "tracker": Tracker}[device.type](device)
