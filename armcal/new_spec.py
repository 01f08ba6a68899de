"""`armcal new`: a commented starting spec for one library robot and one measuring device.

The robot section is the library file's text (its sources kept as comments), followed by the
targets the device needs; the device, procedure, data and simulate sections are laid out for the
robot's size from the reference setups shipped in specs/ (Stone's digitizer, Goswami's ball-bar
fixture, the two-theodolite network), scaled by the robot's size against the PUMA 560's.
"""

from __future__ import annotations

import json

from pathlib import Path

from armcal.robot_library import LibraryRobot

DEVICES = ("tracker", "ballbar", "theodolite", "sonic_digitizer")
PUMA_SIZE = 885.0  # mm, a2 + a3 + d4 of the PUMA 560 (Stone Table 6-2): the reference setups' robot


def robot_size(entry: LibraryRobot) -> float:
    """The arm's length in mm: the sum of |a| and |d| beyond the first joint, plus its a."""
    joints = entry.robot.joints
    return abs(joints[0].a.value) + sum(abs(j.a.value) + abs(j.d.value) for j in joints[1:])


def new_spec_text(entry: LibraryRobot, device: str, stem: str) -> str:
    """The whole spec for ``entry`` measured by ``device``; its data files are named after ``stem``."""
    s = robot_size(entry) / PUMA_SIZE
    targets, sections = _LAYOUTS[device](entry, s)
    validation = device != "sonic_digitizer"
    lines = [
        f"# {entry.robot.name} measured by a {device.replace('_', ' ')}: a starting spec written by",
        f"# `armcal new --robot {entry.name} --device {device}`. The robot section is the library's",
        f"# (specs/robots/{entry.path.name}); the instrument's placement and the targets are placeholders",
        "# scaled to the robot's size: measure your setup and replace them. Rehearse with",
        f"# `armcal simulate {stem}.yaml --out .` then `armcal run {stem}.yaml` (docs/robots.md).",
        "armcal: 1",
        "data:",
        f"  calibration: {json.dumps(stem + '-calibration.csv')}",
        *([f"  validation: {json.dumps(stem + '-validation.csv')}"] if validation else []),
        "simulate:   # a simulated true robot for a rehearsal (Stone 7.1-7.8 manufacturing errors)",
        "  seed: 1",
        *_robot_lines(entry),
        "  targets:",
        *(f"    {line}" for line in targets),
        *sections,
    ]
    return "\n".join(lines) + "\n"


def _robot_lines(entry: LibraryRobot) -> list[str]:
    """The library file's lines, its home turned into a comment (a spec has no home key)."""
    return [f"# {line}" if line.startswith("home:") else line for line in entry.text.rstrip("\n").splitlines()]


def _mm(value: float) -> str:
    return f"{round(value, 1):g}"


def _flange_point(entry: LibraryRobot, name: str, x: float = 50.0, z: float = 100.0) -> str:
    return f"{name}: {{link: {entry.robot.dof}, x: {_mm(x)}, y: 0, z: {_mm(z)}}}   # on the flange, flange frame (mm)"


def _poses(count: int, seed: int) -> list[str]:
    return ["  type: poses", f"  count: {count}   # random poses within the joint limits", f"  seed: {seed}"]


def _tracker(entry: LibraryRobot, s: float) -> tuple[list[str], list[str]]:
    return [_flange_point(entry, "reflector")], [
        "device:",
        "  type: tracker",
        "  targets: [reflector]",
        "  # Robot base in the tracker frame (placeholder: tracker in front of the robot, facing it);",
        "  # free, identified with the robot.",
        f"  robot_base: {{x: {_mm(max(3000.0, 3000.0 * s))}, y: 0, z: 0, rz: 180, ry: 0, rx: 0}}",
        "  noise: 0.025   # mm, the tracker's stated 1-sigma",
        "procedure:",
        *_poses(150, 1),
        "validation:",
        *_poses(75, 2),
    ]


def _theodolite(entry: LibraryRobot, s: float) -> tuple[list[str], list[str]]:
    fixed = "{value: 0, vary: false}"
    return [_flange_point(entry, "ball")], [
        "device:",
        "  type: theodolite",
        "  # World frame at station t1; the robot stands in front of the baseline (as specs/puma560_theodolite.yaml).",
        "  stations:",
        f"    t1: {{pose: {{x: {fixed}, y: {fixed}, z: {fixed}}}}}",
        f"    t2: {{pose: {{x: {_mm(3000 * s)}, y: 0.0, z: 0.0}}}}",
        "  targets: [ball]",
        f"  robot_base: {{x: {_mm(1500 * s)}, y: {_mm(2500 * s)}, z: {_mm(-1200 * s)}, rz: -90.0, ry: 0.0, rx: 0.0}}",
        "  noise: 2 arcsec",
        "  scale_bar:   # fixes the network's scale: its calibrated length and its marks' rough positions",
        f"    length: {_mm(1000 * s)}",
        "    noise: 0.01",
        f"    end1: {{x: {_mm(1000 * s)}, y: {_mm(1500 * s)}, z: {_mm(-1000 * s)}}}",
        f"    end2: {{x: {_mm(2000 * s)}, y: {_mm(1500 * s)}, z: {_mm(-1000 * s)}}}",
        "procedure:",
        *_poses(150, 3),
        "validation:",
        *_poses(75, 4),
    ]


