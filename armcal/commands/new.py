"""`armcal new`: a commented starting spec for one library robot and one measuring device.

The robot section is the library file's text (its sources kept as comments), followed by the
targets the device needs; the device, procedure, data and simulate sections are laid out for the
robot's size from the reference setups shipped in specs/ (Stone's digitizer, Goswami's ball-bar
fixture, the two-theodolite network), scaled by the robot's size against the PUMA 560's.
"""

from __future__ import annotations

import json

from pathlib import Path

from armcal.devices.registry import INSTRUMENTS
from armcal.robot_library import LibraryRobot
from armcal.spec.placeholders import marker_lines

PUMA_SIZE = 885.0  # mm, a2 + a3 + d4 of the PUMA 560 (Stone Table 6-2): the reference setups' robot


def robot_size(entry: LibraryRobot) -> float:
    """The arm's length in mm: the sum of |a| and |d| beyond the first joint, plus its a."""
    joints = entry.robot.joints
    return abs(joints[0].a.value) + sum(abs(j.a.value) + abs(j.d.value) for j in joints[1:])


def new_spec_text(entry: LibraryRobot, device: str, stem: str) -> str:
    """The whole spec for ``entry`` measured by ``device``; its data files are named after ``stem``."""
    s = robot_size(entry) / PUMA_SIZE
    targets, sections = INSTRUMENTS[device].section.starter(entry.robot.dof, entry.home, s)
    validation = "validation:" in (line.split()[0] for line in sections if line.strip())
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
    text = "\n".join(lines) + "\n"
    stand_ins = ["robot.serial", "robot.targets", "device", "procedure", *(["validation"] if validation else [])]
    return text + "\n".join(marker_lines(text, stand_ins)) + "\n"


def _robot_lines(entry: LibraryRobot) -> list[str]:
    """The library file's lines, its home turned into a comment (a spec has no home key)."""
    return [f"# {line}" if line.startswith("home:") else line for line in entry.text.rstrip("\n").splitlines()]




def default_out(robot: str, device: str) -> Path:
    """``<robot>-<device>.yaml`` in the current folder."""
    return Path(f"{robot}-{device}.yaml")
