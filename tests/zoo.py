"""A generated robot zoo: random serial chains, their campaigns, and the truth a fit should find.

A test oracle for armcal (issue 29 item 6), written from the docs only: nothing here imports armcal.

- Kinematics (docs/spec.md, "Robot"): ``dh`` A_i = Rot(z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(x, alpha)
  (Stone (2.9)), followed by Hayati's Rot(y, beta) where armcal adds it (a ``dh`` axis parallel to the next) or
  where an ``mdh`` joint gives it (armcal's ``mdh`` is (2.9) then Rot(y, beta), docs/spec.md: Hayati's tilt, not
  Craig's modified DH); ``six_parameter`` F_0 = base L_1, F_i = F_(i-1) Rot(z, theta0 + k q) L_(i+1) (Goswami (2),
  (3); Trans(0, 0, theta0 + k q) for a prismatic joint), L = Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma).
  A revolute joint's reading adds to theta, a prismatic one's to d. Poses Trans(x, y, z) Rot(z, rz) Rot(y, ry)
  Rot(x, rx).
- Devices: tracker (docs/devices/tracker.md: s P p(q)), ball-bar (docs/devices/ballbar.md: |s(q) - c| + L0 - L),
  theodolite (docs/devices/theodolite.md: azimuth atan2(y, x), elevation atan2(z, hypot(x, y)) in the station's
  frame; the scale bar's marks sighted like targets, and |end2 - end1| = length one more observation).

Every model value is named as armcal names it (``j2.a``, ``L3.x``, ``base.x``, ``smr.y``, ``robot_base.rz``,
``station.t2.x``, ``pivot.c1.x``, ``scale_bar.end1.x``, ``j3.k``), in the spec's units (mm, deg, scale 1).

    robot = zoo_robot(7)                  # deterministic per seed
    campaign = write_campaign(folder, robot, stream=0)   # spec.yaml, calibration.csv, validation.csv
    campaign["truth"]                     # {name: true value} of every parameter of the model

The zoo (zoo_robot): 4 to 7 axes, conventions dh / mdh / six_parameter and devices tracker / ball-bar / theodolite
in turn (seed % 9), parallel axes (alpha 0, up to three in a row) and prismatic joints; link lengths 50-800 mm;
variants drawn per seed: a target on a joint's axis (the last joint's axis, where it cannot see that joint
turn), a second tracker target on the link before the last, free ball-bar spheres, free encoder offsets and
scales (six_parameter), and campaigns in which one joint barely moves (+-0.01 deg, or +-0.01 mm).
The truth is the nominal plus manufacturing errors (lengths 0.3 mm, angles 0.03 deg, Hayati tilts 0.02-0.05 deg,
each clipped to 3 sigma), on every model value the spec leaves free and on the encoder offsets even where the
spec holds them (a link's Euler angles carry them exactly); values the spec holds and nothing can carry (the
bar's length, the chucks, held spheres, held encoder scales) are true as given. Readings get Gaussian noise at
the device's declared sigma.

``equivalent_truth`` expresses the truth in a base set: with the parameters a fit held at the values it held
them, the free ones that reproduce the true robot's noise-free readings of the calibration poses best (weighted
least squares, Gauss-Newton with central differences). That is what an unbiased fit of the base set estimates.
"""

from __future__ import annotations

import pathlib

import numpy as np

DEG = np.pi / 180.0
ARCSEC = 1.0 / 3600.0  # deg
CONVENTIONS = ("dh", "mdh", "six_parameter")
DEVICES = ("tracker", "ballbar", "theodolite")
POSE_FIELDS = ("x", "y", "z", "rx", "ry", "rz")
DH_FIELDS = ("theta", "d", "a", "alpha")
LINK_FIELDS = ("x", "y", "z", "alpha", "beta", "gamma")
SIGMA_LENGTH, SIGMA_ANGLE, CLIP = 0.3, 0.03, 3.0  # mm, deg, sigmas
BARELY = 0.01  # deg (or mm): the half-range of a joint that barely moves
TRAVEL, MARGIN = 75.0, 10.0  # ball-bar LVDT travel and the margin kept inside it, mm


# ------------------------------------------------------------------------------------------- transforms
def rot(axis: str, angle) -> np.ndarray:
    """Rot(axis, angle) as (..., 4, 4); angle in rad, scalar or array."""
    angle = np.asarray(angle, float)
    c, s = np.cos(angle), np.sin(angle)
    T = np.zeros(angle.shape + (4, 4))
    T[..., 3, 3] = 1.0
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    k = 3 - i - j
    T[..., k, k] = 1.0
    T[..., i, i], T[..., i, j], T[..., j, i], T[..., j, j] = c, -s, s, c
    return T


