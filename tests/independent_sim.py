"""Independent campaign simulator: a test oracle for armcal, written from the docs only.

Nothing here imports armcal. The kinematics follow the textbook definitions
(standard DH, A_i = Rz(theta_i + q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), plus Hayati's
Ry(beta) on nominally parallel axes in the true robot); the devices follow
docs/devices/tracker.md and docs/devices/ballbar.md; the hidden effects follow the
formulas of docs/effects.md.

    info = write_campaign(folder, "puma560", "tracker", "gear_harmonic", seed=3, sigmas=3.0)

writes folder/spec.yaml (byte-identical for a given robot and device), calibration.csv
and validation.csv, and returns the spec path, the hidden effect and the truth.
``effect["rms_visible"]`` is the RMS of the part of the signature a refit geometry cannot
absorb; with v = rms_visible / noise and N calibration readings, ``noncentrality`` = N v^2
and ``expected_statistic`` = N v^2 / (1 + v^2), the score statistic to expect for the right
candidate when the score is normalised by the residual variance (what armcal's scores
matched in the checks). Below ~15, or with ``visible_fraction`` under 0.05 (armcal then
calls the candidate "not distinguishable"), the diagnosis cannot be expected to find the
effect: the ball-bar campaigns absorb 90-98 % of a joint-2/3 compliance or encoder scale.
"""

from __future__ import annotations

import pathlib

import numpy as np

DEG = np.pi / 180.0
G = np.array([0.0, 0.0, -9.81])  # m/s^2, along -z of the base frame (docs/effects.md)
DEFAULT_MASS = 5.0  # kg at the origin of each frame F_j..F_n (docs/effects.md)
# The spec says convention dh; armcal itself adds Hayati's beta (free) on each parallel pair
# and holds that joint's d ("armcal validate" prints it), which is the truth's form here.

# name: (DH rows (theta, d, a, alpha) in mm/deg, limits, sampling centre, sampling half-width)
ROBOTS = {
    "puma560": dict(  # Stone Table 6-2 / Craig, in mm; axes 2 and 3 parallel
        dh=[(0, 0, 0, -90), (0, 149.09, 431.8, 0), (0, 0, -20.32, 90),
            (0, 433.07, 0, -90), (0, 0, 0, 90), (0, 0, 0, 0)],
        limits=[(-160, 160), (-225, 45), (-45, 225), (-110, 170), (-100, 100), (-266, 266)],
        centre=[0, -60, 150, 30, 0, 0], half=[90, 60, 60, 90, 90, 150], name="PUMA 560"),
    "ur_like": dict(  # UR10 manufacturer's DH; axes 2, 3 and 4 parallel
        dh=[(0, 127.3, 0, 90), (0, 0, -612.0, 0), (0, 0, -572.3, 0),
            (0, 163.941, 0, 90), (0, 115.7, 0, -90), (0, 92.2, 0, 0)],
        limits=[(-360, 360)] * 6,
        centre=[0, -90, 90, -90, -90, 0], half=[90, 60, 60, 90, 60, 180], name="UR10-like"),
}
TRACKER = dict(target=(50.0, 30.0, 80.0), noise=0.02,
               base=dict(x=2000.0, y=-500.0, z=300.0, rz=30.0, ry=1.0, rx=-2.0))
BALLBAR = dict(noise=0.005, length=460.0, travel=75.0,
               spheres={"s1": (60.0, 0.0, 80.0), "s2": (-30.0, 51.962, 80.0), "s3": (-30.0, -51.962, 80.0)},
               pivots={"puma560": {"c1": (565.0, 0.0, -400.0), "c2": (392.5, 100.0, -400.0), "c3": (392.5, -100.0, -400.0)},
                       "ur_like": {"c1": (-650.0, 0.0, 0.0), "c2": (-477.5, 100.0, 0.0), "c3": (-477.5, -100.0, 0.0)}})
COUNTS = {"tracker": (120, 60), "ballbar": (153, 63)}  # calibration, validation samples


