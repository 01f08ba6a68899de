"""The robot's working region for armcal plan --region: the box of one of the certificate's tasks.

  - ``iso_cube``: the ISO 9283 cube (ISO 9283:1998 6.2), where the spec's ``report.iso9283_cube`` puts it, else
    the largest cube the robot reaches near its workspace's centre (procedures/placement.py, as the certificate's
    ISO 9283 task places it);
  - ``grid``: the box of Stone's grid (7.2.1, Table 7-1: 60 x 30 x 50 cm), where the design model reaches it
    there, else scaled and placed in the robot's own workspace (placement.py, as the grid task places it).
The poses in it are procedures/regions.py's.
"""

from __future__ import annotations

import numpy as np

from armcal.support.errors import UserError
from armcal.evaluate.grid import grid_control, grid_unreachable, measured_point
from armcal.kinematics.compiler import KinematicModel
from armcal.kinematics.transforms import compose, rot_y, rot_z
from armcal.procedures.placement import placed, unplaced
from armcal.procedures.regions import Region
from armcal.spec.document import Spec

REGIONS = ("iso_cube", "grid")


def working_region(spec: Spec, kinematics: KinematicModel, name: str, oriented: bool = False) -> Region:
    """The box ``name`` (iso_cube, grid) for the spec's robot (module doc), its poses at the task's orientation
    where ``oriented``; a UserError where it is not reachable."""
    frame, p = measured_point(spec), kinematics.parameters.nominal
    if name == "iso_cube":
        cube = spec.report.iso9283_cube
        if cube is not None:
            centre, side, how = np.array([cube.x, cube.y, cube.z]), cube.side, "the spec's report.iso9283_cube"
            rotation = compose(rot_y(np.pi), rot_z(np.pi / 2))[:3, :3]  # as evaluate/grid.py's ISO 9283 task
        else:
            stands = placed("iso9283", kinematics, p, frame)
            if stands is None:
                raise UserError(f"--region iso_cube: the robot's design model reaches no ISO 9283 cube: {unplaced('iso9283', kinematics, p, frame)}")
            centre, side, how, rotation = stands.centre, stands.size, stands.how, stands.frames[0, :3, :3]
        return Region(name, centre - side / 2, centre + side / 2, frame, how, rotation, oriented)
    if name == "grid":
        solved = grid_control(kinematics, p, frame)
        if solved is None:
            raise UserError(f"--region grid: {grid_unreachable(kinematics, p, frame)}")
        frames = solved[1].frames
        return Region(name, frames[:, :3, 3].min(axis=0), frames[:, :3, 3].max(axis=0), frame, solved[1].how, frames[0, :3, :3], oriented)
    raise UserError(f"--region {name}: choose one of {', '.join(REGIONS)}")