def trans(x, y, z) -> np.ndarray:
    """Trans(x, y, z) as (..., 4, 4); components scalar or arrays of one shape."""
    x, y, z = np.broadcast_arrays(*(np.asarray(v, float) for v in (x, y, z)))
    T = np.zeros(x.shape + (4, 4))
    T[..., 0, 0] = T[..., 1, 1] = T[..., 2, 2] = T[..., 3, 3] = 1.0
    T[..., 0, 3], T[..., 1, 3], T[..., 2, 3] = x, y, z
    return T


def pose(p: dict, prefix: str) -> np.ndarray:
    """Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx) of the values ``prefix.x`` ... (mm, deg; missing: 0)."""
    g = lambda f: p.get(f"{prefix}.{f}", 0.0)  # noqa: E731
    return trans(g("x"), g("y"), g("z")) @ rot("z", g("rz") * DEG) @ rot("y", g("ry") * DEG) @ rot("x", g("rx") * DEG)


def six_link(p: dict, i: int) -> np.ndarray:
    """Goswami (3): L_i = Trans(x, y, z) Rot(z, alpha) Rot(y, beta) Rot(x, gamma)."""
    g = lambda f: p[f"L{i}.{f}"]  # noqa: E731
    return trans(g("x"), g("y"), g("z")) @ rot("z", g("alpha") * DEG) @ rot("y", g("beta") * DEG) @ rot("x", g("gamma") * DEG)


def joint_transform(robot: dict, p: dict, i: int, q) -> np.ndarray:
    """A_i(q) of joint i (1-based) for readings q (spec units, array (N,)): the transform F_(i-1) -> F_i."""
    q = np.asarray(q, float)
    revolute = robot["types"][i - 1] == "revolute"
    if robot["convention"] == "six_parameter":
        value = p[f"j{i}.theta0"] + p[f"j{i}.k"] * q
        J = rot("z", value * DEG) if revolute else trans(0.0 * value, 0.0 * value, value)
        return J @ six_link(p, i + 1)
    theta = p[f"j{i}.theta"] + (q if revolute else 0.0 * q)
    d = p[f"j{i}.d"] + (0.0 * q if revolute else q)
    A = rot("z", theta * DEG) @ trans(0.0 * d, 0.0 * d, d) @ trans(p[f"j{i}.a"], 0.0, 0.0) @ rot("x", p[f"j{i}.alpha"] * DEG)
    beta = p.get(f"j{i}.beta")
    return A if beta is None else A @ rot("y", beta * DEG)


def link_frames(robot: dict, p: dict, q: np.ndarray, upto: int) -> np.ndarray:
    """F_upto (N, 4, 4) in the world frame for joint readings q (N, n)."""
    F = np.broadcast_to(pose(p, "base"), (len(q), 4, 4))
    if robot["convention"] == "six_parameter":
        F = F @ six_link(p, 1)
    for i in range(1, upto + 1):
        F = F @ joint_transform(robot, p, i, q[:, i - 1])
    return F


def target_points(robot: dict, p: dict, q: np.ndarray, target: str) -> np.ndarray:
    """Positions (N, 3) of a robot target in the robot's world frame."""
    F = link_frames(robot, p, q, robot["targets"][target])
    local = np.array([p[f"{target}.x"], p[f"{target}.y"], p[f"{target}.z"], 1.0])
    return (F @ local)[:, :3]