# ----------------------------------------------------------------------------- kinematics
def link(theta, d, a, alpha, beta=0.0):
    """Batched A = Rz(theta) Tz(d) Tx(a) Rx(alpha) Ry(beta); theta may be an array (N,)."""
    theta = np.asarray(theta, float)
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    A = np.zeros(theta.shape + (4, 4))
    A[..., 0, :] = np.stack([ct, -st * ca, st * sa, a * ct], -1)
    A[..., 1, :] = np.stack([st, ct * ca, -ct * sa, a * st], -1)
    A[..., 2, :] = np.stack([0 * ct, sa + 0 * ct, ca + 0 * ct, d + 0 * ct], -1)
    A[..., 3, 3] = 1.0
    cb, sb = np.cos(beta), np.sin(beta)
    Ry = np.array([[cb, 0, sb, 0], [0, 1, 0, 0], [-sb, 0, cb, 0], [0, 0, 0, 1.0]])
    return A @ Ry


def frames(geom, q):
    """Frames F_0 = I, F_i = F_(i-1) A_i(q_i) for joint angles q (N, n) in rad: (n+1, N, 4, 4)."""
    F = [np.broadcast_to(np.eye(4), (len(q), 4, 4))]
    for i, (theta, d, a, alpha, beta) in enumerate(geom["rows"]):
        F.append(F[-1] @ link(theta + q[:, i], d, a, alpha, beta))
    return np.stack(F)


def pose(x, y, z, rz, ry, rx):
    """Trans(x, y, z) Rot(z, rz) Rot(y, ry) Rot(x, rx), angles in rad."""
    c, s = np.cos, np.sin
    Rz = np.array([[c(rz), -s(rz), 0], [s(rz), c(rz), 0], [0, 0, 1]])
    Ry = np.array([[c(ry), 0, s(ry)], [0, 1, 0], [-s(ry), 0, c(ry)]])
    Rx = np.array([[1, 0, 0], [0, c(rx), -s(rx)], [0, s(rx), c(rx)]])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = Rz @ Ry @ Rx, (x, y, z)
    return T


def gravity_torque(F, j):
    """tau_j = sum_{k=j..n} z_(j-1) . ((o_k - o_(j-1)) x m g), default 5 kg at each o_k, in N m."""
    z, o = F[j - 1][:, :3, 2], F[j - 1][:, :3, 3]
    tau = np.zeros(len(z))
    for k in range(j, len(F)):
        r = (F[k][:, :3, 3] - o) / 1000.0  # mm -> m
        tau += np.einsum("ij,ij->i", z, np.cross(r, DEFAULT_MASS * G))
    return tau


def joint_angles(geom, q, effect, amp):
    """Joint angles the chain sees, q + Delta_j (docs/effects.md), for effect amplitude amp."""
    q = q.copy()
    if effect is None or amp == 0.0:
        return q
    j, qj = effect["joint"], q[:, effect["joint"] - 1]
    if effect["type"] == "gear_harmonic":  # Delta = A sin(h q) + B cos(h q), r = 1
        h, phi = effect["order"], effect["phase"]
        delta = amp * (np.cos(phi) * np.sin(h * qj) + np.sin(phi) * np.cos(h * qj))
    elif effect["type"] == "encoder_scale":  # Delta = s q
        delta = amp * qj
    else:  # joint_compliance: Delta = c tau_j(q), torque from the chain at the readings
        delta = amp * gravity_torque(frames(geom, q), j)
    q[:, j - 1] += delta
    return q


def readings(geom, device, q, keys, effect=None, amp=0.0):
    """Noise-free readings, flattened: tracker x, y, z per row; ball-bar length per row."""
    F6 = frames(geom, joint_angles(geom, q, effect, amp))[-1]
    if device == "tracker":
        p = F6 @ np.append(geom["targets"]["smr"], 1.0)
        return (p @ geom["robot_base"].T)[:, :3].ravel()
    out = np.empty(len(q))
    for idx, (pivot, sphere) in enumerate(keys):
        s = F6[idx] @ np.append(geom["targets"][sphere], 1.0)
        out[idx] = np.linalg.norm(s[:3] - geom["pivots"][pivot])
    return out


