"""The warning a spec gets for a target on the axis of the joint it rides on (kinematics/axis_targets.py finds them)."""

from __future__ import annotations

from armcal.support.errors import Issue
from armcal.kinematics.axis_targets import targets_on_axes
from armcal.spec.loader import LoadedSpec, located_issues


def axis_warnings(loaded: LoadedSpec) -> list[Issue]:
    """One located warning per target on its joint's axis (``targets_on_axes``)."""
    return located_issues(loaded, [
        (("robot", "targets", name), f"{distance:.1f} mm from joint {joint}'s axis: the point does not move when joint {joint} turns, "
                                     f"so its readings say nothing of that joint; place it off the axis (docs/devices/tracker.md)")
        for name, joint, distance in targets_on_axes(loaded.spec.robot.chain(), loaded.spec.device.sees_orientation())
    ])