# ------------------------------------------------------------------------------------------ the devices
def _apply(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ T[:3, :3].T + T[:3, 3]


def _sight(p: dict, station: str, world: np.ndarray) -> np.ndarray:
    """Azimuth and elevation (deg) of instrument-frame points seen from a station (docs/devices/theodolite.md)."""
    local = _apply(np.linalg.inv(pose(p, f"station.{station}")), world)
    x, y, z = local.T
    return np.column_stack([np.arctan2(y, x), np.arctan2(z, np.hypot(x, y))]) / DEG


def predict(robot: dict, p: dict, rows: list) -> np.ndarray:
    """Readings (len(rows), channels) of rows [(key, q)] (q (n,) in spec units, None on scale-bar rows)."""
    device = robot["device"]
    kind = device["type"]
    width = {"tracker": 3, "ballbar": 1, "theodolite": 2}[kind]
    out = np.empty((len(rows), width))
    groups: dict = {}
    for index, (key, _) in enumerate(rows):
        groups.setdefault(key, []).append(index)
    for key, idx in groups.items():
        if kind == "theodolite" and key[1].startswith("scale_bar."):
            end = np.array([[p[f"{key[1]}.{c}"] for c in "xyz"]])
            out[idx] = _sight(p, key[0], np.repeat(end, len(idx), 0))
            continue
        q = np.array([rows[i][1] for i in idx], float)
        target = key[0] if kind == "tracker" else key[1]
        points = target_points(robot, p, q, target)
        if kind == "tracker":
            out[idx] = p["tracker.scale"] * _apply(pose(p, "robot_base"), points)
        elif kind == "ballbar":
            centre = np.array([p[f"pivot.{key[0]}.{c}"] for c in "xyz"])
            out[idx, 0] = np.linalg.norm(points - centre, axis=1) + device["length"] - p["bar.length"]
        else:
            out[idx] = _sight(p, key[0], _apply(pose(p, "robot_base"), points))
    return out


def bar_length(p: dict) -> float:
    """|end2 - end1| of the theodolite's scale bar, the observation its calibrated length gives."""
    return float(np.linalg.norm([p[f"scale_bar.end2.{c}"] - p[f"scale_bar.end1.{c}"] for c in "xyz"]))


def noise_sigma(robot: dict) -> float:
    return robot["device"]["noise"]


# --------------------------------------------------------------------------------------- the generator
def _clipped(rng, sigma: float, size=None):
    return np.clip(rng.normal(0.0, sigma, size), -CLIP * sigma, CLIP * sigma)


def _dh_design(rng, n: int) -> tuple[list, list]:
    """Nominal DH rows [theta, d, a, alpha] (mm, deg) and joint types of a sensible random arm."""
    types, rows = [], []
    run = 0  # parallel pairs in a row just before this joint
    for i in range(n):
        prismatic = i > 0 and sum(t == "prismatic" for t in types) < 2 and rng.random() < 0.15
        if prismatic and types[-1] == "prismatic" and rows[-1][3] == 0:
            prismatic = False  # two parallel slides would move the same way
        types.append("prismatic" if prismatic else "revolute")
        alpha = float(rng.choice([0.0, 90.0, -90.0], p=[0.3, 0.35, 0.35]))
        if i < n - 1 and alpha == 0.0 and run >= 2:
            alpha = float(rng.choice([90.0, -90.0]))  # at most three parallel axes in a row
        run = run + 1 if (i < n - 1 and alpha == 0.0) else 0
        a = float(rng.uniform(50, 800)) * rng.choice([-1, 1]) if rng.random() < 0.5 else 0.0
        if alpha == 0.0 and i < n - 1 and abs(a) < 150:
            a = float(rng.uniform(150, 800)) * rng.choice([-1, 1])  # parallel axes, never one line
        d = float(rng.uniform(50, 400)) * rng.choice([-1, 1]) if rng.random() < 0.5 else 0.0
        theta = float(rng.choice([0.0, 90.0, -90.0], p=[0.6, 0.2, 0.2]))
        rows.append([theta, d, a, alpha])
    total = sum(abs(r[1]) + abs(r[2]) for r in rows)
    if total > 2000.0:  # keep the arm's reach near 2 m; no length below 50 mm
        for r in rows:
            for k in (1, 2):
                if r[k]:
                    r[k] = float(np.sign(r[k]) * max(50.0, abs(r[k]) * 2000.0 / total))
    return rows, types


def _parallel(rows: list, i: int) -> bool:
    """Joint i's axis (0-based) parallel to the next one's: alpha within 5 deg of 0 or 180 (docs/method.md)."""
    return i + 1 < len(rows) and min(abs(rows[i][3]) % 180.0, 180.0 - abs(rows[i][3]) % 180.0) < 5.0


def _nominal_chain(convention: str, rows: list, types: list) -> dict:
    """The nominal model values of the chain (no base, targets or device)."""
    p: dict = {}
    if convention == "six_parameter":
        p.update({f"L1.{f}": 0.0 for f in LINK_FIELDS})
        for i, ((theta, d, a, alpha), kind) in enumerate(zip(rows, types), start=1):
            if kind == "revolute":  # Rz(theta + q) Tz(d) Tx(a) Rx(alpha): L = Trans(a, 0, d) Rot(x, alpha)
                p[f"j{i}.theta0"] = theta
                link = dict(x=a, y=0.0, z=d, alpha=0.0, beta=0.0, gamma=alpha)
            else:  # Tz(d + q) Rz(theta) Tx(a) Rx(alpha): L = Trans(a cos, a sin, 0) Rot(z, theta) Rot(x, alpha)
                p[f"j{i}.theta0"] = d
                link = dict(x=a * np.cos(theta * DEG), y=a * np.sin(theta * DEG), z=0.0, alpha=theta, beta=0.0, gamma=alpha)
            p[f"j{i}.k"] = 1.0
            p.update({f"L{i + 1}.{f}": float(np.round(v, 9)) + 0.0 for f, v in link.items()})
        return p
    for i, row in enumerate(rows, start=1):
        p.update({f"j{i}.{f}": float(v) for f, v in zip(DH_FIELDS, row)})
        if _parallel(rows, i - 1):
            p[f"j{i}.beta"] = 0.0  # armcal adds it to a dh chain; an mdh spec gives it
    return p


def zoo_robot(seed: int) -> dict:
    """A random robot with its device set-up, nominal spec values, what the spec holds, and a true robot."""
    rng = np.random.default_rng([29, 6, seed])
    convention, device_type = CONVENTIONS[seed % 3], DEVICES[(seed // 3) % 3]
    n = int(rng.integers(4, 8))
    rows, types = _dh_design(rng, n)
    nominal = _nominal_chain(convention, rows, types)
    limits = [(-float(rng.uniform(120, 175)), float(rng.uniform(120, 175))) if t == "revolute"
              else (0.0, float(rng.uniform(150, 400))) for t in types]
    held: set = set()  # values the spec holds (vary: false)
    units = {}
    for name in nominal:
        field = name.split(".")[1]
        units[name] = ("scale" if field == "k" else "length" if field in ("d", "a", "x", "y", "z")
                       else "angle")
    for i, kind in enumerate(types, start=1):
        if convention == "six_parameter" and kind == "prismatic":
            units[f"j{i}.theta0"] = "length"
    variants = dict(barely=None, on_axis=False, second_target=False, free_spheres=False, free_theta0=False, free_k=False)
    if rng.random() < 0.3:
        variants["barely"] = int(rng.integers(1, n + 1))
    if convention == "six_parameter":
        variants["free_theta0"] = bool(rng.random() < 0.5)
        variants["free_k"] = bool(rng.random() < 0.3)
        for i in range(1, n + 1):
            if not variants["free_theta0"]:
                held.add(f"j{i}.theta0")
            if not variants["free_k"]:
                held.add(f"j{i}.k")
    robot = dict(seed=seed, name=f"Zoo arm {seed}", serial=f"ZOO-{seed:04d}", convention=convention, n=n, types=types,
                 limits=limits, dh=rows, targets={}, variants=variants)

    # the targets: points on the last link (F_n), one on the last joint's axis where the variant says so
    def on_axis(h: float) -> list:
        """A point h along joint n's axis (z of F_(n-1)), in F_n coordinates at the nominal."""
        A = joint_transform(robot, nominal, n, np.zeros(1))[0]
        return list(np.linalg.solve(A, [0.0, 0.0, h, 1.0])[:3])

    def off_axis() -> list:
        return [float(rng.uniform(40, 120) * rng.choice([-1, 1])), float(rng.uniform(40, 120) * rng.choice([-1, 1])),
                float(rng.uniform(30, 150))]

    targets: dict = {}
    if device_type == "ballbar":
        variants["on_axis"] = bool(rng.random() < 0.3)  # one sphere on the last axis (the others see it turn)
        variants["free_spheres"] = bool(rng.random() < 0.3)
        r, h, phase = float(rng.uniform(50, 80)), float(rng.uniform(40, 100)), float(rng.uniform(0, 360))
        for k in range(3):
            phi = (phase + 120 * k) * DEG
            targets[f"s{k + 1}"] = (n, [r * np.cos(phi), r * np.sin(phi), h])
        if variants["on_axis"]:
            targets["s1"] = (n, on_axis(h))
    else:
        variants["on_axis"] = bool(rng.random() < 0.25)
        name = "smr" if device_type == "tracker" else "ball"
        targets[name] = (n, on_axis(float(rng.uniform(50, 150))) if variants["on_axis"] else off_axis())
        if device_type == "tracker" and rng.random() < 0.3:
            variants["second_target"] = True
            targets["smr2"] = (n - 1, off_axis())
    for name, (link, xyz) in targets.items():
        robot["targets"][name] = link
        for c, v in zip("xyz", xyz):
            nominal[f"{name}.{c}"] = float(np.round(v, 6)) + 0.0
            units[f"{name}.{c}"] = "length"
            if device_type == "ballbar" and not variants["free_spheres"]:
                held.add(f"{name}.{c}")

    # the device
    reach = sum(abs(row[1]) + abs(row[2]) for row in rows) + sum(hi for (lo, hi), t in zip(limits, types) if t == "prismatic")
    reach += 150.0
    device: dict = dict(type=device_type)
    true_device: dict = {}
    if device_type == "tracker":
        device.update(noise=float(rng.uniform(0.01, 0.03)), targets=list(targets))
        true_device.update(_pose_values("robot_base", [reach + rng.uniform(1000, 2500), rng.uniform(-500, 500), rng.uniform(-300, 300),
                                                       rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-180, 180)]))
        spec_device = {k: float(np.round(v, -2)) if k.endswith(("x", "y", "z")) else 0.0 for k, v in true_device.items()}
        true_device["tracker.scale"] = spec_device["tracker.scale"] = 1.0
        held.add("tracker.scale")
    elif device_type == "theodolite":
        baseline, distance = float(rng.uniform(2000, 3500)), reach + float(rng.uniform(1200, 2000))
        device.update(noise=float(rng.uniform(1.0, 2.5)) * ARCSEC, targets=list(targets), bar_noise=0.01, bar=1000.0,
                      stations=["t1", "t2"])
        true_device.update(_pose_values("robot_base", [baseline / 2 + rng.uniform(-300, 300), distance, rng.uniform(-1000, 0),
                                                       rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-180, 180)]))
        true_device.update(_pose_values("station.t1", [0.0] * 6))
        true_device.update(_pose_values("station.t2", [baseline, rng.uniform(-200, 200), rng.uniform(-100, 100), 0.0, 0.0,
                                                       rng.uniform(-5, 5)]))
        held.update(f"station.t1.{f}" for f in POSE_FIELDS)
        held.update(f"station.t2.{f}" for f in ("rx", "ry"))
        centre = np.array([baseline / 2, distance - reach - 300.0, -600.0]) + rng.uniform(-100, 100, 3)
        way = rng.uniform(0, 2 * np.pi)
        half = 500.0 * np.array([np.cos(way), np.sin(way), 0.0])  # a horizontal bar of 1000 mm
        for end, point in (("scale_bar.end1", centre - half), ("scale_bar.end2", centre + half)):
            true_device.update({f"{end}.{c}": float(v) for c, v in zip("xyz", point)})
        # the spec's start: a tape measure's guesses (the fit has no registration for angles)
        spec_device = {}
        for name, value in true_device.items():
            if name in held:
                spec_device[name] = value
            elif name.endswith(("rx", "ry", "rz")):
                spec_device[name] = float(np.round(value + rng.normal(0, 0.3), 1))
            else:
                spec_device[name] = float(np.round(value + rng.normal(0, 10.0)))
    else:  # ball-bar: three chucks (held: they define the frame), the bar held at its calibrated length
        device.update(noise=float(rng.uniform(0.004, 0.01)), length=float(np.round(rng.uniform(250, 460))),
                      travel=TRAVEL, spheres=list(targets))
        spec_device, true_device = {}, {}
        # the pivots, the robot base and the shells are placed in ballbar_setup (they need the true robot)
    for name in true_device:
        units[name] = "scale" if name.endswith("scale") else "angle" if name.rsplit(".", 1)[1] in ("rx", "ry", "rz") else "length"

    # base: free for the ball-bar (the robot relative to the chucks), held at 0 otherwise (the instrument carries it)
    for f in POSE_FIELDS:
        nominal[f"base.{f}"] = 0.0
        units[f"base.{f}"] = "angle" if f.startswith("r") else "length"
        if device_type != "ballbar":
            held.add(f"base.{f}")

    # the truth: manufacturing errors on the chain, the targets and the base
    truth = dict(nominal)
    for name in nominal:
        field = name.rsplit(".", 1)[1]
        if name in held and not name.endswith("theta0"):
            continue  # held by the spec and nothing carries it: true as given
        if field == "k":
            truth[name] = 1.0 + float(_clipped(rng, 2e-4))
        elif field == "beta" and not name.startswith("L"):
            truth[name] = float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.05))
        elif units[name] == "angle":
            truth[name] = nominal[name] + float(_clipped(rng, SIGMA_ANGLE))
        else:
            truth[name] = nominal[name] + float(_clipped(rng, SIGMA_LENGTH))
    robot.update(nominal={**nominal, **spec_device}, truth={**truth, **true_device}, held=held, units=units,
                 device=device, reach=reach)
    if device_type == "ballbar":
        _ballbar_setup(robot, rng)
    return robot