# ------------------------------------------------------------------------------- the truth
def true_geometry(robot, device, rng):
    """Nominal DH + manufacturing errors (0.3 mm, 0.03 deg), Hayati beta on parallel axes."""
    rows, truth = [], {}
    dh = ROBOTS[robot]["dh"]
    for i, (theta, d, a, alpha) in enumerate(dh):
        parallel = alpha == 0 and i + 1 < len(dh)
        dev = dict(theta=rng.normal(0, 0.03), d=0.0 if parallel else rng.normal(0, 0.3),
                   a=rng.normal(0, 0.3), alpha=rng.normal(0, 0.03))
        if parallel:
            dev["beta"] = rng.choice([-1, 1]) * rng.uniform(0.02, 0.05)
        truth.update({f"j{i + 1}.{k}": float(v) for k, v in dev.items()})
        rows.append(((theta + dev["theta"]) * DEG, d + dev["d"], a + dev["a"],
                     (alpha + dev["alpha"]) * DEG, dev.get("beta", 0.0) * DEG))
    nominal = {"smr": TRACKER["target"]} if device == "tracker" else BALLBAR["spheres"]
    targets = {}
    for name, xyz in nominal.items():
        err = rng.normal(0, 0.3, 3)
        truth.update({f"{name}.{k}": float(v) for k, v in zip("xyz", err)})
        targets[name] = np.array(xyz) + err
    geom = dict(rows=rows, targets=targets, parallel=[a == 0 and i + 1 < len(dh) for i, (_, _, _, a) in enumerate(dh)])
    if device == "tracker":
        b = TRACKER["base"]
        geom["robot_base"] = pose(b["x"], b["y"], b["z"], b["rz"] * DEG, b["ry"] * DEG, b["rx"] * DEG)
        truth["robot_base"] = dict(b)
    else:
        geom["pivots"] = {k: np.array(v) for k, v in BALLBAR["pivots"][robot].items()}
    return geom, truth


def sample_configurations(robot, count, rng):
    """Uniform configurations around a comfortable one, redrawn within 15 deg of the wrist
    singularity (sin q5 = 0) and clipped to the joint limits."""
    spec = ROBOTS[robot]
    c, h = np.array(spec["centre"], float), np.array(spec["half"], float)
    lim = np.array(spec["limits"], float)
    q = rng.uniform(c - h, c + h, (count, 6))
    while (bad := np.abs(np.sin(q[:, 4] * DEG)) < np.sin(15 * DEG)).any():
        q[bad] = rng.uniform(c - h, c + h, (int(bad.sum()), 6))
    return np.clip(q, lim[:, 0] + 1, lim[:, 1] - 1)


def ballbar_poses(robot, geom, count, rng):
    """Configurations whose true sphere-to-pivot distance is within the travel (10 mm margin),
    spread evenly over the nine pairings, each with the sphere above its pivot."""
    pairs = [(p, s) for p in geom["pivots"] for s in geom["targets"]]
    want = int(np.ceil(count / len(pairs)))
    chosen = {k: [] for k in pairs}
    half = BALLBAR["travel"] / 2 - 10.0
    while min(len(v) for v in chosen.values()) < want:
        q = sample_configurations(robot, 20000, rng)
        F6 = frames(geom, q * DEG)[-1]
        for pivot, sphere in pairs:
            s = (F6 @ np.append(geom["targets"][sphere], 1.0))[:, :3] - geom["pivots"][pivot]
            ok = (np.abs(np.linalg.norm(s, axis=1) - BALLBAR["length"]) < half) & (s[:, 2] > 0.2 * BALLBAR["length"])
            free = np.flatnonzero(ok & ~np.isnan(q[:, 0]))[: want - len(chosen[(pivot, sphere)])]
            chosen[(pivot, sphere)].extend(q[free])
            q[free] = np.nan  # each configuration is used once
    keys = [k for k in pairs for _ in range(want)][:count]
    return np.array([q for k in pairs for q in chosen[k][:want]])[:count], keys


def visible_part(geom, device, q, keys, signature, eps=1e-5):
    """The signature minus its least-squares projection onto the columns of the spec's free
    geometry (theta d a alpha per joint, beta instead of d on parallel axes, target offsets,
    the tracker pose): what a fitted geometric model cannot absorb. Central differences."""
    J = geometry_jacobian(geom, device, q, keys, eps)
    J /= np.linalg.norm(J, axis=0) + 1e-300
    return signature - J @ np.linalg.lstsq(J, signature, rcond=1e-10)[0]


