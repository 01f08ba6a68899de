"""`armcal new`: a commented starting spec for one library robot and one measuring device.

The robot section is the library file's text (its sources kept as comments), followed by the
targets the device needs; the device, procedure, data and simulate sections are laid out for the
robot's size from the reference setups shipped in specs/ (Stone's digitizer, Goswami's ball-bar
fixture, the two-theodolite network), scaled by the robot's size against the PUMA 560's.

Once the spec is written its design is checked as `armcal plan` judges a plan (procedures/pose_selection.py): the
Jacobian of its own calibration poses at the design model, weighted by the instrument's noise, must determine every
free parameter (no unidentifiable direction, nothing held as weakly identifiable, identify/precision.py) with a
condition number below DESIGN_CONDITION, the bound below which a run reports no flat direction. The starting specs are
laid out to pass it (tests/test_new_specs.py); `armcal new` says the figures, and for a spec that does not pass, what
it leaves undetermined and that it needs more poses before anything is measured.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armcal.devices import device_model
from armcal.devices.registry import INSTRUMENTS
from armcal.identify.precision import WEAK
from armcal.kinematics.compiler import compile_robot
from armcal.procedures import Plan, plan
from armcal.procedures.pose_selection import condition_number, information, keyed_plan_candidates
from armcal.robot_library import LibraryRobot
from armcal.spec.loader import spec_from_bytes
from armcal.spec.placeholders import marker_lines

PUMA_SIZE = 885.0  # mm, a2 + a3 + d4 of the PUMA 560 (Stone Table 6-2): the reference setups' robot
DESIGN_CONDITION = 1e3  # the starting design's condition number stays below it: a run reports a direction below 1e-3 of the largest as flat


@dataclass(frozen=True)
class DesignCheck:
    """What the starting spec's calibration poses determine at the design model (module docstring)."""

    poses: int  # distinct robot poses the calibration procedure plans
    base: int  # parameters the poses determine
    condition: float  # of the column-scaled, noise-weighted Jacobian on them
    undetermined: tuple[str, ...]  # unidentifiable directions, parameters held as weakly identifiable or left out

    @property
    def well_posed(self) -> bool:
        return not self.undetermined and self.condition < DESIGN_CONDITION

    def describe(self) -> str:
        told = f"{self.poses} calibration poses determine {self.base} parameters, condition number {self.condition:.0f}"
        if self.well_posed:
            return f"{told} (below {DESIGN_CONDITION:g}), no flat direction"
        missing = f"; not determined: {', '.join(self.undetermined)}" if self.undetermined else ""
        return f"{told} (bound {DESIGN_CONDITION:g}){missing}"


def design_check(text: str, path: Path) -> DesignCheck:
    """`armcal plan`'s information (procedures/pose_selection.information) of the spec ``text``'s own calibration poses,
    planned at the design model as a rehearsal plans them; ``path``: where the spec will stand. Too few poses leave
    parameters out of the base set as if they were redundant: those that the calibration and validation poses together
    determine and the calibration poses alone do not are named too."""
    spec = spec_from_bytes(text.encode(), path).spec
    kinematics, device = compile_robot(spec.robot.chain()), device_model(spec)
    planned = plan(spec.procedure, kinematics, device, spec, path.parent)
    found = information(spec, kinematics, device, keyed_plan_candidates(planned))
    design = found.identifiability
    undetermined = (*design.unidentifiable, *(name for name, reason in design.fixed if reason.startswith(WEAK)))
    if spec.validation is not None:
        both = Plan.join([planned, plan(spec.validation, kinematics, device, spec, path.parent)])
        undetermined += tuple(name for name in information(spec, kinematics, device, keyed_plan_candidates(both)).base if name not in design.base)
    on_robot = np.isfinite(planned.q).all(axis=1)  # a reading of no pose (a scale bar's length) has no joints
    poses = len(np.unique(planned.q[on_robot], axis=0))
    return DesignCheck(poses, len(design.base), condition_number(found.blocks, range(len(planned))), undetermined)


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