def _pose_values(prefix: str, values) -> dict:
    return {f"{prefix}.{f}": float(v) for f, v in zip(("x", "y", "z", "rx", "ry", "rz"), values)}


def sample_configurations(robot: dict, count: int, rng) -> np.ndarray:
    """Configurations (count, n) uniform within the joint limits (2 deg or 2 mm inside them); a joint that barely
    moves stays within +-BARELY of one value."""
    lim = np.array(robot["limits"])
    lo, hi = lim[:, 0] + 2.0, lim[:, 1] - 2.0
    q = rng.uniform(lo, hi, (count, robot["n"]))
    j = robot["variants"]["barely"]
    if j is not None:
        centre = robot.setdefault("barely_at", float(np.random.default_rng([29, 6, robot["seed"], 1]).uniform(lo[j - 1] * 0.5 + hi[j - 1] * 0.5 - 20, lo[j - 1] * 0.5 + hi[j - 1] * 0.5 + 20)))
        q[:, j - 1] = centre + rng.uniform(-BARELY, BARELY, count)
    return q


def _ballbar_setup(robot: dict, rng) -> None:
    """Three chucks where the spheres reach them at the bar's length, each pairing often enough; pivots and bar
    length held (true as given), the robot base free (true: a small error about 0)."""
    L = robot["device"]["length"]
    truth = robot["truth"]
    q = sample_configurations(robot, 20000, rng)
    cloud = target_points(robot, truth, q, "s2")
    best = None
    for _ in range(60):
        u = rng.normal(size=3)
        u[2] = abs(u[2]) + 0.6
        u /= np.linalg.norm(u)
        centre = cloud[rng.integers(len(cloud))] - L * u
        hits = _band(cloud, centre, L).sum()
        if best is None or hits > best[0]:
            best = (hits, centre)
    centre = best[1]
    phase = rng.uniform(0, 2 * np.pi)
    for k in range(3):
        phi = phase + 2 * np.pi * k / 3
        c = centre + 120.0 * np.array([np.cos(phi), np.sin(phi), 0.0])
        for axis, v in zip("xyz", c):
            name = f"pivot.c{k + 1}.{axis}"
            robot["nominal"][name] = robot["truth"][name] = float(np.round(v, 3))
            robot["units"][name] = "length"
            robot["held"].add(name)
    robot["nominal"]["bar.length"] = robot["truth"]["bar.length"] = L
    robot["units"]["bar.length"] = "length"
    robot["held"].add("bar.length")