def geometry_changes(geom, device):
    """The spec's free geometry as changes (kind, index, field): DH rows (theta d a alpha, beta
    instead of d on parallel axes), target offsets, small shifts and turns of the tracker frame."""
    changes = [("row", i, f) for i, par in enumerate(geom["parallel"]) for f in range(5)
               if (f != 1 or not par) and (f != 4 or par)]
    changes += [("target", name, k) for name in geom["targets"] for k in range(3)]
    return changes + ([("base", None, k) for k in range(6)] if device == "tracker" else [])


def changed(geom, change, s):
    """A copy of geom with one change (geometry_changes) of size s (rad, mm)."""
    kind, index, f = change
    g = geom_copy(geom)
    if kind == "row":
        row = list(g["rows"][index]); row[f] += s; g["rows"][index] = tuple(row)
    elif kind == "target":
        g["targets"][index] = g["targets"][index] + s * np.eye(3)[f]
    else:  # a small translation / rotation of the tracker frame
        g["robot_base"] = small_motion(f, s) @ g["robot_base"]
    return g


def small_motion(f, s):
    """A shift of s along axis f (0-2) or a turn of s about axis f - 3 (3-5), to first order, as a 4x4 transform."""
    T = np.eye(4)
    if f < 3:
        T[f, 3] = s
    else:
        a, b = [m for m in range(3) if m != f - 3]
        T[a, b], T[b, a] = -s, s
    return T


def geometry_jacobian(geom, device, q, keys, eps=1e-5):
    """d readings / d geometry (geometry_changes' columns), central differences."""
    column = lambda c: (readings(changed(geom, c, eps), device, q, keys) - readings(changed(geom, c, -eps), device, q, keys)) / (2 * eps)  # noqa: E731
    return np.column_stack([column(c) for c in geometry_changes(geom, device)])


def geom_copy(geom):
    """A copy deep enough for visible_part's changes."""
    return dict(geom, rows=list(geom["rows"]), targets=dict(geom["targets"]))


# ------------------------------------------------------------------------------ the files
def spec_text(robot, device):
    """The spec (no effects); depends only on (robot, device)."""
    r = ROBOTS[robot]
    lines = ["# Written by tests/independent_sim.py (an armcal-independent simulator). Data simulated;",
             "# the hidden effect is not declared: the diagnosis must find it.",
             "armcal: 1", "robot:", f"  name: {r['name']}", f"  serial: INDEP-{robot.upper()}-{device.upper()}",
             "  units: {length: mm, angle: deg}", "  convention: dh", "  joints:"]
    for i, ((theta, d, a, alpha), (lo, hi)) in enumerate(zip(r["dh"], r["limits"])):
        lines.append(f"    - {{name: j{i + 1}, limits: [{lo:g}, {hi:g}], theta: {theta:g}, d: {d:g}, "
                     f"a: {a:g}, alpha: {alpha:g}}}")
    lines.append("  targets:")
    if device == "tracker":
        x, y, z = TRACKER["target"]
        lines += [f"    smr: {{link: 6, x: {x:g}, y: {y:g}, z: {z:g}}}",
                  "device:", "  type: tracker", "  targets: [smr]",
                  "  robot_base: {x: 2000, y: 0, z: 0, rz: 0, ry: 0, rx: 0}   # registered by armcal",
                  f"  noise: {TRACKER['noise']:g}",
                  "procedure: {type: poses, count: 120, seed: 1}",
                  "validation: {type: poses, count: 60, seed: 2}"]
    else:
        lines += [f"    {n}: {{link: 6, x: {x:g}, y: {y:g}, z: {z:g}}}" for n, (x, y, z) in BALLBAR["spheres"].items()]
        lines += ["device:", "  type: ballbar", "  pivots:"]
        fix = "{{value: {:g}, vary: false}}".format
        lines += [f"    {n}: {{x: {fix(x)}, y: {fix(y)}, z: {fix(z)}}}"
                  for n, (x, y, z) in BALLBAR["pivots"][robot].items()]
        lines += ["  spheres: [s1, s2, s3]", f"  length: {{value: {BALLBAR['length']:g}, vary: false}}",
                  f"  travel: {BALLBAR['travel']:g}", f"  noise: {BALLBAR['noise']:g}"]
        pairings = ", ".join(f"{{pivot: {p}, sphere: {s}}}" for p in BALLBAR["pivots"][robot] for s in BALLBAR["spheres"])
        for section in ("procedure", "validation"):
            lines += [f"{section}:", "  type: shells", f"  pairings: [{pairings}]",
                      "  latitudes: [20, 40, 60, 80]", "  longitudes: 12"]
    lines.append("data: {calibration: calibration.csv, validation: validation.csv}")
    return "\n".join(lines) + "\n"