def _ballbar(entry: LibraryRobot, s: float) -> tuple[list[str], list[str]]:
    # Goswami's fixture: three spheres 60 mm off the flange axis, 80 mm out; three chucks on the table.
    spheres = [(60.0, 0.0), (-30.0, 51.962), (-30.0, -51.962)]
    targets = [f"sphere{i}: {{link: {entry.robot.dof}, x: {x:g}, y: {y:g}, z: 80}}" for i, (x, y) in enumerate(spheres, 1)]
    chucks = [(565.0, 0.0), (392.5, 100.0), (392.5, -100.0)]
    pairings = [f"    - {{pivot: chuck{p}, sphere: sphere{q}}}" for p in (1, 2, 3) for q in (1, 2, 3)]
    shells = ["  latitudes: [20, 35, 50, 65, 80]", "  longitudes: 23"]
    return targets, [
        "device:",
        "  type: ballbar",
        "  # Three magnetic chucks on a fixture in front of the robot, robot base frame (placeholders",
        "  # scaled from Goswami's PUMA fixture, specs/goswami_puma560.yaml).",
        "  pivots:",
        *(f"    chuck{i}: {{x: {_mm(x * s)}, y: {_mm(y * s)}, z: 0.0}}" for i, (x, y) in enumerate(chucks, 1)),
        "  spheres: [sphere1, sphere2, sphere3]",
        f"  length: {{value: {_mm(460 * s)}, vary: false}}   # centre-to-centre at mid-travel",
        f"  extension_rods: {{rod: {_mm(150 * s)}}}",
        f"  travel: {_mm(75 * s)}",
        "  noise: 0.084   # mm (Goswami's residual level)",
        "procedure:",
        "  type: shells",
        "  pairings:",
        *pairings,
        *shells,
        "validation:   # the same pairings with the extension rod: held-out shells",
        "  type: shells",
        "  pairings:",
        *pairings,
        *shells,
        "  extension: rod",
    ]


def _sonic(entry: LibraryRobot, s: float) -> tuple[list[str], list[str]]:
    dof = entry.robot.dof
    home = ", ".join(f"{v:g}" for v in entry.home)

    def fixed_point(x: float, y: float) -> str:
        return f"{{x: {{value: {_mm(x)}, vary: false}}, y: {{value: {_mm(y)}, vary: false}}, z: {{value: 0, vary: false}}}}"

    side = 1430.0 * s
    return [f"sparker{i}: {{link: {i}, x: {_mm(300 * s)}, y: {_mm(150 * s)}, z: {_mm(100 * s)}}}   # on link {i}, its DH frame" for i in range(1, dof + 1)], [
        "device:",
        "  type: sonic_digitizer",
        "  # Stone's GP-8-3D array (specs/puma560_dh.yaml) scaled to the robot: origin at microphone C,",
        "  # y towards B, z out of the sensor plane; D only for the speed-of-sound rods.",
        "  microphones:",
        f"    A: {fixed_point(side, 1440.87 * s)}",
        f"    B: {fixed_point(0, side)}",
        f"    C: {fixed_point(0, 0)}",
        f"    D: {fixed_point(side, 0)}",
        f"  robot_base: {{x: {_mm(1597.32 * s)}, y: {_mm(155.41 * s)}, z: {_mm(694.22 * s)}, rz: -135.0, ry: 25.0, rx: 90.0}}",
        "  speed_of_sound: 344000   # mm/s at 21 degC",
        "  calibration_rods:",
        "    - {length: 1000.0, microphone: B}",
        "    - {length: 1000.0, microphone: D}",
        "  noise: {a: 9.6432e-5, b: 0.03}   # sigma = a * range + b, mm (Stone 7.9)",
        "  resolution: 0.1",
        f"  range_limits: [300, {_mm(max(2500.0, 2500.0 * s))}]",
        "procedure:   # circle-point sweeps (Stone 4.5, 6.4): each joint alone, from the maker's home",
        "  type: circle_point",
        f"  signature: [{home}]",
        f"  targets: [{', '.join(f'sparker{i}' for i in range(1, dof + 1))}]",
        "  points_per_joint: 20",
        "  averaging: 10",
    ]


_LAYOUTS = {"tracker": _tracker, "ballbar": _ballbar, "theodolite": _theodolite, "sonic_digitizer": _sonic}


def default_out(robot: str, device: str) -> Path:
    """``<robot>-<device>.yaml`` in the current folder."""
    return Path(f"{robot}-{device}.yaml")