def _band(points: np.ndarray, centre: np.ndarray, L: float) -> np.ndarray:
    """Sphere positions a bar seated at centre reads within its travel (MARGIN kept), the sphere above the chuck."""
    v = points - centre
    return (np.abs(np.linalg.norm(v, axis=1) - L) < TRAVEL / 2 - MARGIN) & (v[:, 2] > 0.2 * L)


# ------------------------------------------------------------------------------------------ campaigns
COUNTS = {"tracker": (100, 50), "ballbar": (270, 90), "theodolite": (80, 40)}  # poses: calibration, validation
BAR_SIGHTINGS = 3


def campaign_rows(robot: dict, count: int, rng) -> list:
    """Rows [(key, q)] of one data file: every target at every pose (tracker), every station sighting every target
    and each scale-bar mark BAR_SIGHTINGS times (theodolite), or ``count`` bar readings spread over the nine
    pairings, each within the bar's travel on the true robot (ball-bar)."""
    kind = robot["device"]["type"]
    if kind == "tracker":
        q = sample_configurations(robot, count, rng)
        return [((t,), row) for row in q for t in robot["device"]["targets"]]
    if kind == "theodolite":
        q = sample_configurations(robot, count, rng)
        rows = [((s, t), row) for row in q for s in robot["device"]["stations"] for t in robot["device"]["targets"]]
        rows += [((s, end), None) for s in robot["device"]["stations"] for end in ("scale_bar.end1", "scale_bar.end2")
                 for _ in range(BAR_SIGHTINGS)]
        return rows
    truth, L = robot["truth"], robot["device"]["length"]
    pairs = [(f"c{i}", s) for i in (1, 2, 3) for s in robot["device"]["spheres"]]
    want = int(np.ceil(count / len(pairs)))
    chosen: dict = {k: [] for k in pairs}
    for _ in range(200):
        if min(len(v) for v in chosen.values()) >= want:
            break
        q = sample_configurations(robot, 20000, rng)
        used = np.zeros(len(q), bool)
        for pivot, sphere in pairs:
            centre = np.array([truth[f"pivot.{pivot}.{c}"] for c in "xyz"])
            ok = _band(target_points(robot, truth, q, sphere), centre, L) & ~used
            free = np.flatnonzero(ok)[: want - len(chosen[(pivot, sphere)])]
            chosen[(pivot, sphere)].extend(q[free])
            used[free] = True
    short = {k: len(v) for k, v in chosen.items() if len(v) < want}
    if short:
        raise RuntimeError(f"zoo robot {robot['seed']}: too few ball-bar poses for {short}")
    return [(k, row) for k in pairs for row in chosen[k][:want]][:count]