def write_csv(path, device, q_deg, keys, values):
    """Contract columns: sample, target|pivot,sphere, q1..q6, x,y,z|length (mm, deg)."""
    head = ["sample"] + (["target"] if device == "tracker" else ["pivot", "sphere"])
    head += [f"q{i + 1}" for i in range(q_deg.shape[1])] + (["x", "y", "z"] if device == "tracker" else ["length"])
    vals = values.reshape(len(q_deg), -1)
    rows = [",".join(head)]
    for n, (q, key, v) in enumerate(zip(q_deg, keys, vals), start=1):
        rows.append(",".join([str(n), *key] + [f"{x:.10f}" for x in q] + [f"{x:.6f}" for x in v]))
    path.write_text("\n".join(rows) + "\n")


def write_campaign(folder: pathlib.Path, robot: str, device: str, effect: str, seed: int, sigmas: float,
                   *, joint: int | None = None, order: int | None = None, visible: bool = False) -> dict:
    """Simulate one campaign into ``folder``; return {"spec", "effect", "truth"}.

    The true robot is the nominal one with manufacturing errors and Hayati tilts, plus one
    hidden ``effect`` whose RMS signature on the calibration readings (every scalar reading:
    a tracker coordinate or a bar length) is ``sigmas`` noise sigmas, plus Gaussian noise.
    ``visible=True`` scales the part of the signature the geometry cannot absorb instead
    (see visible_part); ``joint``/``order`` override the random choice of the effect.
    "truth" holds the deviations from the spec's nominal values named as armcal names them
    (j2.a mm, j2.theta/alpha/beta deg, smr.x mm...) and the true tracker pose "robot_base".
    """
    assert robot in ROBOTS and device in COUNTS and 2 <= sigmas <= 5
    assert effect in ("gear_harmonic", "encoder_scale", "joint_compliance")
    rng = np.random.default_rng(seed)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    geom, truth = true_geometry(robot, device, rng)
    noise = TRACKER["noise"] if device == "tracker" else BALLBAR["noise"]
    j = joint or int(rng.integers(2, 4) if effect == "joint_compliance" else rng.integers(2, 6))
    eff = dict(type=effect, joint=j, order=None, phase=None)
    if effect == "gear_harmonic":
        eff["order"] = order or int(rng.integers(1, 3))
        eff["phase"] = rng.uniform(0, 2 * np.pi)
    sign = 1.0 if effect == "joint_compliance" else rng.choice([-1.0, 1.0])  # compliance c > 0

    sets = []
    for count in COUNTS[device]:
        if device == "tracker":
            q = sample_configurations(robot, count, rng)
            keys = [("smr",)] * count
        else:
            q, keys = ballbar_poses(robot, geom, count, rng)
            keys = list(keys)
        sets.append((q, keys))

    # amplitude so that the signature's RMS on the calibration readings is sigmas * noise
    q_cal, k_cal = sets[0]
    base = readings(geom, device, q_cal * DEG, k_cal)
    amp = 1e-5 * sign
    for _ in range(3):
        signature = readings(geom, device, q_cal * DEG, k_cal, eff, amp) - base
        seen = visible_part(geom, device, q_cal * DEG, k_cal, signature) if visible else signature
        amp *= sigmas * noise / np.sqrt(np.mean(seen ** 2))
    signature = readings(geom, device, q_cal * DEG, k_cal, eff, amp) - base
    rms_raw = float(np.sqrt(np.mean(signature ** 2)))
    rms_visible = float(np.sqrt(np.mean(visible_part(geom, device, q_cal * DEG, k_cal, signature) ** 2)))
    v2 = (rms_visible / noise) ** 2

    for name, (q, keys) in zip(("calibration.csv", "validation.csv"), sets):
        y = readings(geom, device, q * DEG, keys, eff, amp)
        write_csv(folder / name, device, q, keys, y + rng.normal(0, noise, y.shape))
    spec = folder / "spec.yaml"
    spec.write_text(spec_text(robot, device))

    if effect == "gear_harmonic":
        tag = f"gear_harmonic.j{j}.h{eff['order']}"
        values = {"sin": amp * np.cos(eff["phase"]) / DEG, "cos": amp * np.sin(eff["phase"]) / DEG}  # deg
    elif effect == "encoder_scale":
        tag, values = f"encoder_scale.j{j}", {"scale": amp}
    else:
        tag, values = f"joint_compliance.j{j}", {"compliance": amp}  # rad / (N m), default masses
    values = {k: float(v) for k, v in values.items()}
    return {"spec": spec,
            "effect": {"type": effect, "joint": j, "order": eff["order"], "values": values,
                       "armcal_names": {f"{tag}.{k}": v for k, v in values.items()},
                       "rms_signature": rms_raw, "rms_visible": rms_visible, "noise": noise,
                       "visible_fraction": rms_visible / rms_raw,
                       "noncentrality": len(signature) * (rms_visible / noise) ** 2,
                       "expected_statistic": len(signature) * v2 / (1 + v2)},
            "truth": truth,
            "geometry": geom, "hidden": (eff, amp)}  # readings(geometry, device, q, keys, *hidden): the true robot