def true_readings(robot: dict, rows: list, params: dict | None = None) -> np.ndarray:
    return predict(robot, robot["truth"] if params is None else params, rows)


def with_noise(robot: dict, values: np.ndarray, rng) -> np.ndarray:
    return values + rng.normal(0.0, noise_sigma(robot), values.shape)


def write_campaign(folder, robot: dict, stream: int = 0, truth: dict | None = None) -> dict:
    """Simulate a campaign of ``robot`` (its truth, or ``truth`` in its place) into ``folder``: spec.yaml,
    calibration.csv, validation.csv. ``stream`` picks other poses and noise for the same robot (the instrument stays
    where it was). Returns {"spec", "truth", "rows" (calibration rows), "robot"}."""
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng([29, 6, robot["seed"], 2, stream])
    model = dict(robot, truth=truth if truth is not None else robot["truth"])
    files = {}
    for name, count in zip(("calibration", "validation"), COUNTS[robot["device"]["type"]]):
        rows = campaign_rows(model, count, rng)
        values = with_noise(robot, true_readings(model, rows), rng)
        write_csv(folder / f"{name}.csv", robot, rows, values)
        files[name] = rows
    spec = folder / "spec.yaml"
    spec.write_text(spec_text(robot))
    return {"spec": spec, "truth": model["truth"], "rows": files["calibration"], "robot": model}