# ------------------------------------------------------------------ a robot set up at stations
STATIONS = {  # the robot base frame in the tracker frame at each set-up (mm, deg)
    "s1": dict(x=2000.0, y=-500.0, z=300.0, rz=30.0, ry=1.0, rx=-2.0),
    "s2": dict(x=-1800.0, y=900.0, z=-200.0, rz=-140.0, ry=-2.0, rx=1.5),
    "s3": dict(x=300.0, y=2500.0, z=100.0, rz=95.0, ry=3.0, rx=0.5),
    "n1": dict(x=2400.0, y=400.0, z=-100.0, rz=175.0, ry=-1.0, rx=2.5),
    "n2": dict(x=-600.0, y=-2200.0, z=250.0, rz=-60.0, ry=2.0, rx=-1.0),
}


def write_stationed_campaign(folder: pathlib.Path, seed: int, errors: dict[str, float], *, poses: int = 60,
                             register: int = 8, evaluate: int = 25, bend=(0.0, 0.0, 0.0)) -> dict:
    """A PUMA 560 with a tracker, its base set up at calibration stations s1, s2, s3 (``poses`` configurations
    each) and at held-out stations n1, n2 (``register`` rows marked use: register, then ``evaluate`` rows), from
    docs/devices/tracker.md's station columns. The true robot is the nominal one plus ``errors`` (armcal's names:
    j2.a mm, j2.alpha deg, smr.x mm...) and a bend of the target, ``bend`` (mm, the robot's base frame) times
    sin(2 (q2 + q3)), that no effect of the vocabulary expresses. Writes spec.yaml, calibration.csv, validation.csv;
    returns the truth, the noise drawn per file (n, 3) and the true readings' Jacobians the held-out statistics need."""
    rng = np.random.default_rng(seed)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    geom = dict(stationed_geometry(errors), bend=np.asarray(bend, dtype=float))
    noise = TRACKER["noise"]
    drawn = {}
    calibration, validation = [], []
    for name in ("s1", "s2", "s3"):
        calibration += [(name, "", q) for q in sample_configurations("puma560", poses, rng)]
    for name in ("n1", "n2"):
        validation += [(name, "register", q) for q in sample_configurations("puma560", register, rng)]
        validation += [(name, "evaluate", q) for q in sample_configurations("puma560", evaluate, rng)]
    for file, rows in (("calibration.csv", calibration), ("validation.csv", validation)):
        head = ["sample", "target", "station", *(f"q{i}" for i in range(1, 7)), "x", "y", "z"] + (["use"] if file == "validation.csv" else [])
        lines = [",".join(head)]
        drawn[file] = []
        for n, (station, use, q) in enumerate(rows, start=1):
            drawn[file].append(rng.normal(0, noise, 3))
            y = station_readings(geom, station, q[None] * DEG)[0] + drawn[file][-1]
            lines.append(",".join([str(n), "smr", station, *(f"{v:.10f}" for v in q), *(f"{v:.6f}" for v in y)] + ([use] if use else [])))
        (folder / file).write_text("\n".join(lines) + "\n")
    text = spec_text("puma560", "tracker").replace("count: 120", f"count: {poses}")
    stations = "".join(f"\n    {s}: {{robot_base: {{x: 0, y: 0, z: 0, rz: 0, ry: 0, rx: 0}}}}   # registered by armcal" for s in ("s1", "s2", "s3"))
    text = text.replace("  noise:", "  stations:" + stations + "\n  noise:", 1)
    (folder / "spec.yaml").write_text(text)
    return {"spec": folder / "spec.yaml", "geometry": geom, "noise": noise, "drawn": {f: np.array(d) for f, d in drawn.items()},
            "calibration": calibration, "validation": validation}