def write_csv(path: pathlib.Path, robot: dict, rows: list, values: np.ndarray) -> None:
    """Contract columns (docs/devices/*.md): sample, the key columns, q1..qN (spec units), the readings."""
    kind, n = robot["device"]["type"], robot["n"]
    keys = {"tracker": ["target"], "ballbar": ["pivot", "sphere"], "theodolite": ["station", "target"]}[kind]
    reads = {"tracker": ["x", "y", "z"], "ballbar": ["length"], "theodolite": ["azimuth", "elevation"]}[kind]
    digits = 10 if kind == "theodolite" else 7
    lines = [",".join(["sample", *keys, *(f"q{i + 1}" for i in range(n)), *reads])]
    for number, ((key, q), v) in enumerate(zip(rows, values), start=1):
        joints = [""] * n if q is None else [f"{x:.10f}" for x in q]
        lines.append(",".join([str(number), *key, *joints, *(f"{x:.{digits}f}" for x in v)]))
    path.write_text("\n".join(lines) + "\n")


# ---------------------------------------------------------------------------------------------- the spec
def _value(robot: dict, name: str) -> str:
    value = robot["nominal"][name]
    text = f"{0.0 if abs(value) < 1e-9 else value:.10g}"
    return f"{{value: {text}, vary: false}}" if name in robot["held"] else text