def stationed_geometry(errors: dict[str, float]):
    """The nominal PUMA 560 DH rows (Hayati beta on the parallel pair) and tracker target, plus ``errors``."""
    rows = []
    for i, (theta, d, a, alpha) in enumerate(ROBOTS["puma560"]["dh"]):
        e = lambda field: errors.get(f"j{i + 1}.{field}", 0.0)  # noqa: E731
        rows.append(((theta + e("theta")) * DEG, d + e("d"), a + e("a"), (alpha + e("alpha")) * DEG, e("beta") * DEG))
    target = np.array(TRACKER["target"]) + [errors.get(f"smr.{c}", 0.0) for c in "xyz"]
    frames_ = {s: pose(f["x"], f["y"], f["z"], f["rz"] * DEG, f["ry"] * DEG, f["rx"] * DEG) for s, f in STATIONS.items()}
    return dict(rows=rows, targets={"smr": target}, stations=frames_)


def station_readings(geom, station, q):
    """Noise-free x, y, z (N, 3) of the target at joint angles q (N, 6, rad) with the base at ``station``, bent by
    geom's ``bend`` (if any) times sin(2 (q2 + q3)) in the base frame."""
    p = frames(geom, q)[-1] @ np.append(geom["targets"]["smr"], 1.0)
    p[:, :3] += np.sin(2 * (q[:, 1] + q[:, 2]))[:, None] * geom.get("bend", np.zeros(3))
    return (p @ geom["stations"][station].T)[:, :3]


def station_jacobians(geom, station, q, names, eps=1e-6):
    """d readings / d (the robot's ``names``, armcal's, mm and deg) and d readings / d (the station frame: small
    shifts and turns), flattened per reading, central differences."""
    def robot(name, s):
        field_of = {"theta": 0, "d": 1, "a": 2, "alpha": 3, "beta": 4}
        g = dict(geom, rows=list(geom["rows"]), targets=dict(geom["targets"]))
        head, field = name.split(".")
        if head == "smr":
            g["targets"]["smr"] = g["targets"]["smr"] + s * np.eye(3)["xyz".index(field)]
        else:
            i, f = int(head[1:]) - 1, field_of[field]
            row = list(g["rows"][i]); row[f] += s * (DEG if f in (0, 3, 4) else 1.0); g["rows"][i] = tuple(row)
        return station_readings(g, station, q).ravel()
    def frame(k, s):
        g = dict(geom, stations={station: geom["stations"][station] @ small_motion(k, s)})
        return station_readings(g, station, q).ravel()
    J_robot = np.column_stack([(robot(n, eps) - robot(n, -eps)) / (2 * eps) for n in names])
    J_frame = np.column_stack([(frame(k, eps) - frame(k, -eps)) / (2 * eps) for k in range(6)])
    return J_robot, J_frame