def spec_text(robot: dict) -> str:
    """The spec of a zoo robot and its device (docs/spec.md); data files calibration.csv and validation.csv."""
    v = lambda name: _value(robot, name)  # noqa: E731
    n, conv, dev = robot["n"], robot["convention"], robot["device"]
    out = ["# Written by tests/zoo.py (an armcal-independent robot zoo); data simulated.",
           f"# variants: {robot['variants']}",
           "armcal: 1", "robot:", f"  name: {robot['name']}", f"  serial: {robot['serial']}",
           "  units: {length: mm, angle: deg}", f"  convention: {conv}"]
    if dev["type"] == "ballbar":
        out.append("  base: {" + ", ".join(f"{f}: {v(f'base.{f}')}" for f in POSE_FIELDS) + "}")
    if conv == "six_parameter":
        out.append("  links:")
        for i in range(1, n + 2):
            out.append("    - {" + ", ".join(f"{f}: {v(f'L{i}.{f}')}" for f in LINK_FIELDS) + "}")
    out.append("  joints:")
    for i, (kind, (lo, hi)) in enumerate(zip(robot["types"], robot["limits"]), start=1):
        fields = [f"name: j{i}", f"type: {kind}", f"limits: [{lo:.6g}, {hi:.6g}]"]
        if conv == "six_parameter":
            fields += [f"theta0: {v(f'j{i}.theta0')}", f"k: {v(f'j{i}.k')}"]
        else:
            fields += [f"{f}: {v(f'j{i}.{f}')}" for f in DH_FIELDS]
            if conv == "mdh" and f"j{i}.beta" in robot["nominal"]:
                fields.append(f"beta: {v(f'j{i}.beta')}")
        out.append("    - {" + ", ".join(fields) + "}")
    out.append("  targets:")
    for name, link in robot["targets"].items():
        out.append(f"    {name}: {{link: {link}, " + ", ".join(f"{c}: {v(f'{name}.{c}')}" for c in "xyz") + "}")
    out += ["device:", f"  type: {dev['type']}"]
    pose_line = lambda prefix: "{" + ", ".join(f"{f}: {v(f'{prefix}.{f}')}" for f in ("x", "y", "z", "rz", "ry", "rx")) + "}"  # noqa: E731
    if dev["type"] == "tracker":
        out += [f"  targets: [{', '.join(dev['targets'])}]", f"  robot_base: {pose_line('robot_base')}   # registered by armcal",
                f"  noise: {dev['noise']:.6g}"]
    elif dev["type"] == "theodolite":
        out += ["  stations:"]
        out += [f"    {s}: {{pose: {pose_line(f'station.{s}')}}}" for s in dev["stations"]]
        out += [f"  targets: [{', '.join(dev['targets'])}]", f"  robot_base: {pose_line('robot_base')}",
                f"  noise: {dev['noise'] * 3600:.6g} arcsec", "  scale_bar:", f"    length: {dev['bar']:g}",
                f"    noise: {dev['bar_noise']:g}"]
        out += [f"    {end}: {{" + ", ".join(f"{c}: {v(f'scale_bar.{end}.{c}')}" for c in "xyz") + "}" for end in ("end1", "end2")]
    else:
        out.append("  pivots:")
        out += [f"    c{k}: {{" + ", ".join(f"{c}: {v(f'pivot.c{k}.{c}')}" for c in "xyz") + "}" for k in (1, 2, 3)]
        out += [f"  spheres: [{', '.join(dev['spheres'])}]", f"  length: {v('bar.length')}",
                f"  travel: {dev['travel']:g}", f"  noise: {dev['noise']:.6g}"]
    if dev["type"] == "ballbar":
        pairings = ", ".join(f"{{pivot: c{k}, sphere: {s}}}" for k in (1, 2, 3) for s in dev["spheres"])
        for section in ("procedure", "validation"):
            out += [f"{section}:", "  type: shells", f"  pairings: [{pairings}]", "  latitudes: [20, 40, 60, 80]",
                    "  longitudes: 12"]
    else:
        out += ["procedure: {type: poses, count: 100, seed: 1}", "validation: {type: poses, count: 50, seed: 2}"]
    out.append("data: {calibration: calibration.csv, validation: validation.csv}")
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------------- the truth in a base set
def _weighted(robot: dict, p: dict, rows: list) -> np.ndarray:
    """All readings of rows in noise sigmas (plus the scale bar's length for a theodolite)."""
    r = predict(robot, p, rows).ravel() / noise_sigma(robot)
    if robot["device"]["type"] == "theodolite":
        r = np.append(r, bar_length(p) / robot["device"]["bar_noise"])
    return r


def step_size(robot: dict, name: str) -> float:
    return {"length": 1e-4, "angle": 1e-5, "scale": 1e-7}[robot["units"][name]]


def jacobian(robot: dict, p: dict, rows: list, names: list) -> np.ndarray:
    """d (weighted readings) / d (values ``names``, spec units), central differences."""
    columns = []
    for name in names:
        h = step_size(robot, name)
        up, down = dict(p), dict(p)
        up[name] += h
        down[name] -= h
        columns.append((_weighted(robot, up, rows) - _weighted(robot, down, rows)) / (2 * h))
    return np.column_stack(columns)


def equivalent_truth(robot: dict, truth: dict, rows: list, held_values: dict, free: list, iterations: int = 12) -> dict:
    """The free values that, with the others at ``held_values`` (the values the fit held them at), reproduce the
    true readings of ``rows`` best in noise sigmas (Gauss-Newton from the truth). Returns {"values",
    "rms_sigma" (the remaining misfit, RMS in noise sigmas), "condition"}."""
    target = _weighted(robot, truth, rows)
    p = {**truth, **held_values}
    for _ in range(iterations):
        r = _weighted(robot, p, rows) - target
        J = jacobian(robot, p, rows, free)
        scale = np.linalg.norm(J, axis=0)
        scale[scale == 0] = 1.0
        step = np.linalg.lstsq(J / scale, -r, rcond=1e-13)[0] / scale
        for name, s in zip(free, step):
            p[name] += s
        if np.max(np.abs(step * scale)) < 1e-10:
            break
    r = _weighted(robot, p, rows) - target
    s = np.linalg.svd(J / scale, compute_uv=False)
    return {"values": {k: p[k] for k in free}, "rms_sigma": float(np.sqrt(np.mean(r ** 2))),
            "condition": float(s[0] / s[-1]) if s[-1] > 0 else float("inf")}
